"""The cubic spline trajectory of [F eq. 3.1], per axis, with start and end velocities.

[F eq. 3.1]: P(t) = P0 + 3 (Pd - P0) t^2/td^2 - 2 (Pd - P0) t^3/td^3 moves from P0 to Pd in
td seconds with zero velocity at both ends.  :class:`CubicSpline` is its Hermite form, which
also takes a start velocity V0 and an end velocity Vd (both zero gives eq. 3.1 exactly), so a
re-planned trajectory can start from the setpoint's current motion.  Positions metres NED,
velocities m/s, accelerations m/s^2, time seconds since the spline's start; after td the
spline holds Pd (moving at Vd from there), before 0 it holds P0.

:func:`duration_s` is the document's td: the horizontal error divided by the mean speed
(1 m/s in [F 3], so td in seconds equals the error in metres), never below a floor.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

MEAN_SPEED_M_S = 1.0  # [F 3]: td equal to the horizontal error in metres, so 1 m/s on average
MIN_DURATION_S = 0.5  # floor of td: a tiny error never asks for an unbounded acceleration


def duration_s(
    horizontal_error_m: float, mean_speed_m_s: float = MEAN_SPEED_M_S, min_s: float = MIN_DURATION_S
) -> float:
    """td of [F 3]: the horizontal error (m) over the mean speed (m/s), at least ``min_s`` (s)."""
    if not math.isfinite(horizontal_error_m) or mean_speed_m_s <= 0:
        return min_s
    return max(abs(horizontal_error_m) / mean_speed_m_s, min_s)


@dataclass(frozen=True, slots=True)
class SplinePoint:
    """The spline at one time: position (m), velocity (m/s), acceleration (m/s^2), NED per axis."""

    pos: np.ndarray
    vel: np.ndarray
    acc: np.ndarray


@dataclass(frozen=True, slots=True)
class CubicSpline:
    """From ``p0``/``v0`` to ``pd``/``vd`` (m, m/s NED, any number of axes) in ``td_s`` seconds."""

    p0: np.ndarray
    pd: np.ndarray
    td_s: float
    v0: np.ndarray | None = None
    vd: np.ndarray | None = None

    def at(self, t_s: float) -> SplinePoint:
        """Position, velocity and acceleration at ``t_s`` seconds since the start (clamped to [0, td])."""
        p0 = np.asarray(self.p0, dtype=float)
        pd = np.asarray(self.pd, dtype=float)
        v0 = np.zeros_like(p0) if self.v0 is None else np.asarray(self.v0, dtype=float)
        vd = np.zeros_like(p0) if self.vd is None else np.asarray(self.vd, dtype=float)
        td = max(float(self.td_s), 1e-9)
        if t_s >= td:
            return SplinePoint(pd + vd * 0.0, vd.copy(), np.zeros_like(p0))
        t = max(float(t_s), 0.0)
        s = t / td
        # Hermite basis on s in [0, 1]; the velocity terms are scaled by td.
        h00, h10, h01, h11 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s, -2 * s**3 + 3 * s**2, s**3 - s**2
        d00, d10, d01, d11 = 6 * s**2 - 6 * s, 3 * s**2 - 4 * s + 1, -6 * s**2 + 6 * s, 3 * s**2 - 2 * s
        a00, a10, a01, a11 = 12 * s - 6, 6 * s - 4, -12 * s + 6, 6 * s - 2
        pos = h00 * p0 + h10 * td * v0 + h01 * pd + h11 * td * vd
        vel = (d00 * p0 + d10 * td * v0 + d01 * pd + d11 * td * vd) / td
        acc = (a00 * p0 + a10 * td * v0 + a01 * pd + a11 * td * vd) / td**2
        return SplinePoint(pos, vel, acc)
