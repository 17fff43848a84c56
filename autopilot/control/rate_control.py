"""Body-rate PID (PX4's RateControl), output as angular acceleration.

alpha_sp = P e + I integral(e) + D d(-rate)/dt, per FRD axis, in rad/s^2; the
caller turns it into torque with the vehicle's inertia (tau = J alpha), so gains
carry over between airframes.  [Q 3.4]'s clamps: the integrator is
limited to :attr:`RateGains.int_lim_rad_s2` and stops growing on an axis the mixer
reports saturated in the same direction.  NaN inputs never reach the integrator, and neither does a
``dt`` that is not in (0, :data:`MAX_DT_S`] (time going back, or a gap: a restarted simulator, a stall):
that step has no integration and no derivative, which starts again from the sample's rate.

Pure: the gains arrive as a :class:`RateGains` record (from parameters, see
:mod:`autopilot.control.gains_from_params`); no I/O, no clock, ``dt`` is an input.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

Axes3 = tuple[float, float, float]  # roll, pitch, yaw (FRD x, y, z)

_D_CUTOFF_HZ = 30.0
_D_TAU_S = 1.0 / (2 * math.pi * _D_CUTOFF_HZ)  # the derivative filter's time constant, s
MAX_DT_S = 0.02  # the longest step integrated, s (PX4's rate controller limits its dt to 20 ms too)


@dataclass(frozen=True, slots=True)
class RateGains:
    """Gains of the body-rate PID, per axis (roll, pitch, yaw; FRD)."""

    p_per_s: Axes3  # angular acceleration (rad/s^2) per rad/s of rate error
    i_per_s2: Axes3  # integrator growth (rad/s^2 per s) per rad/s of rate error
    d_unitless: Axes3  # angular acceleration (rad/s^2) per rad/s^2 of (filtered) angular acceleration: no unit
    int_lim_rad_s2: Axes3  # integrator clamp
    d_lim_rad_s2: float  # clamp of the derivative term, every axis


class RateControl:
    def __init__(self, gains: RateGains) -> None:
        self.integral = [0.0, 0.0, 0.0]  # rad/s^2
        self.prev_rate: list[float] | None = None
        self.d_filtered = [0.0, 0.0, 0.0]
        self.set_gains(gains)

    def set_gains(self, gains: RateGains) -> None:
        """New gains from the next update on (the integrator keeps its value, clamped by the new limit then)."""
        self.gains = gains
        # One tuple, swapped in one assignment: update() unpacks it once (no per-axis attribute lookups).
        self._k = (gains.p_per_s, gains.i_per_s2, gains.d_unitless, gains.int_lim_rad_s2, gains.d_lim_rad_s2)

    def reset(self) -> None:
        self.integral = [0.0, 0.0, 0.0]
        self.prev_rate = None
        self.d_filtered = [0.0, 0.0, 0.0]

    def update(
        self,
        rate: np.ndarray,
        rate_sp: np.ndarray,
        dt: float,
        sat_pos: np.ndarray | None = None,
        sat_neg: np.ndarray | None = None,
        integrate: bool = True,
    ) -> np.ndarray:
        """Angular acceleration setpoint (rad/s^2, FRD) from the body rate and its setpoint (rad/s, FRD).

        ``sat_pos``/``sat_neg``: per axis, the mixer could not deliver more
        positive / negative torque last step; the integrator does not grow that way.
        """
        rate_f = rate.tolist() if isinstance(rate, np.ndarray) else rate
        sp_f = rate_sp.tolist() if isinstance(rate_sp, np.ndarray) else rate_sp
        return np.array(self.update_floats(rate_f, sp_f, dt, sat_pos, sat_neg, integrate))

    def update_floats(
        self,
        rate: Sequence[float],
        rate_sp: Sequence[float],
        dt: float,
        sat_pos: Sequence[bool] | np.ndarray | None = None,
        sat_neg: Sequence[bool] | np.ndarray | None = None,
        integrate: bool = True,
    ) -> list[float]:
        """:meth:`update` on Python floats (three of each, FRD): runs at the IMU rate, where numpy's per-call
        cost would be most of the work."""
        r0, r1, r2 = rate
        s0, s1, s2 = rate_sp
        err = (s0 - r0, s1 - r1, s2 - r2)
        if not math.isfinite(err[0] + err[1] + err[2]):
            return [0.0, 0.0, 0.0]  # NaN never reaches the integrator
        p, ki, kd, int_lim, lim = self._k
        dt_ok = 0.0 < dt <= MAX_DT_S  # (False for NaN)
        d = self.d_filtered
        prev = self.prev_rate
        if prev is not None and dt_ok:
            a = dt / (dt + _D_TAU_S)
            d[0] += a * (-(r0 - prev[0]) / dt - d[0])
            d[1] += a * (-(r1 - prev[1]) / dt - d[1])
            d[2] += a * (-(r2 - prev[2]) / dt - d[2])
        self.prev_rate = [r0, r1, r2]
        out = [0.0, 0.0, 0.0]
        integral = self.integral
        grow_ok = integrate and dt_ok
        for i in (0, 1, 2):
            d_term = kd[i] * d[i]
            d_term = -lim if d_term < -lim else (lim if d_term > lim else d_term)  # (NaN passes, as min/max)
            out[i] = p[i] * err[i] + integral[i] + d_term
            if grow_ok:
                grow = ki[i] * err[i] * dt
                if (grow > 0 and sat_pos is not None and sat_pos[i]) or (
                    grow < 0 and sat_neg is not None and sat_neg[i]
                ):
                    grow = 0.0
                v, m = integral[i] + grow, int_lim[i]
                integral[i] = -m if v < -m else (m if v > m else v)
        return out
