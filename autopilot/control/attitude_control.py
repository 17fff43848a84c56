"""Attitude P controller on quaternions (PX4's AttitudeControl, simplified).

Error quaternion q_e = q^-1 q_sp (body FRD); the rate setpoint is
2 sign(w_e) (x_e, y_e, z_e) times the per-axis gains, limited to the per-axis
maximum rates (PX4's MC_ROLL_P ... and MC_*RATE_MAX, mapped by
:mod:`autopilot.control.gains_from_params`).  Rates in rad/s.

Pure: gains arrive as an :class:`AttitudeGains` record; no I/O, no clock.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

Axes3 = tuple[float, float, float]  # roll, pitch, yaw (FRD x, y, z)


@dataclass(frozen=True, slots=True)
class AttitudeGains:
    """Gains of the attitude loop, per axis (roll, pitch, yaw; FRD)."""

    p_per_s: Axes3  # rate setpoint (rad/s) per rad of attitude error
    rate_max_rad_s: Axes3  # limit of the rate setpoint, each way


class AttitudeControl:
    def __init__(self, gains: AttitudeGains) -> None:
        self.set_gains(gains)

    def set_gains(self, gains: AttitudeGains) -> None:
        """New gains from the next update on."""
        self.gains = gains
        # (gain, limit) per axis as one tuple swapped in one assignment: update() reads one attribute.
        (gx, gy, gz), (mx, my, mz) = gains.p_per_s, gains.rate_max_rad_s
        self._k = ((gx, mx), (gy, my), (gz, mz))

    def update(self, q: np.ndarray, q_sp: np.ndarray) -> np.ndarray:
        """Rate setpoint (rad/s, FRD) that turns attitude q toward q_sp (both (w, x, y, z), FRD -> NED)."""
        return np.array(self.update_floats(q.tolist(), q_sp.tolist()))

    def update_floats(self, q: Sequence[float], q_sp: Sequence[float]) -> tuple[float, float, float]:
        """:meth:`update` on Python floats (q_e = q^-1 q_sp written out): runs at the IMU rate, where numpy's
        per-call cost would be most of the work."""
        w, x, y, z = q
        sw, sx, sy, sz = q_sp
        ew = w * sw + x * sx + y * sy + z * sz
        ex = w * sx - x * sw - y * sz + z * sy
        ey = w * sy + x * sz - y * sw - z * sx
        ez = w * sz - x * sy + y * sx - z * sw
        k = 2.0 if ew >= 0 else -2.0
        (gx, mx), (gy, my), (gz, mz) = self._k
        rx, ry, rz = k * ex * gx, k * ey * gy, k * ez * gz
        # Each limited to +-max (NaN passes, as min/max would let it).
        return (
            -mx if rx < -mx else (mx if rx > mx else rx),
            -my if ry < -my else (my if ry > my else ry),
            -mz if rz < -mz else (mz if rz > mz else rz),
        )


def with_yaw_rate(rates_frd: Axes3, q: Sequence[float], yaw_rate_rad_s: float) -> Axes3:
    """Body rates (rad/s, FRD) plus a yaw rate about NED down (PX4's yawspeed setpoint fed forward): NED down in
    FRD is the third row of the attitude's matrix (``q`` (w, x, y, z), FRD -> NED)."""
    w, x, y, z = q
    r = yaw_rate_rad_s
    return (
        rates_frd[0] + 2.0 * (x * z - w * y) * r,
        rates_frd[1] + 2.0 * (y * z + w * x) * r,
        rates_frd[2] + (w * w - x * x - y * y + z * z) * r,
    )
