"""The commander's side of missions, geofence and rally points.

:class:`Plans` holds the three stored plans (mission, fence, rally) the mission protocol
uploads and downloads, checks them (:mod:`autopilot.navigation.mission_checks`, the
geofence's own geometry checks), keeps the mission's progress (current item, DO_JUMP
counters, MISSION_STATE) and saves them with ``--state-dir``.  The functions below are what the
commander calls, with what they need (the plans, the estimate, home, the parameters), never the
commander itself: they return what to say and what to do, and the commander does it
(:mod:`autopilot.commander.mission_flight`): start AUTO.MISSION (:func:`start_mission`), run it
(:func:`advance`: the runner's requests for a return, a precision landing (flown inside AUTO.MISSION,
as PX4 does) or a new home), pause it when another mode takes over, check the geofence every update
(:func:`check_geofence`, GF_ACTION as in PX4: a :class:`FenceAction`) and give the rally points in NED
(:func:`rally_points_ned`) that a return chooses among (:mod:`autopilot.navigation.rtl_mission`, RTL_TYPE).

Frames: NED metres relative to the estimator origin; plans in MAVLink's units (degE7, m).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING, Callable

import numpy as np
from pymavlink.dialects.v20 import common as S

from autopilot.navigation import mission_checks
from autopilot.navigation.geofence import FenceError, Geofence, GfAction, stop_point
from autopilot.navigation.mission import MissionTask, item_position
from autopilot.parameters import ParameterStore
from autopilot.topics import HomePosition, MissionState, MissionStatus, VehicleEstimate
from mavsim_core import mission_items as mi
from mavsim_core.geodesy import geodetic_to_ned
from mavsim_core.mission_items import MissionItem
from mavsim_core.px4_modes import Mode

if TYPE_CHECKING:
    from autopilot.control.position_control import PositionSetpoint

BREACH_REPORT_US = 5_000_000  # a continuing breach is reported again this often
FENCE_MARGIN_M = 1.0  # the predicted stop must stay this far inside the fence ...
FENCE_REACTION_S = 0.5  # ... plus this many seconds of flight at the current speed (controller lag)


class Plans:
    """The stored plans, their checks, the mission's progress and the geofence built from the fence plan."""

    def __init__(self, params: ParameterStore) -> None:
        self.params = params
        self.items: dict[int, list[MissionItem]] = {mi.MISSION: [], mi.FENCE: [], mi.RALLY: []}
        self.current = 0
        self.jumps_left: dict[int, int] = {}
        self.state = MissionState.NO_MISSION
        self.reached: list[int] = []  # MISSION_ITEM_REACHED to send
        self.save: Callable[[dict[int, list[MissionItem]]], None] | None = None  # set with --state-dir
        self.breached = False
        self.breach_said_us = -(2**62)  # when the latest breach was reported
        self._fence: Geofence | None = None
        self._fence_origin: tuple[float, float] | None = None
        self.fence_hold: object | None = None  # the hold task a geofence breach started
        self._status: tuple[tuple, MissionStatus] | None = None  # the record last published and its fields

    def load(self, plans: dict[int, list[MissionItem]]) -> None:
        """Plans saved by an earlier run (already checked when they were uploaded)."""
        for mtype, items in plans.items():
            self.items[mtype] = list(items)
            self._plans_changed(mtype)

    def plan(self, mission_type: int) -> list[MissionItem]:
        return self.items.get(mission_type, [])

    def check_item(self, item: MissionItem, home: HomePosition | None) -> tuple[int, str]:
        ceiling = self.params.get("GF_MAX_VER_DIST") or mission_checks.HARD_CEILING_M
        return mission_checks.check_item(item, None if home is None else home.alt_amsl_m, ceiling)

    def replace(self, mission_type: int, items: list[MissionItem], mission_active: bool) -> tuple[int, str]:
        """Store a plan after its whole-plan checks; refused while a mission that would change is flown."""
        if mission_type == mi.MISSION and mission_active:
            return mi.DENIED, "the mission is being flown: pause it (LOITER) first"
        result = mission_checks.check_plan(mission_type, items)
        if result[0] != mi.ACCEPTED:
            return result
        if mission_type == mi.FENCE and items:
            try:
                Geofence.from_items(items, items[0].lat_deg, items[0].lon_deg)
            except FenceError as exc:
                return mi.INVALID, str(exc)
        self.items[mission_type] = [it.renumbered(k) for k, it in enumerate(items)]
        self._plans_changed(mission_type)
        if self.save is not None:
            self.save(self.items)
        return mi.ACCEPTED, ""

    def _plans_changed(self, mission_type: int) -> None:
        if mission_type == mi.MISSION:
            self.current = 0
            self.jumps_left = {}
            self.state = MissionState.NOT_STARTED if self.items[mi.MISSION] else MissionState.NO_MISSION
        if mission_type == mi.FENCE:
            self._fence = None  # rebuilt from the new plan at the next check
            self.breached = False

    def set_current(self, seq: int, reset_jumps: bool = False) -> tuple[bool, str]:
        total = len(self.items[mi.MISSION])
        if not 0 <= seq < total:
            return False, f"item {seq} does not exist (mission of {total} items)"
        self.current = seq
        if reset_jumps:
            self.jumps_left = {}
        if self.state is MissionState.COMPLETE:
            self.state = MissionState.PAUSED
        return True, ""

    def fence(self, est: VehicleEstimate) -> Geofence:
        """The geofence in this estimate's frame, built once per origin and fence plan (empty without one)."""
        origin = (est.origin_lat_deg, est.origin_lon_deg)
        if self._fence is None or self._fence_origin != origin:
            self._fence = Geofence.from_items(self.items[mi.FENCE], *origin)
            self._fence_origin = origin
        return self._fence

    def status(self, mode: Mode) -> MissionStatus:
        """The mission part of the published status (the previous record again while nothing in it changed)."""
        items = self.items
        key = (self.current, len(items[mi.MISSION]), self.state, mode is Mode.AUTO_MISSION, len(items[mi.FENCE]),
               len(items[mi.RALLY]), self.breached)  # fmt: skip
        last = self._status
        if last is None or last[0] != key:
            last = self._status = (key, MissionStatus(*key))
        return last[1]


