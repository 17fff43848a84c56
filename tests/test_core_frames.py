"""The one ENU/FLU <-> NED/FRD conversion point (mavsim_core.frames) and SciPy's quaternion order.

No sockets, no processes, no clocks.  (From tests/test_units.py, split by subject.)
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from mavsim_core import frames
from mavsim_core import quaternion as quat


def random_quats(n: int, seed: int = 0) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        q = rng.standard_normal(4)
        out.append(q / np.linalg.norm(q))
    return out


def test_enu_ned_and_flu_frd_vectors():
    assert frames.enu_to_ned(np.array([1.0, 2.0, 3.0])) == pytest.approx([2.0, 1.0, -3.0])  # east 1, north 2, up 3
    assert frames.ned_to_enu(np.array([2.0, 1.0, -3.0])) == pytest.approx([1.0, 2.0, 3.0])
    assert frames.flu_to_frd(np.array([1.0, 2.0, 3.0])) == pytest.approx([1.0, -2.0, -3.0])
    assert frames.frd_to_flu(np.array([1.0, -2.0, -3.0])) == pytest.approx([1.0, 2.0, 3.0])
    v = np.array([0.3, -1.7, 4.2])
    assert frames.ned_to_enu(frames.enu_to_ned(v)) == pytest.approx(v)
    assert frames.frd_to_flu(frames.flu_to_frd(v)) == pytest.approx(v)


def test_mujoco_yawed_90_deg_from_east_faces_north():
    c = math.sqrt(0.5)
    q_enu_flu = np.array([c, 0.0, 0.0, c])  # +90 deg about ENU up: body x from East to North
    q_ned = frames.quat_enu_flu_to_ned_frd(q_enu_flu)
    assert q_ned == pytest.approx([1.0, 0.0, 0.0, 0.0], abs=1e-12)
    assert quat.to_euler(q_ned) == pytest.approx((0.0, 0.0, 0.0), abs=1e-12)
    # MuJoCo's identity faces East: NED yaw +90 deg.
    assert quat.to_euler(frames.quat_enu_flu_to_ned_frd(np.array([1.0, 0.0, 0.0, 0.0]))) == pytest.approx(
        (0.0, 0.0, math.pi / 2)
    )
    # Nose up 10 deg in MuJoCo (negative rotation about FLU y, the left axis) is pitch +10 deg in FRD.
    pitch = math.radians(10)
    q_up = quat.mul(q_enu_flu, np.array([math.cos(-pitch / 2), 0.0, math.sin(-pitch / 2), 0.0]))
    assert quat.to_euler(frames.quat_enu_flu_to_ned_frd(q_up)) == pytest.approx((0.0, pitch, 0.0))


def test_quaternion_conversion_round_trip_and_rotates_vectors_consistently():
    rng = np.random.default_rng(1)
    for q_enu in random_quats(50):
        q_ned = frames.quat_enu_flu_to_ned_frd(q_enu)
        assert np.linalg.norm(q_ned) == pytest.approx(1.0) and q_ned[0] >= 0
        back = frames.quat_ned_frd_to_enu_flu(q_ned)
        assert abs(float(np.dot(back, q_enu))) == pytest.approx(1.0)  # same rotation (q and -q)
        v_flu = rng.standard_normal(3)
        v_enu = quat.to_matrix(q_enu) @ v_flu
        assert quat.to_matrix(q_ned) @ frames.flu_to_frd(v_flu) == pytest.approx(frames.enu_to_ned(v_enu))


def test_wxyz_xyzw_helpers_against_scipy():
    from scipy.spatial.transform import Rotation  # here, not at collection: every xdist worker collects every file

    for q in random_quats(20, seed=2):
        xyzw = frames.wxyz_to_xyzw(q)
        assert xyzw == pytest.approx([q[1], q[2], q[3], q[0]])
        assert frames.xyzw_to_wxyz(xyzw) == pytest.approx(q)
        assert Rotation.from_quat(xyzw).as_matrix() == pytest.approx(quat.to_matrix(q))
        assert Rotation.from_quat(xyzw).as_matrix() == pytest.approx(
            Rotation.from_quat(q, scalar_first=True).as_matrix()
        )
    yaw90 = frames.xyzw_to_wxyz(Rotation.from_euler("z", 90, degrees=True).as_quat())
    assert yaw90 == pytest.approx([math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5)])


# ENU <-> NED swaps x/y and negates z; FLU <-> FRD negates y and z.  Both are their own inverse.
P_NED_ENU = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])
P_FLU_FRD = np.diag([1.0, -1.0, -1.0])


def test_vector_conversions_are_the_fixed_matrices_and_their_own_inverse():
    rng = np.random.default_rng(3)
    for v in rng.standard_normal((100, 3)) * 10:
        assert frames.enu_to_ned(v) == pytest.approx(P_NED_ENU @ v)
        assert frames.ned_to_enu(v) == pytest.approx(P_NED_ENU @ v)
        assert frames.flu_to_frd(v) == pytest.approx(P_FLU_FRD @ v)
        assert frames.enu_to_ned(frames.ned_to_enu(v)) == pytest.approx(v)
        assert frames.flu_to_frd(frames.frd_to_flu(v)) == pytest.approx(v)


def test_attitude_conversion_both_ways_is_the_matrix_product():
    """R_ned_frd = P_ned_enu R_enu_flu P_flu_frd, starting from either side, and back again."""
    for q_enu in random_quats(100, seed=4):
        q_ned = frames.quat_enu_flu_to_ned_frd(q_enu)
        assert quat.to_matrix(q_ned) == pytest.approx(P_NED_ENU @ quat.to_matrix(q_enu) @ P_FLU_FRD, abs=1e-12)
    for q_ned in random_quats(100, seed=5):
        q_enu = frames.quat_ned_frd_to_enu_flu(q_ned)
        assert q_enu[0] >= 0 and np.linalg.norm(q_enu) == pytest.approx(1.0)
        assert quat.to_matrix(q_enu) == pytest.approx(P_NED_ENU @ quat.to_matrix(q_ned) @ P_FLU_FRD, abs=1e-12)
        again = frames.quat_enu_flu_to_ned_frd(q_enu)
        assert abs(float(np.dot(again, q_ned))) == pytest.approx(1.0)


def test_heading_east_of_north_is_90_deg_minus_mujoco_yaw():
    for yaw_enu_deg in (-170.0, -90.0, -30.0, 0.0, 45.0, 90.0, 135.0, 179.0):
        half = math.radians(yaw_enu_deg) / 2
        q_enu = np.array([math.cos(half), 0.0, 0.0, math.sin(half)])  # yaw about ENU up, body level
        roll, pitch, yaw = quat.to_euler(frames.quat_enu_flu_to_ned_frd(q_enu))
        assert (roll, pitch) == pytest.approx((0.0, 0.0), abs=1e-12)
        assert quat.wrap_pi(yaw - math.radians(90.0 - yaw_enu_deg)) == pytest.approx(0.0, abs=1e-12)
