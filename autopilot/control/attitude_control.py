"""Attitude P controller on quaternions (PX4's AttitudeControl, simplified).

Error quaternion q_e = q^-1 q_sp (body FRD); the rate setpoint is
2 sign(w_e) (x_e, y_e, z_e) times the per-axis gains, limited to the per-axis
maximum rates (PX4's MC_ROLL_P ... and MC_*RATE_MAX, mapped by
:mod:`autopilot.control.gains_from_params`).  Rates in rad/s.

Yaw comes after roll and pitch, as in PX4 (MC_YAW_WEIGHT): the setpoint is first split into the
rotation that tilts the vehicle's thrust axis onto the setpoint's (the reduced attitude) and the
heading change about that axis, and only ``yaw_weight`` of the heading change is kept (the yaw gain
divided by it, so that a small heading error is corrected as before).  Without it a large heading
error turns the tilt correction about the thrust axis by half the heading error: at 150 deg the
correction stood 75 deg off the tilt it should undo, the quadcopter rocked 34 deg and lost 2.9 m of
height (issue 36: benchmarks/heading_benchmark.py with the heading stepped).  ``yaw_weight`` 1 is the
plain quaternion error.

Pure: gains arrive as an :class:`AttitudeGains` record; no I/O, no clock.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

Axes3 = tuple[float, float, float]  # roll, pitch, yaw (FRD x, y, z)


@dataclass(frozen=True, slots=True)
class AttitudeGains:
    """Gains of the attitude loop, per axis (roll, pitch, yaw; FRD)."""

    p_per_s: Axes3  # rate setpoint (rad/s) per rad of attitude error
    rate_max_rad_s: Axes3  # limit of the rate setpoint, each way
    yaw_weight: float = 1.0  # the fraction of a heading change kept beside the tilt (PX4's MC_YAW_WEIGHT), 0..1


class AttitudeControl:
    def __init__(self, gains: AttitudeGains) -> None:
        self.set_gains(gains)

    def set_gains(self, gains: AttitudeGains) -> None:
        """New gains from the next update on."""
        self.gains = gains
        # (gain, limit) per axis as one tuple swapped in one assignment: update() reads one attribute.
        (gx, gy, gz), (mx, my, mz) = gains.p_per_s, gains.rate_max_rad_s
        yw = min(max(gains.yaw_weight, 0.0), 1.0)
        self._yaw_w = yw
        self._k = ((gx, mx), (gy, my), (gz / yw if yw > 1e-4 else gz, mz))  # (PX4 divides the yaw gain likewise)

    def update(self, q: np.ndarray, q_sp: np.ndarray) -> np.ndarray:
        """Rate setpoint (rad/s, FRD) that turns attitude q toward q_sp (both (w, x, y, z), FRD -> NED)."""
        return np.array(self.update_floats(q.tolist(), q_sp.tolist()))

    def update_floats(self, q: Sequence[float], q_sp: Sequence[float]) -> tuple[float, float, float]:
        """:meth:`update` on Python floats (q_e = q^-1 q_sp written out): runs at the IMU rate, where numpy's
        per-call cost would be most of the work."""
        w, x, y, z = q
        sw, sx, sy, sz = q_sp if self._yaw_w >= 1.0 else yaw_weighted(q, q_sp, self._yaw_w)
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


def _mul(a: Sequence[float], b: Sequence[float]) -> tuple[float, float, float, float]:
    aw, ax, ay, az = a
    bw, bx, by, bz = b
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


def yaw_weighted(q: Sequence[float], q_sp: Sequence[float], yaw_weight: float) -> tuple[float, float, float, float]:
    """The setpoint ``q_sp`` with only ``yaw_weight`` of its heading change from ``q`` (both (w, x, y, z), FRD ->
    NED): the shortest rotation of the thrust axis onto the setpoint's, applied to ``q`` (the reduced attitude),
    then that fraction of the rotation about the thrust axis that remains to the setpoint.  When the thrust axes
    are nearly opposite the setpoint is returned as it is (PX4 does the same)."""
    w, x, y, z = q
    sw, sx, sy, sz = q_sp
    # body z (thrust axis, down) in NED of each: the third column of its rotation matrix
    ax, ay, az = 2.0 * (x * z + w * y), 2.0 * (y * z - w * x), w * w - x * x - y * y + z * z
    bx, by, bz = 2.0 * (sx * sz + sw * sy), 2.0 * (sy * sz - sw * sx), sw * sw - sx * sx - sy * sy + sz * sz
    cw = 1.0 + ax * bx + ay * by + az * bz  # the shortest arc a -> b: (1 + a.b, a x b), normalised
    cx, cy, cz = ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx
    n = math.sqrt(cw * cw + cx * cx + cy * cy + cz * cz)
    if n == 0.0 or max(abs(cx), abs(cy)) > (1.0 - 1e-5) * n:  # thrust axes (nearly) opposite: no unique tilt
        return sw, sx, sy, sz
    red = _mul((cw / n, cx / n, cy / n, cz / n), q)  # the reduced attitude: q tilted onto the setpoint's axis
    rw, rx, ry, rz = red
    dw, _, _, dz = _mul((rw, -rx, -ry, -rz), q_sp)  # red^-1 q_sp: a rotation about body z (x, y ~ 0)
    half = math.atan2(dz, dw) if dw >= 0.0 else math.atan2(-dz, -dw)  # half the heading change, |.| <= pi/2
    half *= yaw_weight
    return _mul(red, (math.cos(half), 0.0, 0.0, math.sin(half)))


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
