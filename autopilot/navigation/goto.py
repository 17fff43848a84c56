"""Go-to: a straight move from a start to a goal with a trapezoidal speed profile, then hold.

The setpoint never jumps: the position controller receives the moving point, its
velocity and its acceleration as feed-forward (the position controller slews that
acceleration at MPC_JERK_AUTO).  The profile accelerates at a constant rate to the
cruise speed, cruises, and brakes at the same rate onto the goal; a move too short
to reach the cruise speed follows a triangle profile.  Positions are metres NED
relative to the estimator origin; time is simulated microseconds.
"""

from __future__ import annotations

import math

import numpy as np

from autopilot.navigation.flight_task import PositionSetpoint
from autopilot.parameters import ParamDef, param
from autopilot.topics import VehicleEstimate

P_XY_CRUISE = param("MPC_XY_CRUISE", 3.0, 0.5, 20.0, "m/s", "Horizontal cruise speed of automatic moves")
P_ACC_HOR = param("MPC_ACC_HOR", 2.0, 0.5, 10.0, "m/s^2", "Horizontal acceleration of automatic moves")

# The parameters of automatic moves (listed in autopilot/param_catalogue.py); whoever builds a
# GotoTask reads them (the commander for DO_REPOSITION, the return-to-launch).
PARAMS: tuple[ParamDef, ...] = (
    P_XY_CRUISE,
    P_ACC_HOR,
)

ARRIVE_RADIUS_M = 0.3  # the move has arrived when its profile has ended and the vehicle is this close


class GotoTask:
    """Straight line from a start to a goal with a trapezoidal speed profile, then hold.

    ``start_ned_m`` None starts from the vehicle's position at activation.  Speeds in
    m/s along the line, acceleration in m/s^2 along the line.
    """

    def __init__(
        self,
        goal_ned_m: np.ndarray,
        yaw_rad: float,
        cruise_m_s: float,
        accel_m_s2: float,
        start_ned_m: np.ndarray | None = None,
    ) -> None:
        self.goal = goal_ned_m.astype(float).copy()
        self.yaw_rad = yaw_rad
        self.cruise_m_s = cruise_m_s
        self.accel_m_s2 = accel_m_s2
        self.start = None if start_ned_m is None else start_ned_m.astype(float).copy()
        self._done = False

    def activate(self, est: VehicleEstimate, now_us: int) -> None:
        """Start the profile at ``now_us``, from ``start_ned_m`` or else the estimated position."""
        start = est.pos_ned_m if self.start is None else self.start
        self.start = start.astype(float).copy()
        self.t0_us = now_us
        self.length = float(np.linalg.norm(self.goal - self.start))
        self.dir = (self.goal - self.start) / self.length if self.length > 1e-6 else np.zeros(3)
        # Triangle profile when the move is too short to reach cruise speed.
        self.v = min(self.cruise_m_s, math.sqrt(self.accel_m_s2 * self.length)) if self.length > 0 else 0.0
        self.a = self.accel_m_s2
        self.t_acc = self.v / self.a if self.a > 0 else 0.0
        d_acc = 0.5 * self.a * self.t_acc**2
        self.t_cruise = (self.length - 2 * d_acc) / self.v if self.v > 0 else 0.0
        self.duration_s = 2 * self.t_acc + max(self.t_cruise, 0.0)
        self._done = False

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

    def update(self, est: VehicleEstimate, now_us: int) -> PositionSetpoint:
        """The point of the profile at ``now_us``, with its velocity and acceleration as feed-forward."""
        self._done = self.arrived(now_us, est)
        s, v, a = self._profile((now_us - self.t0_us) * 1e-6)
        return PositionSetpoint(self.start + self.dir * s, self.dir * v, self.yaw_rad, self.dir * a)

    def finished(self, now_us: int) -> bool:
        """The profile has ended (the setpoint is the goal)."""
        return (now_us - self.t0_us) * 1e-6 >= self.duration_s

    def arrived(self, now_us: int, est: VehicleEstimate) -> bool:
        """The profile has ended and the vehicle is within ARRIVE_RADIUS_M of the goal."""
        return self.finished(now_us) and float(np.linalg.norm(est.pos_ned_m - self.goal)) < ARRIVE_RADIUS_M

    @property
    def done(self) -> bool:
        return self._done

    @property
    def failed(self) -> bool:
        return False

    def shift(self, delta_ned_m: np.ndarray) -> None:
        """Move the whole path with an estimator reset, so the vehicle itself does not move."""
        if self.start is not None:
            self.start += delta_ned_m
        self.goal += delta_ned_m
