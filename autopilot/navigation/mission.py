"""The mission runner (AUTO.MISSION): flies a stored mission item by item, as PX4's navigator does.

Navigation items (a position to reach, or a time to wait) become flight actions; the others act
at once and the runner goes on to the next item in the same step:

- NAV_WAYPOINT: a leg (:mod:`.mission_leg`) to the point; reached within the acceptance radius
  (param2, or NAV_ACC_RAD) horizontally and NAV_MC_ALT_RAD vertically; then param1 seconds of
  hold.  Without a hold time and with a waypoint next, the leg ends at the corner speed, so the
  vehicle turns without stopping.  Yaw: param4 in degrees, or (NaN) toward the waypoint, slewed
  at MPC_YAWRAUTO_MAX;
- NAV_TAKEOFF: straight up to its altitude (skipped when already higher); a mission started on
  the ground without one climbs first to the higher of MIS_TAKEOFF_ALT and the first item's altitude;
- NAV_LOITER_UNLIM / NAV_LOITER_TIME (param1 s): fly there and hold (for ever / for the time);
- NAV_DELAY (param1 s): hold where the vehicle is;
- NAV_LAND: fly above the point (none given: here), then land; param2 1/2 asks for a precision landing
  (``request``), which the commander flies as ``precland`` without leaving AUTO.MISSION, as PX4 does;
  NAV_RETURN_TO_LAUNCH hands over to the return (``request``);
- DO_CHANGE_SPEED (param2 m/s, -1 default), DO_JUMP (param1 target, param2 repeats, -1 for ever),
  DO_SET_HOME (param1 1: here, else the position; ``request``), DO_LAND_START (a marker),
  CONDITION_YAW (param1 deg, param4 1 relative: hold position and turn).

After the last item the vehicle holds where it is (``complete``).  Reached items are queued in
``reached`` for MISSION_ITEM_REACHED; ``current`` is the item being flown.  Positions are metres
NED relative to the estimator origin: a relative-altitude item is placed above home, a global one
at its AMSL altitude.  Time is simulated microseconds.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from autopilot.navigation.flight_task import PositionSetpoint
from autopilot.navigation.land import LandTask
from autopilot.navigation.mission_leg import Leg, corner_speed, path_speed
from autopilot.parameters import ParamDef, ParameterStore, param
from autopilot.topics import HomePosition, VehicleEstimate
from mavsim_core import mission_items as mi
from mavsim_core.geodesy import geodetic_to_ned
from mavsim_core.mission_items import MissionItem

P_ACC_RAD = param("NAV_ACC_RAD", 2.0, 0.05, 200.0, "m", "Acceptance radius of mission waypoints (param2 0)")
P_ALT_RAD = param("NAV_MC_ALT_RAD", 0.8, 0.05, 10.0, "m", "Vertical acceptance of mission waypoints (multicopter)")
P_YAW_RATE = param("MPC_YAWRAUTO_MAX", 45.0, 5.0, 360.0, "deg/s", "Yaw rate of automatic modes")

# The runner's own parameters (listed in autopilot/param_catalogue.py); it also reads the go-to's,
# the take-off's and the position controller's speed limits.
PARAMS: tuple[ParamDef, ...] = (P_ACC_RAD, P_ALT_RAD, P_YAW_RATE)

MAX_STEPS_PER_UPDATE = 64  # immediate items (DO_*) handled in one step at most: a DO_JUMP loop cannot hang it
YAW_ACCEPT_RAD = math.radians(3.0)  # CONDITION_YAW is done within this
TAKEOFF_ACCEL_M_S2 = 1.0


def item_position(item: MissionItem, est: VehicleEstimate, home: HomePosition | None) -> np.ndarray:
    """Where a position item is (m NED from the estimator origin); lat/lon 0/0 means here.  A relative altitude is
    above home (above the estimator's origin while there is none: a mission flies only with a home)."""
    if item.x == 0 and item.y == 0:
        pos = est.pos_ned_m.astype(float).copy()
    else:
        pos = geodetic_to_ned(item.lat_deg, item.lon_deg, 0.0, est.origin_lat_deg, est.origin_lon_deg, 0.0)
    if item.frame in mi.RELATIVE_FRAMES:
        pos[2] = (home.pos_ned_m[2] if home is not None else 0.0) - item.z
    else:
        pos[2] = est.origin_alt_amsl_m - item.z
    return pos


def _wrap(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi


class MissionTask:
    """Fly ``items`` from ``start_seq``; ``jumps_left``: DO_JUMP seq -> repeats left (shared with the
    commander, so a paused mission resumes with its counters); ``on_ground``: take off first."""

    def __init__(
        self,
        items: list[MissionItem],
        start_seq: int,
        home: HomePosition,
        params: ParameterStore,
        jumps_left: dict[int, int],
        on_ground: bool = False,
    ) -> None:
        self.items, self.home, self.params = items, home, params
        self.current = start_seq
        self.jumps_left = jumps_left
        self.on_ground = on_ground
        self.reached: list[int] = []
        self.request: tuple | None = None  # ("rtl",) / ("precland", mode) / ("home", pos or None) for the commander
        self.complete = False
        self.cruise = params.get("MPC_XY_CRUISE")
        self.leg: Leg | None = None
        self.hold_until_us: int | None = None  # holding at a reached point until then (None: not holding)
        self.land: LandTask | None = None
        self.yaw_target: float | None = None  # CONDITION_YAW: turning in place
        self.pending: MissionItem | None = None  # the nav item the leg flies to
        self.precland: Any = None  # the precision landing the commander flies for a NAV_LAND param2 1/2
        self.follows_plan = True  # the stored mission's progress (False: a return's own list of items)

    # -- the flight-task interface ---------------------------------------------------------
    def activate(self, est: VehicleEstimate, now_us: int) -> None:
        self.est = est
        self.sp = est.pos_ned_m.astype(float).copy()
        self.yaw = self.yaw_cmd = est.yaw_rad
        self.v_carry = 0.0
        self.last_us = now_us
        first = self.items[self.current] if self.current < len(self.items) else None
        if self.on_ground and (first is None or first.command != mi.NAV_TAKEOFF):
            self._implicit_takeoff(now_us)
        else:
            self._advance(self.current, now_us)

    def update(self, est: VehicleEstimate, now_us: int) -> PositionSetpoint:
        self.est = est
        dt = max((now_us - self.last_us) * 1e-6, 0.0)
        self.last_us = now_us
        if self.land is None:  # once landing, the land task flies to the end
            self._next_if_done(est, now_us)
            self._slew_yaw(dt)
        if self.land is not None:
            return self.land.update(est, now_us)
        if self.leg is not None:
            return self.leg.setpoint(now_us, self.yaw_cmd)
        return PositionSetpoint(self.sp.copy(), np.zeros(3), self.yaw_cmd, np.zeros(3))

    def _next_if_done(self, est: VehicleEstimate, now_us: int) -> None:
        """Go on when the leg has been accepted, the hold has run out or the CONDITION_YAW turn is done."""
        if self.leg is not None and self.leg.finished(now_us) and self._accepted(est):
            self._on_reached(now_us)
        elif self.hold_until_us is not None and now_us >= self.hold_until_us:
            self.hold_until_us = None
            self._advance(self.current + 1, now_us)
        elif self.yaw_target is not None and abs(_wrap(self.yaw_target - self.yaw_cmd)) < YAW_ACCEPT_RAD:
            self.yaw_target = None
            self.reached.append(self.current)
            self._advance(self.current + 1, now_us)

    @property
    def done(self) -> bool:
        return self.complete

    @property
    def failed(self) -> bool:
        return False

    @property
    def landing(self) -> bool:
        return self.land is not None or self.precland is not None

    @property
    def phase(self) -> Any:
        """The precision landing's phase while one is flown (the flight log's), else None."""
        return None if self.precland is None else self.precland.phase

    def shift(self, delta_ned_m: np.ndarray) -> None:
        self.sp += delta_ned_m
        for part in (self.leg, self.land, self.precland):
            if part is not None:
                part.shift(delta_ned_m)

    # -- items -----------------------------------------------------------------------------
    def _advance(self, seq: int, now_us: int) -> None:
        """Go to item ``seq``: run immediate items until one that flies or waits (or the end)."""
        self.leg = self.pending = None
        self.hold_until_us = None
        for _ in range(MAX_STEPS_PER_UPDATE):
            if seq >= len(self.items):
                self.current = len(self.items)
                self.complete = True
                return
            self.current = seq
            item = self.items[seq]
            nxt = self._immediate(item)
            if nxt is None:
                self._start_nav(item, now_us)
                return
            seq = nxt
        self.complete = True  # a jump loop without a navigation item: stop here and hold

    def _immediate(self, item: MissionItem) -> int | None:
        """Run an item that acts at once and return the next seq, or None for an item that flies."""
        c, seq = item.command, item.seq
        if c == mi.DO_CHANGE_SPEED:
            self.cruise = item.param2 if item.param2 > 0 else self.params.get("MPC_XY_CRUISE")
        elif c == mi.DO_JUMP:
            left = self.jumps_left.get(seq, int(item.param2))
            if left != 0:
                self.jumps_left[seq] = left - 1 if left > 0 else -1
                return int(item.param1)
        elif c == mi.DO_SET_HOME:
            self.request = ("home", None if item.param1 == 1 else item)
        elif c == mi.DO_LAND_START:
            pass  # a marker: where a mission landing starts
        else:
            return None
        self.reached.append(seq)
        return seq + 1

    def _start_nav(self, item: MissionItem, now_us: int) -> None:
        c = item.command
        if c == mi.CONDITION_YAW:
            target = math.radians(item.param1)
            self.yaw_target = _wrap(self.yaw_cmd + target * (-1 if item.param3 < 0 else 1) if item.param4 else target)
        elif c == mi.NAV_DELAY:
            self.hold_until_us = now_us + int(max(item.param1, 0.0) * 1e6)
        elif c == mi.NAV_RETURN_TO_LAUNCH:
            self.reached.append(item.seq)
            self.request = ("rtl",)
            self.complete = True
        elif c == mi.NAV_TAKEOFF:
            goal = item_position(item, self.est, self.home)
            goal[:2] = self.sp[:2]
            if self.est.pos_ned_m[2] <= goal[2] + self.params.get("NAV_MC_ALT_RAD"):
                self.reached.append(item.seq)  # already that high
                self._advance(item.seq + 1, now_us)
                return
            self._fly(item, goal, now_us, self.params.get("MPC_TKO_SPEED"))
        elif c == mi.NAV_LAND:
            goal = item_position(item, self.est, self.home)
            goal[2] = self.sp[2]
            if np.linalg.norm(goal[:2] - self.est.pos_ned_m[:2]) > self.params.get("NAV_ACC_RAD"):
                self._fly(item, goal, now_us)
            else:
                self._land(item, now_us)
        else:  # waypoint, loiters
            self._fly(item, item_position(item, self.est, self.home), now_us)

    def _fly(self, item: MissionItem, goal: np.ndarray, now_us: int, speed: float | None = None) -> None:
        """A leg from the setpoint to ``goal``, leaving at the corner speed when a waypoint follows."""
        d = goal - self.sp
        length = float(np.linalg.norm(d))
        direction = d / length if length > 1e-6 else np.zeros(3)
        p = self.params
        cruise = speed if speed is not None else path_speed(
            direction, self.cruise, p.get("MPC_Z_VEL_MAX_UP") * 0.7, p.get("MPC_Z_VEL_MAX_DN") * 0.7
        )  # fmt: skip
        v_out = 0.0
        nxt = self._next_position(item)
        if item.command == mi.NAV_WAYPOINT and item.param1 <= 0 and nxt is not None and length > 1e-6:
            d2 = nxt - goal
            n2 = float(np.linalg.norm(d2))
            if n2 > 1e-6:
                v_out = corner_speed(min(cruise, self.cruise), direction, d2 / n2, p.get("MPC_ACC_HOR"))
        accel = TAKEOFF_ACCEL_M_S2 if item.command == mi.NAV_TAKEOFF else p.get("MPC_ACC_HOR")
        self.leg = Leg(self.sp, goal, self.v_carry, v_out, cruise, accel, now_us, p.get("MPC_JERK_AUTO"))
        self.pending = item
        if math.isfinite(item.param4) and item.command != mi.NAV_LAND:
            self.yaw = math.radians(item.param4)
        elif float(np.linalg.norm(d[:2])) > 1.0:
            self.yaw = math.atan2(d[1], d[0])

    def _next_position(self, item: MissionItem) -> np.ndarray | None:
        """The position of the next waypoint after ``item`` (None if something else comes first)."""
        for it in self.items[item.seq + 1 :]:
            if it.command in (mi.DO_CHANGE_SPEED, mi.DO_LAND_START):
                continue
            if it.command == mi.NAV_WAYPOINT:
                return item_position(it, self.est, self.home)
            return None
        return None

    def _accepted(self, est: VehicleEstimate) -> bool:
        item, leg = self.pending, self.leg
        assert item is not None and leg is not None
        radius = item.param2 if item.command == mi.NAV_WAYPOINT and item.param2 > 0 else self.params.get("NAV_ACC_RAD")
        horizontal = float(np.linalg.norm(est.pos_ned_m[:2] - leg.end[:2]))
        return horizontal <= radius and abs(float(est.pos_ned_m[2] - leg.end[2])) <= self.params.get("NAV_MC_ALT_RAD")

    def _on_reached(self, now_us: int) -> None:
        item, leg = self.pending, self.leg
        assert item is not None and leg is not None
        self.sp = leg.end.copy()
        self.v_carry = leg.v_out
        self.leg = self.pending = None
        if item.command == mi.NAV_LAND:
            self._land(item, now_us)
            return
        if item.seq >= 0:  # not the implicit take-off
            self.reached.append(item.seq)
        wait = {mi.NAV_WAYPOINT: item.param1, mi.NAV_LOITER_TIME: item.param1}.get(item.command, 0.0)
        if item.command == mi.NAV_LOITER_UNLIM:
            self.hold_until_us = 2**62
        elif wait > 0:
            self.hold_until_us = now_us + int(wait * 1e6)
        else:
            self._advance(item.seq + 1, now_us)

    def _land(self, item: MissionItem, now_us: int) -> None:
        self.v_carry = 0.0
        precision = int(item.param2) if math.isfinite(item.param2) else 0
        if precision:
            self.request = ("precland", precision)
            return
        self.land = LandTask(self.home.pos_ned_m[2], self.params, self.sp[:2].copy(), self.yaw_cmd)
        self.land.activate(self.est, now_us)

    def _implicit_takeoff(self, now_us: int) -> None:
        """Climb before a mission started on the ground whose first item is not a take-off."""
        first_nav = next((it for it in self.items[self.current :] if it.command in mi.NAV_COMMANDS), None)
        height = self.params.get("MIS_TAKEOFF_ALT")
        if first_nav is not None and first_nav.command in (mi.NAV_WAYPOINT, mi.NAV_LOITER_TIME, mi.NAV_LOITER_UNLIM):
            height = max(height, self.home.pos_ned_m[2] - item_position(first_nav, self.est, self.home)[2])
        goal = np.array([self.sp[0], self.sp[1], self.home.pos_ned_m[2] - height])
        takeoff = MissionItem(self.current - 1, mi.FRAME_GLOBAL_RELATIVE_ALT, mi.NAV_TAKEOFF, z=height)
        self._fly(takeoff, goal, now_us, self.params.get("MPC_TKO_SPEED"))
        self.pending = takeoff

    def _slew_yaw(self, dt: float) -> None:
        target = self.yaw_target if self.yaw_target is not None else self.yaw
        step = math.radians(self.params.get("MPC_YAWRAUTO_MAX")) * dt
        err = _wrap(target - self.yaw_cmd)
        self.yaw_cmd = _wrap(self.yaw_cmd + max(-step, min(step, err)))