# ---------------------------------------------------------------------------------- the mode


Text = tuple[int, str]  # a STATUSTEXT to say: (severity, text)


def start_mission(
    plans: Plans,
    home: HomePosition | None,
    est: VehicleEstimate | None,
    params: ParameterStore,
    in_air: bool,
    now_us: int,
) -> tuple[MissionTask | None, list[Text]]:
    """The runner for AUTO.MISSION from the current item, started (None: refused), and what to say."""  # fmt: skip
    items = plans.items[mi.MISSION]
    if not items:
        return None, [(S.MAV_SEVERITY_CRITICAL, "Mission denied: no mission uploaded")]
    if home is None or est is None:
        return None, [(S.MAV_SEVERITY_CRITICAL, "Mission denied: no home position")]
    if plans.state is MissionState.COMPLETE or plans.current >= len(items):
        plans.current = 0
        plans.jumps_left = {}
    task = MissionTask(items, plans.current, home, params, plans.jumps_left, on_ground=not in_air)
    task.activate(est, now_us)
    plans.state = MissionState.ACTIVE
    texts = [(S.MAV_SEVERITY_INFO, f"Mission: executing from item {plans.current} of {len(items)}")]
    return task, texts + sync(plans, task)


def advance(
    plans: Plans, task: MissionTask, est: VehicleEstimate, now_us: int
) -> tuple[PositionSetpoint | None, list[Text], tuple | None]:
    """One update of the mission runner (or of a return flown through it): its setpoint, what to say of its
    progress, and its request to the commander (None; ("rtl",); ("precland", mode); ("home", item or None))."""
    setpoint = task.update(est, now_us)
    texts = sync(plans, task) if task.follows_plan else []
    request, task.request = task.request, None
    return setpoint, texts, request


def requested_home(item: MissionItem | None, est: VehicleEstimate, home: HomePosition | None) -> np.ndarray:
    """Where a mission's DO_SET_HOME puts home (m NED): the item's position, or here (``item`` None)."""
    return est.pos_ned_m if item is None else item_position(item, est, home)


def sync(plans: Plans, task: MissionTask) -> list[Text]:
    """The runner's progress copied into the stored mission's; what to say of it."""
    plans.current = min(task.current, len(plans.items[mi.MISSION]))
    plans.reached.extend(task.reached)
    texts = [(S.MAV_SEVERITY_INFO, f"Mission: item {seq} reached") for seq in task.reached]
    task.reached.clear()
    if task.complete and plans.state is MissionState.ACTIVE:
        plans.state = MissionState.COMPLETE
        plans.current = len(plans.items[mi.MISSION])
        texts.append((S.MAV_SEVERITY_INFO, "Mission finished" + ("" if task.request else ": holding position")))
    return texts


