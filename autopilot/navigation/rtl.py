"""Return to launch: climb to RTL_RETURN_ALT, fly home, wait RTL_LAND_DELAY, land.

Phases (:class:`RtlPhase`): CLIMB straight up to the return height (the higher of the
current height and RTL_RETURN_ALT above home), RETURN at that height to above home,
LOITER there for RTL_LAND_DELAY seconds (-1: hold for good, the return is then ``done``),
LAND over home (a direct return; the returns through the mission's landing, RTL_TYPE 1-3:
:mod:`.rtl_mission`).  Each phase is a go-to, a loiter or a land task; the next phase starts
from the previous one's goal when the vehicle has arrived.  Vertical legs fly at 0.7
MPC_Z_VEL_MAX_UP with 1 m/s^2, horizontal ones at MPC_XY_CRUISE with MPC_ACC_HOR; all with MPC_JERK_AUTO.
Positions are metres NED relative to the estimator origin; time is simulated microseconds.
"""

from __future__ import annotations

from enum import Enum

import numpy as np

from autopilot.control import gains_from_params
from autopilot.navigation import goto
from autopilot.navigation.flight_task import PositionSetpoint, defined_in
from autopilot.navigation.goto import GotoTask
from autopilot.navigation.land import LandTask
from autopilot.navigation.loiter import LoiterTask
from autopilot.parameters import ParamDef, ParameterStore, ParamType, param
from autopilot.topics import VehicleEstimate

P_RETURN_ALT = param("RTL_RETURN_ALT", 10.0, 0.0, 150.0, "m", "Return altitude above home for return-to-launch")
P_LAND_DELAY = param(
    "RTL_LAND_DELAY", 0.0, -1.0, 300.0, "s", "Hover time over home before landing (-1: do not land)", ParamType.REAL32
)
P_RTL_TYPE = param(
    "RTL_TYPE", 0, 0, 3, "",
    "Return type: 0 closest of home and rally points; 1 mission landing (or closest rally point), else home;"
    " 2 along the mission to its landing, else the mission backwards to home; 3 closest of home, mission landing"
    " and rally points (autopilot/navigation/rtl_mission.py)",
    ParamType.INT32,
)  # fmt: skip

# The parameters the return reads (listed in autopilot/param_catalogue.py); the go-to's and the
# position controller's are their definitions, not copies.  The LAND phase reads the land's.
PARAMS: tuple[ParamDef, ...] = (
    P_RETURN_ALT,
    P_LAND_DELAY,
    P_RTL_TYPE,
    goto.P_XY_CRUISE,
    goto.P_ACC_HOR,
    defined_in(gains_from_params.POSITION_PARAMS, "MPC_Z_VEL_MAX_UP"),
    defined_in(gains_from_params.POSITION_PARAMS, "MPC_JERK_AUTO"),
)

VERTICAL_SPEED_FRAC = 0.7  # vertical legs fly at this fraction of MPC_Z_VEL_MAX_UP
VERTICAL_ACCEL_M_S2 = 1.0  # acceleration of the vertical legs, m/s^2


class RtlPhase(Enum):
    CLIMB = "climb"
    RETURN = "return"
    LOITER = "loiter"
    LAND = "land"


class ReturnTask:
    """Return to launch over ``home_ned`` (m NED, relative to the estimator origin)."""

    def __init__(self, home_ned: np.ndarray, params: ParameterStore) -> None:
        self.params = params
        self.home = home_ned.astype(float).copy()
        self.phase = RtlPhase.CLIMB

    def activate(self, est: VehicleEstimate, now_us: int) -> None:
        """Start climbing from the estimated position, keeping the heading at ``now_us``."""
        self.yaw_rad = est.yaw_rad
        self.return_down = min(float(est.pos_ned_m[2]), self.home[2] - self.params.get("RTL_RETURN_ALT"))
        self.phase = RtlPhase.CLIMB
        self._start_phase(RtlPhase.CLIMB, now_us, est, est.pos_ned_m)

    def _move(self, start: np.ndarray, goal: np.ndarray) -> GotoTask:
        p = self.params
        if abs(goal[2] - start[2]) > np.linalg.norm(goal[:2] - start[:2]):
            return GotoTask(
                goal,
                self.yaw_rad,
                p.get("MPC_Z_VEL_MAX_UP") * VERTICAL_SPEED_FRAC,
                VERTICAL_ACCEL_M_S2,
                start_ned_m=start,
            )
        return GotoTask(goal, self.yaw_rad, p.get("MPC_XY_CRUISE"), p.get("MPC_ACC_HOR"), start, p.get("MPC_JERK_AUTO"))

    def _start_phase(self, phase: RtlPhase, now_us: int, est: VehicleEstimate, pos: np.ndarray) -> None:
        self.phase = phase
        self.task: GotoTask | LoiterTask | LandTask
        if phase is RtlPhase.CLIMB:
            self.task = self._move(pos, np.array([pos[0], pos[1], self.return_down]))
        elif phase is RtlPhase.RETURN:
            self.task = self._move(pos, np.array([self.home[0], self.home[1], self.return_down]))
        elif phase is RtlPhase.LOITER:
            self.task = LoiterTask(pos, self.yaw_rad)
            self.loiter_until_us = now_us + int(max(self.params.get("RTL_LAND_DELAY"), 0.0) * 1e6)
        else:
            self.task = LandTask(self.home[2], self.params, self.home[:2], self.yaw_rad)
        self.task.activate(est, now_us)

    def shift(self, delta_ned_m: np.ndarray) -> None:
        """Move home, the return height and the phase's points with an estimator reset."""
        self.home += delta_ned_m
        self.return_down += float(delta_ned_m[2])
        self.task.shift(delta_ned_m)

    def update(self, est: VehicleEstimate, now_us: int) -> PositionSetpoint:
        """Advance the phase when the current one has ended, then the phase's setpoint."""
        t = self.task  # (a go-to while climbing and returning)
        if self.phase is RtlPhase.CLIMB and isinstance(t, GotoTask) and t.arrived(now_us, est):
            self._start_phase(RtlPhase.RETURN, now_us, est, t.goal)
        elif self.phase is RtlPhase.RETURN and isinstance(t, GotoTask) and t.arrived(now_us, est):
            self._start_phase(RtlPhase.LOITER, now_us, est, t.goal)
        elif (
            self.phase is RtlPhase.LOITER and now_us >= self.loiter_until_us and self.params.get("RTL_LAND_DELAY") >= 0
        ):
            self._start_phase(RtlPhase.LAND, now_us, est, est.pos_ned_m)
        return self.task.update(est, now_us)

    @property
    def done(self) -> bool:
        """Holding over home for good (RTL_LAND_DELAY -1); with landing, touchdown is the land detector's call."""
        return self.phase is RtlPhase.LOITER and self.params.get("RTL_LAND_DELAY") < 0

    @property
    def failed(self) -> bool:
        return False
