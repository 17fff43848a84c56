"""mavsim_core.quaternion, written out per component without MuJoCo, checked against MuJoCo's C
routines (mju_mulQuat, mju_quat2Mat, mju_mat2Quat, mju_quatIntegrate) on random inputs.

Quaternions are (w, x, y, z), Hamilton product, as in MuJoCo and MAVLink.
"""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from mavsim_core import quaternion as quat

N = 500  # random cases per check


def unit_quats(rng: np.random.Generator, n: int = N) -> np.ndarray:
    q = rng.standard_normal((n, 4))
    return q / np.linalg.norm(q, axis=1, keepdims=True)


def test_mul_matches_mju_mulquat_unit_and_not():
    rng = np.random.default_rng(10)
    for a, b in zip(rng.standard_normal((N, 4)) * 3, rng.standard_normal((N, 4)) * 3):
        expected = np.zeros(4)
        mujoco.mju_mulQuat(expected, a, b)
        assert quat.mul(a, b) == pytest.approx(expected, rel=1e-12, abs=1e-12)
        assert quat.mul(list(a), tuple(b)) == pytest.approx(expected, rel=1e-12, abs=1e-12)  # any 4-sequence


def test_to_matrix_matches_mju_quat2mat():
    rng = np.random.default_rng(11)
    for q in unit_quats(rng):
        expected = np.zeros(9)
        mujoco.mju_quat2Mat(expected, q)
        r = quat.to_matrix(q)
        assert r == pytest.approx(expected.reshape(3, 3), abs=1e-14)
        assert r @ r.T == pytest.approx(np.eye(3), abs=1e-12) and np.linalg.det(r) == pytest.approx(1.0)


def test_from_matrix_matches_mju_mat2quat_up_to_sign():
    """Ours returns w >= 0; MuJoCo may return -q, the same rotation."""
    rng = np.random.default_rng(12)
    qs = unit_quats(rng)
    # rotations by about pi about each axis exercise every branch of Shepperd's method
    qs = np.vstack([qs, [[0.0, 1.0, 0.0, 0.0], [0.0, 0.0, 1.0, 0.0], [0.0, 0.0, 0.0, 1.0], [1e-9, 1.0, 1e-9, 0.0]]])
    for q in qs:
        r = quat.to_matrix(q)
        expected = np.zeros(4)
        mujoco.mju_mat2Quat(expected, r.ravel())
        got = quat.from_matrix(r)
        assert got[0] >= 0.0 and np.linalg.norm(got) == pytest.approx(1.0)
        sign = 1.0 if float(np.dot(got, expected)) >= 0 else -1.0
        assert got == pytest.approx(sign * expected, abs=1e-9)
        assert abs(float(np.dot(got, q / np.linalg.norm(q)))) == pytest.approx(1.0)


def test_integrate_matches_mju_quatintegrate():
    rng = np.random.default_rng(13)
    for q, rate, dt in zip(unit_quats(rng), rng.standard_normal((N, 3)) * 5.0, rng.uniform(1e-4, 0.1, N)):
        expected = q.copy()
        mujoco.mju_quatIntegrate(expected, rate, dt)  # body-frame rate, in place
        assert quat.integrate(q, rate, dt) == pytest.approx(expected, abs=1e-12)
    q = unit_quats(rng, 1)[0]
    assert quat.integrate(q, [0.0, 0.0, 0.0], 0.004) == pytest.approx(q, abs=1e-15)  # no rotation


def test_euler_round_trip_and_axes():
    rng = np.random.default_rng(14)
    for roll, pitch, yaw in zip(
        rng.uniform(-math.pi, math.pi, N), rng.uniform(-1.5, 1.5, N), rng.uniform(-math.pi, math.pi, N)
    ):
        q = quat.from_euler(roll, pitch, yaw)
        assert np.linalg.norm(q) == pytest.approx(1.0)
        assert quat.to_euler(q) == pytest.approx((roll, pitch, yaw), abs=1e-9)
    # yaw +90 deg turns body forward (FRD x) to East (NED y); pitch +30 deg raises the nose (NED -z)
    assert quat.to_matrix(quat.from_euler(0.0, 0.0, math.pi / 2)) @ [1.0, 0.0, 0.0] == pytest.approx([0.0, 1.0, 0.0])
    nose = quat.to_matrix(quat.from_euler(0.0, math.radians(30), 0.0)) @ [1.0, 0.0, 0.0]
    assert nose == pytest.approx([math.cos(math.radians(30)), 0.0, -0.5])


def test_cross_and_wrap_pi():
    rng = np.random.default_rng(15)
    for a, b in zip(rng.standard_normal((N, 3)), rng.standard_normal((N, 3))):
        assert quat.cross(a, b) == pytest.approx(np.cross(a, b), abs=1e-12)
    for a in rng.uniform(-50.0, 50.0, N):
        w = quat.wrap_pi(a)
        assert -math.pi <= w < math.pi
        assert (math.sin(w), math.cos(w)) == pytest.approx((math.sin(a), math.cos(a)), abs=1e-9)


def test_tilt_is_the_angle_of_the_body_z_axis_from_the_vertical():
    assert quat.tilt_rad(0.0, 0.0) == pytest.approx(0.0, abs=1e-12)
    assert quat.tilt_rad(math.radians(10.0), 0.0) == pytest.approx(math.radians(10.0))
    z = quat.to_matrix(quat.from_euler(math.radians(6.0), math.radians(8.0), 0.0))[:, 2]
    assert quat.tilt_rad(math.radians(6.0), math.radians(8.0)) == pytest.approx(math.acos(z[2]))