def on_mode_change(plans: Plans, old: Mode, new: Mode) -> None:
    """A mission that was being flown and is left for another mode is paused (resumes at its item)."""
    if old is Mode.AUTO_MISSION and new is not Mode.AUTO_MISSION and plans.state is MissionState.ACTIVE:
        plans.state = MissionState.PAUSED


def on_landed(plans: Plans) -> list[Text]:
    """Touchdown during a mission's landing: the mission is complete; what to say."""
    if plans.state is not MissionState.ACTIVE:
        return []
    plans.reached.append(plans.current)
    plans.state = MissionState.COMPLETE
    plans.current = len(plans.items[mi.MISSION])
    return [(S.MAV_SEVERITY_INFO, "Mission finished: landed")]


# ---------------------------------------------------------------------------------- geofence and rally


@dataclass(frozen=True)
class FenceAction:
    """What a geofence check asks: a STATUSTEXT, and a hold at ``hold_at`` (m NED) or a mode to enter."""

    text: Text | None = None
    hold_at: np.ndarray | None = None
    enter: Mode | None = None


def check_geofence(
    plans: Plans,
    params: ParameterStore,
    est: VehicleEstimate,
    now_us: int,
    home: HomePosition | None,
    mode: Mode,
    holding: bool,
) -> FenceAction:
    """Predict a breach of the fence, GF_MAX_HOR_DIST or GF_MAX_VER_DIST; what GF_ACTION says to do (``holding``:
    the vehicle already flies the hold a breach started)."""  # fmt: skip
    p = params
    max_hor, max_ver = p.get("GF_MAX_HOR_DIST"), p.get("GF_MAX_VER_DIST")
    if not plans.items[mi.FENCE] and max_hor <= 0 and max_ver <= 0:
        plans.breached = False
        return FenceAction()
    fence = plans.fence(est)
    speed = float(np.linalg.norm(est.vel_ned_m_s[:2]))
    brake = p.get("MPC_ACC_HOR")
    breach = fence.check(
        est.pos_ned_m, est.vel_ned_m_s, None if home is None else home.pos_ned_m, max_hor, max_ver,
        bool(p.get("GF_PREDICT")), brake, margin_m=FENCE_MARGIN_M + FENCE_REACTION_S * speed,
    )  # fmt: skip
    was = plans.breached
    plans.breached = breach is not None
    if breach is None:
        return FenceAction()
    action = GfAction(int(p.get("GF_ACTION")))
    text = None
    if not was or now_us - plans.breach_said_us >= BREACH_REPORT_US:
        plans.breach_said_us = now_us
        text = (S.MAV_SEVERITY_CRITICAL, f"{breach.reason} ({action.name.lower()})")
    if action is GfAction.HOLD and mode not in (Mode.AUTO_LAND, Mode.AUTO_RTL):
        if holding:
            return FenceAction(text)  # already stopping
        # Stop where braking at MPC_ACC_HOR ends (PX4's loiter point for a multicopter), not beyond.
        v = est.vel_ned_m_s.copy()
        v[2] = 0.0
        stop = np.array(stop_point(tuple(est.pos_ned_m), v, brake, 0.0))
        return FenceAction(text, hold_at=stop if fence.inside(stop) else est.pos_ned_m.copy())
    if action is GfAction.RETURN and mode not in (Mode.AUTO_RTL, Mode.AUTO_LAND):
        return FenceAction(text, enter=Mode.AUTO_RTL)
    if action in (GfAction.LAND, GfAction.TERMINATE) and mode is not Mode.AUTO_LAND:
        return FenceAction(text, enter=Mode.AUTO_LAND)  # termination is not simulated: land instead
    return FenceAction(text)


def fence_prearm_failures(plans: Plans, est: VehicleEstimate | None) -> list[str]:
    """Arming is refused outside an inclusion fence (or inside an exclusion)."""
    if est is None or not est.position_valid or not plans.items[mi.FENCE]:
        return []
    fence = plans.fence(est)
    return [] if fence is None or fence.inside(est.pos_ned_m) else ["vehicle outside the geofence"]


def rally_points_ned(plans: Plans, home: HomePosition, est: VehicleEstimate) -> list[np.ndarray]:
    """The rally points (m NED), their ground at home's height (the simulated world is flat)."""
    out = []
    for item in plans.items[mi.RALLY]:
        pos = geodetic_to_ned(item.lat_deg, item.lon_deg, 0.0, est.origin_lat_deg, est.origin_lon_deg, 0.0)
        out.append(np.array([pos[0], pos[1], home.pos_ned_m[2]]))
    return out
