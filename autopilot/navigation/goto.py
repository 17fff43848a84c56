"""Go-to: a jerk-limited move from a start to a goal, then hold.

The setpoint never jumps: the position controller receives the moving point, its velocity and its
acceleration as feed-forward.  The move (:class:`autopilot.navigation.trajectory.Move`) limits the
speed along the way to the cruise speed, the acceleration to ``accel_m_s2`` and the jerk to
``jerk_m_s3`` (MPC_JERK_AUTO), so the acceleration fed forward is continuous and the attitude
setpoint moves smoothly; it ends exactly on the goal with zero velocity and acceleration.  From
rest it is a straight line with an S-shaped speed profile; started from a moving state (a new goal
mid-move: ``start_vel_ned_m_s``, ``start_acc_ned_m_s2``) it bends smoothly onto the new goal.
The heading turns to ``yaw_rad`` the same way, never in a step: from the vehicle's heading and yaw rate at
activation, at most MPC_YAWRAUTO_MAX and MPC_YAWRAUTO_ACC (``heading``;
:class:`autopilot.navigation.heading_smoothing.HeadingSmoothing`), its rate fed forward as the setpoint's
``yaw_rate_rad_s`` (PX4's yawspeed setpoint), so that it stops on the heading instead of overshooting it.
Positions are metres NED relative to the estimator origin; time is simulated microseconds.
"""

from __future__ import annotations

import math

import numpy as np

from autopilot.navigation import heading_smoothing
from autopilot.navigation.flight_task import PositionSetpoint
from autopilot.navigation.heading_smoothing import HeadingLimits, HeadingSmoothing, yaw_rate_of
from autopilot.navigation.trajectory import Limits, Move
from autopilot.parameters import ParamDef, param
from autopilot.topics import VehicleEstimate

P_XY_CRUISE = param("MPC_XY_CRUISE", 5.0, 0.5, 20.0, "m/s", "Horizontal cruise speed of automatic moves")
P_ACC_HOR = param("MPC_ACC_HOR", 4.0, 0.5, 10.0, "m/s^2", "Horizontal acceleration of automatic moves")

# The parameters of automatic moves (listed in autopilot/param_catalogue.py); whoever builds a
# GotoTask reads them (the commander for DO_REPOSITION, the return-to-launch), and MPC_JERK_AUTO
# (declared with the position controller's parameters, which slews its feed-forward with it too);
# the heading's turns: MPC_YAWRAUTO_ACC here, MPC_YAWRAUTO_MAX with the mission runner's.
PARAMS: tuple[ParamDef, ...] = (
    P_XY_CRUISE,
    P_ACC_HOR,
    *heading_smoothing.PARAMS,
)

ARRIVE_RADIUS_M = 0.3  # the move has arrived when its profile has ended and the vehicle is this close
DEFAULT_JERK_M_S3 = 10.0  # the jerk limit when the builder gives none (MPC_JERK_AUTO's default), m/s^3


class GotoTask:
    """A jerk-limited move from a start to a goal, then hold.

    ``start_ned_m`` None starts from the vehicle's position at activation; ``start_vel_ned_m_s`` and
    ``start_acc_ned_m_s2`` (None: at rest) are the state the move starts from (the setpoint of the move it
    replaces).  Limits on the norms: speed ``cruise_m_s`` m/s, acceleration ``accel_m_s2`` m/s^2, jerk
    ``jerk_m_s3`` m/s^3.  ``heading``: how fast the heading turns to ``yaw_rad`` (None: PX4's defaults; the
    builder passes :meth:`HeadingLimits.from_params`).
    """

    def __init__(
        self,
        goal_ned_m: np.ndarray,
        yaw_rad: float,
        cruise_m_s: float,
        accel_m_s2: float,
        start_ned_m: np.ndarray | None = None,
        jerk_m_s3: float = DEFAULT_JERK_M_S3,
        start_vel_ned_m_s: np.ndarray | None = None,
        start_acc_ned_m_s2: np.ndarray | None = None,
        heading: HeadingLimits | None = None,
    ) -> None:
        self.goal = goal_ned_m.astype(float).copy()
        self.yaw_rad = yaw_rad
        self.cruise_m_s = cruise_m_s
        self.accel_m_s2 = accel_m_s2
        self.jerk_m_s3 = jerk_m_s3
        self.start = None if start_ned_m is None else start_ned_m.astype(float).copy()
        self.start_vel = np.zeros(3) if start_vel_ned_m_s is None else np.nan_to_num(start_vel_ned_m_s.astype(float))
        self.start_acc = np.zeros(3) if start_acc_ned_m_s2 is None else np.nan_to_num(start_acc_ned_m_s2.astype(float))
        self._done = False
        self.heading = HeadingSmoothing(heading or HeadingLimits())
        self._last_us = 0

    def activate(self, est: VehicleEstimate, now_us: int) -> None:
        """Plan the move at ``now_us``, from ``start_ned_m`` or else the estimated position."""
        start = est.pos_ned_m if self.start is None else self.start
        self.start = start.astype(float).copy()
        self.t0_us = now_us
        limits = Limits(max(self.cruise_m_s, 1e-3), max(self.accel_m_s2, 1e-3), max(self.jerk_m_s3, 1e-3))
        self.move = Move(self.start, self.start_vel, self.start_acc, self.goal, limits)
        self.duration_s = self.move.duration_s
        self._done = False
        self.heading.reset(est.yaw_rad, yaw_rate_of(est.q_wxyz, est.rate_frd_rad_s))
        self._last_us = now_us

    def update(self, est: VehicleEstimate, now_us: int) -> PositionSetpoint:
        """The point of the move at ``now_us``, with its velocity and acceleration as feed-forward, and the
        heading on its way to ``yaw_rad`` with its rate."""
        self._done = self.arrived(now_us, est)
        pos, vel, acc = self.move.sample((now_us - self.t0_us) * 1e-6)
        h = self.heading
        yaw = h.update(self.yaw_rad, (now_us - self._last_us) * 1e-6)
        self._last_us = now_us
        return PositionSetpoint(pos, vel, yaw, acc, yaw_rate_rad_s=h.rate_rad_s)

    def finished(self, now_us: int) -> bool:
        """The move has ended (the setpoint is the goal)."""
        return (now_us - self.t0_us) * 1e-6 >= self.duration_s

    def arrived(self, now_us: int, est: VehicleEstimate) -> bool:
        """The move has ended and the vehicle is within ARRIVE_RADIUS_M of the goal."""
        if not self.finished(now_us):
            return False
        dn, de, dd = (est.pos_ned_m - self.goal).tolist()  # floats: far cheaper than np.linalg.norm
        return math.sqrt(dn * dn + de * de + dd * dd) < ARRIVE_RADIUS_M

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
        if hasattr(self, "move"):
            self.move.shift(delta_ned_m)  # (shares the goal array's values, not the array)
        self.goal += delta_ned_m
