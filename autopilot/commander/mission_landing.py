"""The commander's side of the mission's landing: MAV_CMD_DO_LAND_START and the return types (RTL_TYPE).

:func:`land_start` decides MAV_CMD_DO_LAND_START sent as a command (MAVProxy's ``land``; the commander does
it, ``FlightCommands.land_start``): as PX4's navigator, the mission goes on from its landing sequence
(:func:`autopilot.navigation.rtl_mission.landing_sequence`) in AUTO.MISSION; a vehicle not flying, or a
mission without a landing, is refused with a STATUSTEXT (MAV_RESULT_DENIED: PX4 1.14 answers ACCEPTED and
only warns on its console, later versions CANCELLED).

:func:`return_task` builds the task of AUTO.RTL as RTL_TYPE says (:func:`.rtl_mission.choose_return`):
a direct return (:class:`autopilot.navigation.rtl.ReturnTask`) or the mission runner on a return's own
list of items (the mission landing, the rest of the mission, or the mission backwards), which the
commander steps as a mission (``MissionFlight._step_mission``) without touching the stored mission's
progress.  Each return through the mission comes with the STATUSTEXT saying which.

Frames: NED metres from the estimator origin.
"""

from __future__ import annotations

from dataclasses import dataclass

from autopilot.commander import mission_control
from autopilot.commander.mission_control import Plans
from autopilot.navigation.mission import MissionTask, item_position
from autopilot.navigation.rtl import ReturnTask
from autopilot.navigation.rtl_mission import (
    ReturnKind,
    choose_return,
    closest_item,
    forward_items,
    has_position,
    landing_items,
    landing_sequence,
    reverse_items,
)
from autopilot.parameters import ParameterStore
from autopilot.topics import HomePosition, MissionState, VehicleEstimate
from mavsim_core import mission_items as mi
from mavsim_core.mission_items import MissionItem
from mavsim_core.px4_modes import Mode


@dataclass(frozen=True)
class LandStart:
    """What MAV_CMD_DO_LAND_START asks now: a refusal (its STATUSTEXT), nothing (the landing is flown already), or
    the mission from item ``start`` to its landing at item ``land``."""

    refusal: str | None = None
    already: bool = False
    start: int = 0
    land: int = 0


def land_start(items: list[MissionItem], flying: bool, mode: Mode, task: object) -> LandStart:
    """MAV_CMD_DO_LAND_START with the mission ``items``, the vehicle ``flying`` (armed, in the air) in ``mode``
    with ``task``: what to do (the commander does it: ``FlightCommands.land_start``)."""
    seq = landing_sequence(items)
    if not flying:
        return LandStart("Mission landing denied: vehicle not flying")
    if seq is None:
        return LandStart("Mission landing denied: the mission has no landing (DO_LAND_START, NAV_LAND)")
    start, land = seq
    flown = (
        mode is Mode.AUTO_MISSION
        and isinstance(task, MissionTask)
        and task.follows_plan
        and start <= task.current <= land
    )
    return LandStart(None, flown, start, land)


def return_task(
    plans: Plans, params: ParameterStore, home: HomePosition, mode: Mode, est: VehicleEstimate
) -> tuple[ReturnTask | MissionTask, str | None]:
    """The task of AUTO.RTL for RTL_TYPE (not started), flown from ``mode``, and the STATUSTEXT saying which
    return it is (None: a direct return says nothing)."""
    items = plans.items[mi.MISSION]
    seq = landing_sequence(items)
    rtl_type = int(params.get("RTL_TYPE"))
    landing = None  # a NAV_LAND "here" (lat/lon 0/0) is no place to return to straight, but a mission's end
    if seq is not None and (rtl_type == 2 or has_position(items[seq[1]])):
        landing = item_position(items[seq[1]], est, home)
    kind, point = choose_return(
        rtl_type,
        est.pos_ned_m,
        home.pos_ned_m,
        mission_control.rally_points_ned(plans, home, est),
        landing,
        any(has_position(it) for it in items),
    )
    if kind is ReturnKind.DIRECT:
        return ReturnTask(point, params), None
    assert seq is not None or kind is ReturnKind.MISSION_REVERSE
    in_mission = mode is Mode.AUTO_MISSION and plans.state is MissionState.ACTIVE
    if kind is ReturnKind.MISSION_LANDING:
        assert seq is not None
        return_down = home.pos_ned_m[2] - params.get("RTL_RETURN_ALT")
        climb = est.origin_alt_amsl_m - return_down if est.pos_ned_m[2] > return_down else None
        route = landing_items(items, seq, climb)
        text = f"Return: through the mission landing (items {seq[0]}-{seq[1]})"
    elif kind is ReturnKind.MISSION_FORWARD:
        assert seq is not None
        start = plans.current if in_mission and plans.current <= seq[1] else None
        if start is None:
            start = closest_item(items, est, home, seq[1])
        start = seq[1] if start is None else start
        route = forward_items(items, start, seq[1])
        text = f"Return: along the mission from item {start} to its landing (item {seq[1]})"
    else:
        start = plans.current - 1 if in_mission else None
        if start is None or start < 0:
            start = closest_item(items, est, home, len(items) - 1)
        start = 0 if start is None else start
        route = reverse_items(items, start, home)
        text = f"Return: the mission backwards from item {start}, then home"
    task = MissionTask(route, 0, home, params, {}, on_ground=False)
    task.follows_plan = False
    return task, text
