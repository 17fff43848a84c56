"""The commander's flight commands: take-off (and its altitude rules), land, return and reposition.

:class:`FlightCommands` is a base class of :class:`autopilot.commander.commander.Commander`;
its methods are the typed commands the MAVLink command table
(:mod:`autopilot.mavlink.commands`) calls for NAV_TAKEOFF, NAV_LAND, DO_LAND_START,
NAV_RETURN_TO_LAUNCH and DO_REPOSITION.  Each returns a MAV_RESULT, says why in a
STATUSTEXT when it refuses, and (:func:`publishes`) has the commander publish its status
afterwards.  They act through the commander's state (``est``, ``home``, ``armed``,
``mode``, ``task``, ``setpoint``, ``params``, ``now_us``) and its ``say``, ``in_air``
and ``_enter`` (the mode switch, which starts the mode's flight task).

Positions are NED metres from the estimator origin; altitudes AMSL or above home as
named; yaw in radians.
"""

from __future__ import annotations

import functools
from typing import TYPE_CHECKING

import numpy as np
from pymavlink.dialects.v20 import common as mavlink

from autopilot.commander import mission_landing
from autopilot.commander.commander_state import CommanderState
from autopilot.navigation import GotoTask, started
from autopilot.navigation.flight_task import PositionSetpoint
from autopilot.navigation.heading_smoothing import HeadingLimits
from autopilot.navigation.mission_checks import HARD_CEILING_M
from autopilot.navigation.precland import PrecLandMode
from mavsim_core import mission_items as mi
from mavsim_core.geodesy import geodetic_to_ned
from mavsim_core.px4_modes import Mode

if TYPE_CHECKING:
    from autopilot.navigation.flight_task import FlightTask
    from autopilot.navigation.land_detector import LandDetector
    from autopilot.parameters import ParameterStore
    from autopilot.topics import AttitudeSetpoint, VehicleEstimate

S = mavlink  # MAV_RESULT_*, MAV_SEVERITY_* constants


def flown_position_setpoint(setpoint: object) -> PositionSetpoint | None:
    """The setpoint being flown if it is a position setpoint; None for none or an attitude one (a stick mode, the
    descend failsafe, a precision landing's touchdown), which a new goal does not start from."""
    return setpoint if isinstance(setpoint, PositionSetpoint) else None


REPOSITION_MAX_M = 1000.0  # farther reposition targets are refused
MIN_TAKEOFF_M = 1.0  # lower take-off altitudes (above home) are raised to this


def altitude_ceiling(params: ParameterStore) -> tuple[float, str]:
    """The highest altitude above home a command may ask for (m), and its name: GF_MAX_VER_DIST when set (> 0),
    else the hard ceiling of the mission checks (HARD_CEILING_M), as for mission items."""
    limit = params.get("GF_MAX_VER_DIST")
    if limit > 0:
        return limit, f"GF_MAX_VER_DIST ceiling of {limit:g} m"
    return HARD_CEILING_M, f"ceiling of {HARD_CEILING_M:g} m (GF_MAX_VER_DIST 0)"


def above_ceiling(params: ParameterStore, above_home_m: float) -> str | None:
    """Why ``above_home_m`` (m above home) may not be flown to, or None."""
    limit, name = altitude_ceiling(params)
    return f"{above_home_m:g} m above home is over the {name}" if above_home_m > limit else None


def point_ned(
    e: VehicleEstimate, lat_deg: float | None, lon_deg: float | None, alt_amsl_m: float | None, default: np.ndarray
) -> np.ndarray | None:
    """A commanded point in m NED from the estimator origin: latitude/longitude (both None: ``default``'s
    horizontal position), altitude AMSL (None: ``default``'s); None when latitude/longitude are out of range."""
    p = default.astype(float).copy()
    if lat_deg is not None and lon_deg is not None:
        if abs(lat_deg) > 90 or abs(lon_deg) > 180:
            return None
        p[:2] = geodetic_to_ned(lat_deg, lon_deg, 0.0, e.origin_lat_deg, e.origin_lon_deg, 0.0)[:2]
    if alt_amsl_m is not None:
        p[2] = e.origin_alt_amsl_m - alt_amsl_m
    return p


