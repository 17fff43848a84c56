"""One straight leg of a mission: a moving setpoint from a start to an end point, entered and left at speed.

Unlike the go-to (:mod:`.goto`), a leg may start moving (the speed the previous leg ended with)
and end moving (the corner speed of the turn onto the next leg), so that a mission flies its
corners without a full stop.  Its speed profile along the line accelerates from the entry speed
to the cruise speed, cruises, and brakes to the exit speed, all at one acceleration; a leg too
short for that peaks lower.  :func:`corner_speed` chooses the exit speed from the turn angle.

Frames and units: positions metres NED relative to the estimator origin, speeds m/s along the
line, accelerations m/s^2, time simulated microseconds.
"""

from __future__ import annotations

import math

import numpy as np

from autopilot.navigation.flight_task import PositionSetpoint


def corner_speed(cruise_m_s: float, dir_in: np.ndarray, dir_out: np.ndarray) -> float:
    """The speed to fly through a corner from unit direction ``dir_in`` onto ``dir_out``:
    cruise speed straight on, falling as cos^2 of half the turn angle to 0 for a reversal."""
    cos_turn = float(np.clip(np.dot(dir_in, dir_out), -1.0, 1.0))
    return cruise_m_s * (1.0 + cos_turn) / 2.0


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
    ``cruise`` with acceleration ``accel`` (m/s^2), starting at ``t0_us``."""

    def __init__(
        self, start: np.ndarray, end: np.ndarray, v_in: float, v_out: float, cruise: float, accel: float, t0_us: int
    ) -> None:
        self.start = start.astype(float).copy()
        self.end = end.astype(float).copy()
        self.t0_us = t0_us
        d = self.end - self.start
        self.length = float(np.linalg.norm(d))
        self.dir = d / self.length if self.length > 1e-6 else np.zeros(3)
        a = max(accel, 1e-3)
        L = self.length
        v_in = max(0.0, min(v_in, cruise))
        v_out = max(0.0, min(v_out, cruise, math.sqrt(v_in * v_in + 2 * a * L)))
        v_in = min(v_in, math.sqrt(v_out * v_out + 2 * a * L) if L > 0 else v_in)
        peak = min(cruise, math.sqrt(max((2 * a * L + v_in * v_in + v_out * v_out) / 2.0, 0.0)))
        peak = max(peak, v_in, v_out)
        self.v_in, self.v_out, self.peak, self.a = v_in, v_out, peak, a
        self.t_up = (peak - v_in) / a
        self.t_down = (peak - v_out) / a
        d_up = (v_in + peak) / 2 * self.t_up
        d_down = (peak + v_out) / 2 * self.t_down
        self.t_cruise = max(L - d_up - d_down, 0.0) / peak if peak > 1e-6 else 0.0
        self.d_up, self.d_down = d_up, d_down
        self.duration_s = self.t_up + self.t_cruise + self.t_down

    def profile(self, t: float) -> tuple[float, float, float]:
        """Distance along the line (m), speed (m/s) and acceleration (m/s^2) at ``t`` s after the start."""
        if t <= 0:
            return 0.0, self.v_in, 0.0
        a = self.a
        if t < self.t_up:
            return self.v_in * t + 0.5 * a * t * t, self.v_in + a * t, a
        t -= self.t_up
        if t < self.t_cruise:
            return self.d_up + self.peak * t, self.peak, 0.0
        t -= self.t_cruise
        if t < self.t_down:
            s = self.d_up + self.peak * self.t_cruise + self.peak * t - 0.5 * a * t * t
            return min(s, self.length), self.peak - a * t, -a
        return self.length, self.v_out, 0.0

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
