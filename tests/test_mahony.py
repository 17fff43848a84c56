"""The Mahony attitude filter (autopilot.estimation.mahony) on synthetic IMU samples.

No sockets, no processes, no clocks.  (From tests/test_units.py, split by subject.)
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from autopilot.estimation.mahony import MahonyFilter
from mavsim_core import quaternion as quat


def tilt_deg(q: np.ndarray) -> float:
    """Angle between the body z axis and the world z axis."""
    return math.degrees(math.acos(max(-1.0, min(1.0, quat.to_matrix(q)[2, 2]))))


G = 9.80665
FIELD_NED_GAUSS = np.array([0.21, 0.016, 0.43])  # Zurich-like, about 4.4 deg east declination
GYRO_BIAS = np.array([0.01, -0.008, 0.004])


def imu_sample(rng, q_true: np.ndarray, rate_true: np.ndarray):
    r = quat.to_matrix(q_true)
    accel = r.T @ np.array([0.0, 0.0, -G]) + 0.03 * rng.standard_normal(3)  # at rest / constant rate: f = -g
    mag = r.T @ FIELD_NED_GAUSS + 0.003 * rng.standard_normal(3)
    gyro = rate_true + GYRO_BIAS + 0.003 * rng.standard_normal(3)
    return gyro, accel, mag


def yaw_err_deg(q_est: np.ndarray, q_true: np.ndarray) -> float:
    return abs(math.degrees(quat.wrap_pi(quat.to_euler(q_est)[2] - quat.to_euler(q_true)[2])))


def test_mahony_at_rest_converges_to_level_and_true_heading():
    rng = np.random.default_rng(3)
    f = MahonyFilter()
    f.declination_rad = math.atan2(FIELD_NED_GAUSS[1], FIELD_NED_GAUSS[0])
    q_true = quat.from_euler(0.0, 0.0, math.radians(60))
    dt = 0.004
    f.update(*imu_sample(rng, q_true, np.zeros(3)), dt)
    assert f.initialised
    f.q = quat.from_euler(math.radians(20), math.radians(-15), math.radians(100))  # badly off
    for _ in range(int(30 / dt)):  # ATT_MAHONY_KP 0.5: a few time constants of the bias learning
        f.update(*imu_sample(rng, q_true, np.zeros(3)), dt)
    assert tilt_deg(f.q) < 1.0
    assert yaw_err_deg(f.q, q_true) < 2.0
    assert f.gyro_bias[:2] == pytest.approx(GYRO_BIAS[:2], abs=0.003)  # roll/pitch gyro bias learned


def test_mahony_tracks_constant_yaw_rate():
    rng = np.random.default_rng(4)
    f = MahonyFilter()
    f.declination_rad = math.atan2(FIELD_NED_GAUSS[1], FIELD_NED_GAUSS[0])
    w = np.array([0.0, 0.0, 0.5])
    q = np.array([1.0, 0.0, 0.0, 0.0])
    dt = 0.004
    worst = 0.0
    for i in range(int(20 / dt)):
        rate = f.update(*imu_sample(rng, q, w), dt)
        q = quat.integrate(q, w, dt)
        if i * dt > 5.0:
            worst = max(worst, yaw_err_deg(f.q, q))
    assert worst < 3.0  # several full turns, heading error stays small
    assert tilt_deg(f.q) < 1.0
    assert rate[2] == pytest.approx(0.5, abs=0.02)