def publishes(method):
    """A command method after which the commander publishes its status, whatever the result."""

    @functools.wraps(method)
    def wrapper(self: FlightCommands, *args, **kwargs) -> int:
        try:
            return method(self, *args, **kwargs)
        finally:
            self._publish()

    return wrapper


class FlightCommands(CommanderState):
    """Take-off, land, return to launch and reposition, as methods of the :class:`Commander`."""

    # Beyond CommanderState's, the commander's state these methods read and set (Commander.__init__ sets it)
    task: FlightTask | None
    precland_mode: PrecLandMode
    setpoint: PositionSetpoint | AttitudeSetpoint | None
    land_detector: LandDetector
    armed_at_us: int
    cruise_override_m_s: float | None = None  # DO_CHANGE_SPEED's speed for later repositions (None: MPC_XY_CRUISE)

    @publishes
    def takeoff(self, rel_alt_m: float | None = None) -> int:
        """Take off to ``rel_alt_m`` above home (None: MIS_TAKEOFF_ALT; at least 1 m)."""
        return self._takeoff(rel_alt_m)

    @publishes
    def land(self, precision: int = 0) -> int:
        """Land where the vehicle is (AUTO.LAND), or on the landing target (AUTO.PRECLAND) with
        ``precision`` = NAV_LAND param 2 as in PX4: 1 opportunistic (an ordinary landing when no target
        is found), 2 required (hold and report).  Armed on the ground the landing is done at once: AUTO.LAND,
        landed now, so the vehicle disarms COM_DISARM_LAND seconds later as after any landing (not after
        COM_DISARM_PRFLT, as an armed vehicle that never took off)."""
        if not self.armed:
            self.say(S.MAV_SEVERITY_CRITICAL, "Land denied: vehicle not armed")
            return S.MAV_RESULT_DENIED
        if not self.in_air:
            self.land_detector.landed_since_us = max(self.now_us, self.armed_at_us + 1)
            self.say(S.MAV_SEVERITY_INFO, "Land: already on the ground")
            return self._enter(Mode.AUTO_LAND)
        if precision in (1, 2):
            self.precland_mode = PrecLandMode(precision)
            return self._enter(Mode.AUTO_PRECLAND)
        return self._enter(Mode.AUTO_LAND)

    @publishes
    def land_start(self) -> int:
        """Fly the mission from its landing sequence (MAV_CMD_DO_LAND_START; :mod:`.mission_landing`)."""
        plan = mission_landing.land_start(self.plans.plan(mi.MISSION), self.armed and self.in_air, self.mode, self.task)
        if plan.refusal is not None:
            self.say(S.MAV_SEVERITY_CRITICAL, plan.refusal)
            return S.MAV_RESULT_DENIED
        if plan.already:
            self.say(S.MAV_SEVERITY_INFO, "Mission landing: already flying it")
            return S.MAV_RESULT_ACCEPTED
        self.plans.set_current(plan.start)
        result = self._start_mission() if self.mode is Mode.AUTO_MISSION else self._enter(Mode.AUTO_MISSION)
        if result == S.MAV_RESULT_ACCEPTED:
            self.say(S.MAV_SEVERITY_INFO, f"Mission landing: from item {plan.start}, landing at item {plan.land}")
        return result

    @publishes
    def set_mission_current(self, seq: int, reset_jumps: bool = False) -> tuple[bool, str]:
        """Make mission item ``seq`` the current one (MISSION_SET_CURRENT, DO_SET_MISSION_CURRENT); a mission
        being flown goes there at once.  ``reset_jumps``: DO_JUMP counters start again.  (done, why not)."""
        done, why = self.plans.set_current(seq, reset_jumps)
        if done and self.mode is Mode.AUTO_MISSION and self.armed:
            self._start_mission()
        return done, why

    @publishes
    def return_to_launch(self) -> int:
        """Return home and land (AUTO.RTL)."""
        if not self.armed:
            self.say(S.MAV_SEVERITY_CRITICAL, "Return denied: vehicle not armed")
            return S.MAV_RESULT_DENIED
        return self._enter(Mode.AUTO_RTL)

    def _takeoff(self, rel_alt_m: float | None) -> int:
        if self.home is None or self.est is None:
            self.say(S.MAV_SEVERITY_CRITICAL, "Takeoff denied: no home position")
            return S.MAV_RESULT_DENIED
        rel = self.params.get("MIS_TAKEOFF_ALT") if rel_alt_m is None else rel_alt_m
        why = "altitude below home" if rel < 0 else above_ceiling(self.params, rel)
        if why is not None:
            self.say(S.MAV_SEVERITY_CRITICAL, f"Takeoff denied: {why}")
            return S.MAV_RESULT_DENIED
        rel = max(rel, MIN_TAKEOFF_M)
        return self._enter(Mode.AUTO_TAKEOFF, self.home.pos_ned_m[2] - rel)

    @publishes
    def reposition(
        self,
        lat_deg: float | None,
        lon_deg: float | None,
        alt_amsl_m: float | None,
        yaw_rad: float | None,
        speed_m_s: float | None,
    ) -> int:
        """Fly to a point and hold there (AUTO.LOITER), along a straight line from the current setpoint.

        None keeps the current value: horizontal position (both lat/lon), altitude AMSL, yaw (radians);
        speed None: DO_CHANGE_SPEED's, else MPC_XY_CRUISE; at most MPC_XY_VEL_MAX.  Refused when not flying,
        without a position estimate, for an impossible latitude/longitude, a target more than REPOSITION_MAX_M
        away or above the ceiling (:func:`altitude_ceiling`).
        """
        e = self.est
        if not (self.armed and self.in_air) or e is None:
            self.say(S.MAV_SEVERITY_CRITICAL, "Reposition denied: vehicle not flying")
            return S.MAV_RESULT_DENIED
        if not e.position_valid:
            self.say(S.MAV_SEVERITY_CRITICAL, "Reposition denied: no position estimate")
            return S.MAV_RESULT_DENIED
        goal = point_ned(e, lat_deg, lon_deg, alt_amsl_m, e.pos_ned_m)
        if goal is None:
            self.say(S.MAV_SEVERITY_CRITICAL, "Reposition denied: latitude/longitude out of range")
            return S.MAV_RESULT_DENIED
        if np.linalg.norm(goal - e.pos_ned_m) > REPOSITION_MAX_M:
            self.say(S.MAV_SEVERITY_CRITICAL, "Reposition denied: target more than 1 km away")
            return S.MAV_RESULT_DENIED
        if self.home is not None and (why := above_ceiling(self.params, self.home.pos_ned_m[2] - goal[2])):
            self.say(S.MAV_SEVERITY_CRITICAL, f"Reposition denied: {why}")
            return S.MAV_RESULT_DENIED
        yaw = e.yaw_rad if yaw_rad is None else yaw_rad
        if speed_m_s is None:
            speed_m_s = self.cruise_override_m_s
        speed = speed_m_s if speed_m_s is not None else self.params.get("MPC_XY_CRUISE")
        if speed > (limit := self.params.get("MPC_XY_VEL_MAX")):
            self.say(S.MAV_SEVERITY_INFO, f"Speed {speed:g} m/s limited to MPC_XY_VEL_MAX")
            speed = limit
        sp = flown_position_setpoint(self.setpoint)
        if sp is not None and np.all(np.isfinite(sp.pos_ned_m)):  # a new goal mid-move: on from the move's state
            start, v0, a0 = sp.pos_ned_m, sp.vel_ned_m_s, sp.acc_ned_m_s2
        else:
            start, v0, a0 = e.pos_ned_m, None, None
        if self.mode is not Mode.AUTO_LOITER:
            self.say(S.MAV_SEVERITY_INFO, "Mode AUTO.LOITER")
        self.mode = Mode.AUTO_LOITER
        turns = HeadingLimits.from_params(self.params)  # the heading turns at MPC_YAWRAUTO_MAX/_ACC, stops on the yaw
        self.task = started(
            GotoTask(
                goal, yaw, speed, self.params.get("MPC_ACC_HOR"), start, self.params.get("MPC_JERK_AUTO"), v0, a0, turns
            ),
            e,
            self.now_us,
        )
        return S.MAV_RESULT_ACCEPTED
