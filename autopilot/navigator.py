"""Flight tasks: turn the active mode into a position setpoint each step.

Each task is a small class with ``setpoint(now_us, est) -> PositionSetpoint`` and
``done``; positions are NED metres relative to the estimator origin.  Straight
moves follow a trapezoidal speed profile (MPC_XY_CRUISE, MPC_ACC_HOR) so the
setpoint never jumps; the position controller receives the moving point and its
velocity as feed-forward.
"""

from __future__ import annotations

import math
from enum import Enum

import numpy as np

from autopilot.control.position_control import PositionSetpoint
from autopilot.parameters import ParamDef, ParameterStore, ParamType, param
from autopilot.topics import VehicleEstimate


# The parameters this module reads (listed in autopilot/param_catalogue.py).
PARAMS: tuple[ParamDef, ...] = (
    param("MIS_TAKEOFF_ALT", 2.5, 0.0, 100.0, "m", "Take-off altitude above home when none is given"),
    param("MPC_TKO_SPEED", 1.5, 0.5, 5.0, "m/s", "Take-off climb speed"),
    param("MPC_LAND_SPEED", 0.7, 0.2, 2.0, "m/s", "Landing descent speed (final phase)"),
    param("MPC_ACC_DOWN_MAX", 3.0, 2.0, 15.0, "m/s^2",
            "Largest change per second of the descent speed setpoint when landing starts or slows"),
    param("MPC_LAND_ALT1", 5.0, 0.0, 50.0, "m", "Below this height above home, descend at MPC_LAND_SPEED"),
    param("MPC_XY_CRUISE", 3.0, 0.5, 20.0, "m/s", "Horizontal cruise speed of automatic moves"),
    param("MPC_ACC_HOR", 2.0, 0.5, 10.0, "m/s^2", "Horizontal acceleration of automatic moves"),
    param("RTL_RETURN_ALT", 10.0, 0.0, 150.0, "m", "Return altitude above home for return-to-launch"),
    param("RTL_LAND_DELAY", 0.0, -1.0, 300.0, "s", "Hover time over home before landing (-1: do not land)",
            ParamType.REAL32),
)

ARRIVE_RADIUS_M = 0.3


class MoveTask:
    """Straight line from a start to a goal with a trapezoidal speed profile, then hold."""

    def __init__(self, start: np.ndarray, goal: np.ndarray, yaw_rad: float, now_us: int,
                 cruise_m_s: float, accel_m_s2: float) -> None:
        self.start = start.astype(float).copy()
        self.goal = goal.astype(float).copy()
        self.yaw_rad = yaw_rad
        self.t0_us = now_us
        self.length = float(np.linalg.norm(self.goal - self.start))
        self.dir = (self.goal - self.start) / self.length if self.length > 1e-6 else np.zeros(3)
        # Triangle profile when the move is too short to reach cruise speed.
        self.v = min(cruise_m_s, math.sqrt(accel_m_s2 * self.length)) if self.length > 0 else 0.0
        self.a = accel_m_s2
        self.t_acc = self.v / self.a if self.a > 0 else 0.0
        d_acc = 0.5 * self.a * self.t_acc**2
        self.t_cruise = (self.length - 2 * d_acc) / self.v if self.v > 0 else 0.0
        self.duration_s = 2 * self.t_acc + max(self.t_cruise, 0.0)

    def _profile(self, t: float) -> tuple[float, float, float]:
        """Distance along the line, speed and acceleration at time t (s) since the start."""
        if self.v <= 0 or t >= self.duration_s:
            return self.length, 0.0, 0.0
        if t < self.t_acc:
            return 0.5 * self.a * t * t, self.a * t, self.a
        d_acc = 0.5 * self.a * self.t_acc**2
        if t < self.t_acc + self.t_cruise:
            return d_acc + self.v * (t - self.t_acc), self.v, 0.0
        td = t - self.t_acc - self.t_cruise
        return d_acc + self.v * self.t_cruise + self.v * td - 0.5 * self.a * td * td, self.v - self.a * td, -self.a

    def setpoint(self, now_us: int, est: VehicleEstimate) -> PositionSetpoint:
        s, v, a = self._profile((now_us - self.t0_us) * 1e-6)
        return PositionSetpoint(self.start + self.dir * s, self.dir * v, self.yaw_rad, self.dir * a)

    def finished(self, now_us: int) -> bool:
        return (now_us - self.t0_us) * 1e-6 >= self.duration_s

    def arrived(self, now_us: int, est: VehicleEstimate) -> bool:
        return self.finished(now_us) and float(np.linalg.norm(est.pos_ned_m - self.goal)) < ARRIVE_RADIUS_M

    def shift(self, delta_ned_m: np.ndarray) -> None:
        """Move the whole path with an estimator reset, so the vehicle itself does not move."""
        self.start += delta_ned_m
        self.goal += delta_ned_m


