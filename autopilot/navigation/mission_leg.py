"""One straight leg of a mission: a moving setpoint from a start to an end point, entered and left at speed.

Unlike the go-to (:mod:`.goto`), a leg may start moving (the speed the previous leg ended with)
and end moving (the corner speed of the turn onto the next leg), so that a mission flies its
corners without a full stop.  Its speed profile along the line changes from the entry speed to
the cruise speed, cruises, and brakes to the exit speed, within the acceleration and jerk limits
(PX4's MPC_ACC_HOR, MPC_JERK_AUTO), so the acceleration fed forward has no steps; a leg too short
for that peaks lower.  :func:`corner_speed` chooses the exit speed from the turn angle.

Frames and units: positions metres NED relative to the estimator origin, speeds m/s along the
line, accelerations m/s^2, time simulated microseconds.
"""

from __future__ import annotations

import math

import numpy as np

from autopilot.navigation.flight_task import PositionSetpoint
from autopilot.navigation.goto import DEFAULT_JERK_M_S3
from autopilot.navigation.trajectory import Limits, LineProfile

CORNER_OVERSHOOT_M = 0.3  # how far past a corner the vehicle may swing while it turns onto the next leg


def corner_speed(cruise_m_s: float, dir_in: np.ndarray, dir_out: np.ndarray, accel_m_s2: float = math.inf) -> float:
    """The speed to fly through a corner from unit direction ``dir_in`` onto ``dir_out``: cruise speed
    straight on, falling as cos^2 of half the turn angle to 0 for a reversal, and at most the speed whose
    part across the next leg (v sin(turn)) the vehicle kills at ``accel_m_s2`` within CORNER_OVERSHOOT_M
    (the setpoint turns at once; the vehicle swings out by (v sin(turn))^2 / 2a)."""
    cos_turn = float(np.clip(np.dot(dir_in, dir_out), -1.0, 1.0))
    speed = cruise_m_s * (1.0 + cos_turn) / 2.0
    sin_turn = math.sqrt(max(1.0 - cos_turn * cos_turn, 0.0))
    if sin_turn > 1e-6:
        speed = min(speed, math.sqrt(2.0 * accel_m_s2 * CORNER_OVERSHOOT_M) / sin_turn)
    return speed


def path_speed(direction: np.ndarray, cruise_xy_m_s: float, up_max_m_s: float, down_max_m_s: float) -> float:
    """The speed along a unit ``direction`` (NED) whose horizontal part is at most the cruise speed and
    whose vertical part at most the climb or descent limit."""
    h = float(np.linalg.norm(direction[:2]))
    v = float(direction[2])
    limits = [cruise_xy_m_s / h] if h > 1e-6 else []
    if v < -1e-6:
        limits.append(up_max_m_s / -v)
    elif v > 1e-6:
        limits.append(down_max_m_s / v)
    return min(limits) if limits else cruise_xy_m_s


class Leg:
    """A straight line from ``start`` to ``end`` (m NED) flown from ``v_in`` to ``v_out`` (m/s) at up to
    ``cruise`` with acceleration ``accel`` (m/s^2) and jerk ``jerk`` (m/s^3, PX4's MPC_JERK_AUTO), starting
    at ``t0_us`` (:class:`autopilot.navigation.trajectory.LineProfile`)."""

    def __init__(
        self,
        start: np.ndarray,
        end: np.ndarray,
        v_in: float,
        v_out: float,
        cruise: float,
        accel: float,
        t0_us: int,
        jerk: float = DEFAULT_JERK_M_S3,
    ) -> None:
        self.start = start.astype(float).copy()
        self.end = end.astype(float).copy()
        self.t0_us = t0_us
        d = self.end - self.start
        self.length = float(np.linalg.norm(d))
        self.dir = d / self.length if self.length > 1e-6 else np.zeros(3)
        self.a, self.jerk = max(accel, 1e-3), max(jerk, 1e-3)
        self.line = LineProfile(self.length, v_in, v_out, Limits(max(cruise, 1e-3), self.a, self.jerk))
        self.v_in, self.v_out, self.duration_s = self.line.v_in, self.line.v_out, self.line.duration_s

    def profile(self, t: float) -> tuple[float, float, float]:
        """Distance along the line (m), speed (m/s) and acceleration (m/s^2) at ``t`` s after the start."""
        return self.line.sample(t)

    def finished(self, now_us: int) -> bool:
        return (now_us - self.t0_us) * 1e-6 >= self.duration_s

    def setpoint(self, now_us: int, yaw_rad: float) -> PositionSetpoint:
        """The moving point at ``now_us`` with its velocity and acceleration as feed-forward; past the end it
        stays at the end (with zero velocity if the leg is over and the vehicle has not yet been accepted)."""
        if self.finished(now_us):
            return PositionSetpoint(self.end.copy(), np.zeros(3), yaw_rad, np.zeros(3))
        s, v, acc = self.profile((now_us - self.t0_us) * 1e-6)
        return PositionSetpoint(self.start + self.dir * s, self.dir * v, yaw_rad, self.dir * acc)

    def shift(self, delta_ned_m: np.ndarray) -> None:
        self.start += delta_ned_m
        self.end += delta_ned_m
