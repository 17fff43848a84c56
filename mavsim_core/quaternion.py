"""Quaternion helpers, (w, x, y, z), in plain Python floats (no MuJoCo here).

A quaternion q here rotates body FRD vectors into NED: v_ned = q * v_frd * q^-1
(Hamilton product, the convention of MAVLink and MuJoCo).  The functions take any
4-sequence and return NumPy arrays; they are written out per component because on
4-vectors that is faster than NumPy's general routines.  ``tests/test_core.py``
checks each against MuJoCo's C routines (``mju_mulQuat``, ``mju_quat2Mat``,
``mju_mat2Quat``, ``mju_quatIntegrate``).
"""

from __future__ import annotations

import math
from typing import Sequence

import numpy as np

Quat = Sequence[float] | np.ndarray


def _floats(v: Quat) -> list[float]:
    """The components as Python floats (``tolist`` is the fast way out of a NumPy array)."""
    return v.tolist() if isinstance(v, np.ndarray) else [float(c) for c in v]


def mul(a: Quat, b: Quat) -> np.ndarray:
    """Hamilton product a * b."""
    aw, ax, ay, az = _floats(a)
    bw, bx, by, bz = _floats(b)
    return np.array(
        (
            aw * bw - ax * bx - ay * by - az * bz,
            aw * bx + ax * bw + ay * bz - az * by,
            aw * by - ax * bz + ay * bw + az * bx,
            aw * bz + ax * by - ay * bx + az * bw,
        )
    )


def matrix_floats(w: float, x: float, y: float, z: float) -> tuple[float, ...]:
    """The rotation matrix of :func:`to_matrix` as 9 floats, row by row (for callers working on plain floats)."""
    ww, xx, yy, zz = w * w, x * x, y * y, z * z
    wx, wy, wz, xy, xz, yz = w * x, w * y, w * z, x * y, x * z, y * z
    return (
        ww + xx - yy - zz,
        2.0 * (xy - wz),
        2.0 * (xz + wy),
        2.0 * (xy + wz),
        ww - xx + yy - zz,
        2.0 * (yz - wx),
        2.0 * (xz - wy),
        2.0 * (yz + wx),
        ww - xx - yy + zz,
    )


def to_matrix(q: Quat) -> np.ndarray:
    """Rotation matrix (3x3) taking FRD vectors to NED (q need not be normalised exactly)."""
    w, x, y, z = q.tolist() if type(q) is np.ndarray else _floats(q)
    return np.array(matrix_floats(w, x, y, z)).reshape(3, 3)


def from_matrix(r: np.ndarray) -> np.ndarray:
    """Unit quaternion (w >= 0) of a rotation matrix (Shepperd's method: largest diagonal first)."""
    (m00, m01, m02), (m10, m11, m12), (m20, m21, m22) = np.asarray(r, dtype=float).reshape(3, 3).tolist()
    trace = m00 + m11 + m22
    if trace > 0.0:
        s = 2.0 * math.sqrt(1.0 + trace)
        q = (0.25 * s, (m21 - m12) / s, (m02 - m20) / s, (m10 - m01) / s)
    elif m00 > m11 and m00 > m22:
        s = 2.0 * math.sqrt(1.0 + m00 - m11 - m22)
        q = ((m21 - m12) / s, 0.25 * s, (m01 + m10) / s, (m02 + m20) / s)
    elif m11 > m22:
        s = 2.0 * math.sqrt(1.0 + m11 - m00 - m22)
        q = ((m02 - m20) / s, (m01 + m10) / s, 0.25 * s, (m12 + m21) / s)
    else:
        s = 2.0 * math.sqrt(1.0 + m22 - m00 - m11)
        q = ((m10 - m01) / s, (m02 + m20) / s, (m12 + m21) / s, 0.25 * s)
    n = math.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3])
    if q[0] < 0.0:
        n = -n
    return np.array((q[0] / n, q[1] / n, q[2] / n, q[3] / n))


def integrate_floats(
    qw: float, qx: float, qy: float, qz: float, wx: float, wy: float, wz: float, dt_s: float
) -> tuple[float, float, float, float]:
    """:func:`integrate` on plain floats: q (w, x, y, z) advanced by the FRD rate (wx, wy, wz) rad/s over dt_s."""
    wx, wy, wz = wx * dt_s, wy * dt_s, wz * dt_s
    angle = math.sqrt(wx * wx + wy * wy + wz * wz)
    if angle < 1e-15:
        bw, bx, by, bz = 1.0, 0.0, 0.0, 0.0
    else:
        half = 0.5 * angle
        s = math.sin(half) / angle
        bw, bx, by, bz = math.cos(half), wx * s, wy * s, wz * s
    w = qw * bw - qx * bx - qy * by - qz * bz
    x = qw * bx + qx * bw + qy * bz - qz * by
    y = qw * by - qx * bz + qy * bw + qz * bx
    z = qw * bz + qx * by - qy * bx + qz * bw
    n = 1.0 / math.sqrt(w * w + x * x + y * y + z * z)
    return w * n, x * n, y * n, z * n


def integrate(q: Quat, rate_frd_rad_s: Sequence[float] | np.ndarray, dt_s: float) -> np.ndarray:
    """q advanced by a body (FRD) rate held for dt_s: q * exp(rate dt / 2), normalised."""
    qw, qx, qy, qz = q.tolist() if type(q) is np.ndarray else _floats(q)
    wx, wy, wz = rate_frd_rad_s.tolist() if type(rate_frd_rad_s) is np.ndarray else _floats(rate_frd_rad_s)
    return np.array(integrate_floats(qw, qx, qy, qz, wx, wy, wz, dt_s))


def to_euler(q: Quat) -> tuple[float, float, float]:
    """(roll, pitch, yaw) in radians, aerospace ZYX convention."""
    w, x, y, z = float(q[0]), float(q[1]), float(q[2]), float(q[3])
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    return roll, pitch, yaw_of(q)


def yaw_of(q: Quat) -> float:
    """The yaw (rad) of :func:`to_euler` (aerospace ZYX), alone: without the roll and pitch."""
    w, x, y, z = float(q[0]), float(q[1]), float(q[2]), float(q[3])
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def tilt_rad(roll: float, pitch: float) -> float:
    """The angle between the body's z axis and the vertical (rad) at this roll and pitch (rad)."""
    return math.acos(max(-1.0, min(1.0, math.cos(roll) * math.cos(pitch))))


def from_euler(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Quaternion of aerospace ZYX Euler angles (rad)."""
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return np.array(
        [
            cr * cp * cy + sr * sp * sy,
            sr * cp * cy - cr * sp * sy,
            cr * sp * cy + sr * cp * sy,
            cr * cp * sy - sr * sp * cy,
        ]
    )


def cross(a: Sequence[float] | np.ndarray, b: Sequence[float] | np.ndarray) -> np.ndarray:
    """3-vector cross product (numpy's np.cross costs ~20x more on 3-vectors)."""
    a0, a1, a2 = float(a[0]), float(a[1]), float(a[2])
    b0, b1, b2 = float(b[0]), float(b[1]), float(b[2])
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def wrap_pi(a: float) -> float:
    """Angle wrapped to [-pi, pi) (rad)."""
    return (a + math.pi) % (2 * math.pi) - math.pi