class LandTask:
    """Hold north/east, descend at a speed that slows near the ground (velocity control on D).

    Without a horizontal position (GPS lost) north/east are not controlled: the
    horizontal velocity setpoint is zero on the inertial estimate and the height is
    the barometer's (PX4's descend).
    """

    def __init__(self, north_east: np.ndarray, yaw_rad: float, home_down_m: float, params: ParameterStore) -> None:
        self.ne = north_east.astype(float).copy()
        self.yaw_rad = yaw_rad
        self.home_down_m = home_down_m
        self.params = params
        self._speed: float | None = None  # the descent speed setpoint flown, m/s down
        self._last_us: int | None = None

    def setpoint(self, now_us: int, est: VehicleEstimate) -> PositionSetpoint:
        height = self.home_down_m - float(est.pos_ned_m[2])
        slow = self.params.get("MPC_LAND_SPEED")
        want = slow if height < self.params.get("MPC_LAND_ALT1") else max(slow, self.params.get("MPC_Z_VEL_MAX_DN"))
        # Change the speed at most MPC_ACC_DOWN_MAX per second, starting from the vehicle's own: a step
        # of the velocity setpoint would cut the thrust at once (and tilt the vehicle further).
        if self._speed is None:
            vz = float(est.vel_ned_m_s[2])
            self._speed = vz if math.isfinite(vz) else 0.0
        dt = 0.0 if self._last_us is None else max(0.0, (now_us - self._last_us) * 1e-6)
        self._last_us = now_us
        step = self.params.get("MPC_ACC_DOWN_MAX") * dt
        self._speed += min(max(want - self._speed, -step), step)
        speed = self._speed
        if not est.position_valid:
            return PositionSetpoint(np.array([math.nan, math.nan, math.nan]), np.array([0.0, 0.0, speed]), self.yaw_rad)
        return PositionSetpoint(np.array([self.ne[0], self.ne[1], math.nan]), np.array([0.0, 0.0, speed]), self.yaw_rad)

    def shift(self, delta_ned_m: np.ndarray) -> None:
        self.ne += delta_ned_m[:2]
        self.home_down_m += float(delta_ned_m[2])


class RtlPhase(Enum):
    CLIMB = "climb"
    RETURN = "return"
    LOITER = "loiter"
    LAND = "land"


class ReturnTask:
    """Return to launch: climb to RTL_RETURN_ALT, fly home, descend and land."""

    def __init__(self, now_us: int, est: VehicleEstimate, home_ned: np.ndarray, params: ParameterStore) -> None:
        self.params = params
        self.home = home_ned.astype(float).copy()
        self.yaw_rad = est.yaw_rad
        self.return_down = min(float(est.pos_ned_m[2]), self.home[2] - params.get("RTL_RETURN_ALT"))
        self.phase = RtlPhase.CLIMB
        self._start_phase(RtlPhase.CLIMB, now_us, est.pos_ned_m)

    def _move(self, start: np.ndarray, goal: np.ndarray, now_us: int) -> MoveTask:
        p = self.params
        if abs(goal[2] - start[2]) > np.linalg.norm(goal[:2] - start[:2]):
            return MoveTask(start, goal, self.yaw_rad, now_us, p.get("MPC_Z_VEL_MAX_UP") * 0.7, 1.0)
        return MoveTask(start, goal, self.yaw_rad, now_us, p.get("MPC_XY_CRUISE"), p.get("MPC_ACC_HOR"))

    def _start_phase(self, phase: RtlPhase, now_us: int, pos: np.ndarray) -> None:
        self.phase = phase
        if phase is RtlPhase.CLIMB:
            self.task = self._move(pos, np.array([pos[0], pos[1], self.return_down]), now_us)
        elif phase is RtlPhase.RETURN:
            self.task = self._move(pos, np.array([self.home[0], self.home[1], self.return_down]), now_us)
        elif phase is RtlPhase.LOITER:
            self.task = MoveTask(pos, pos, self.yaw_rad, now_us, 1.0, 1.0)
            self.loiter_until_us = now_us + int(max(self.params.get("RTL_LAND_DELAY"), 0.0) * 1e6)
        else:
            self.task = LandTask(self.home[:2], self.yaw_rad, self.home[2], self.params)

    def shift(self, delta_ned_m: np.ndarray) -> None:
        self.home += delta_ned_m
        self.return_down += float(delta_ned_m[2])
        self.task.shift(delta_ned_m)

    def setpoint(self, now_us: int, est: VehicleEstimate) -> PositionSetpoint:
        t = self.task
        if self.phase is RtlPhase.CLIMB and t.arrived(now_us, est):
            self._start_phase(RtlPhase.RETURN, now_us, t.goal)
        elif self.phase is RtlPhase.RETURN and t.arrived(now_us, est):
            self._start_phase(RtlPhase.LOITER, now_us, t.goal)
        elif self.phase is RtlPhase.LOITER and now_us >= self.loiter_until_us and self.params.get("RTL_LAND_DELAY") >= 0:
            self._start_phase(RtlPhase.LAND, now_us, est.pos_ned_m)
        return self.task.setpoint(now_us, est)
