"""Quaternion helpers, (w, x, y, z), on top of MuJoCo's C routines.

A quaternion q here rotates body FRD vectors into NED: v_ned = q * v_frd * q^-1.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np


def mul(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    out = np.empty(4)
    mujoco.mju_mulQuat(out, a, b)
    return out


def conj(q: np.ndarray) -> np.ndarray:
    return np.array([q[0], -q[1], -q[2], -q[3]])


def to_matrix(q: np.ndarray) -> np.ndarray:
    """Rotation matrix (3x3) taking FRD vectors to NED."""
    m = np.empty(9)
    mujoco.mju_quat2Mat(m, q)
    return m.reshape(3, 3)


def from_matrix(r: np.ndarray) -> np.ndarray:
    q = np.empty(4)
    mujoco.mju_mat2Quat(q, np.ascontiguousarray(r, dtype=float).reshape(9))
    return q if q[0] >= 0 else -q


def integrate(q: np.ndarray, rate_frd_rad_s: np.ndarray, dt_s: float) -> np.ndarray:
    """q advanced by a body rate held for dt_s, normalised."""
    out = q.copy()
    mujoco.mju_quatIntegrate(out, np.asarray(rate_frd_rad_s, dtype=float), dt_s)
    return out


def to_euler(q: np.ndarray) -> tuple[float, float, float]:
    """(roll, pitch, yaw) in radians, aerospace ZYX convention."""
    w, x, y, z = q
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return roll, pitch, yaw


def from_euler(roll: float, pitch: float, yaw: float) -> np.ndarray:
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    return np.array([
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    ])


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """3-vector cross product (numpy's np.cross costs ~20x more on 3-vectors)."""
    a0, a1, a2 = float(a[0]), float(a[1]), float(a[2])
    b0, b1, b2 = float(b[0]), float(b[1]), float(b[2])
    return np.array([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0])


def wrap_pi(a: float) -> float:
    return (a + math.pi) % (2 * math.pi) - math.pi
