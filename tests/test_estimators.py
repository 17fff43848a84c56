"""The EKF and the Mahony filter on synthetic sensor data (no simulator).

A small generator turns a true trajectory (attitude, position, velocity) into the
samples the flight controller receives: IMU with bias and noise, magnetometer from
the World Magnetic Model's field at the origin, barometric pressure, 5 Hz GPS with 120 ms latency.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np
import pytest
from pygeomag import GeoMag

import autopilot.flight_controller  # noqa: F401  (declares every parameter)
from autopilot.estimation.estimator import Estimator
from autopilot.param_catalogue import default_store
from autopilot.topics import GpsSample, ImuSample
from mavsim_core import quaternion as quat

G = 9.80665
LAT0, LON0, ALT0 = 47.397742, 8.545594, 488.0
EARTH_R = 6_378_137.0
_field = GeoMag().calculate(glat=LAT0, glon=LON0, alt=ALT0 / 1000.0, time=2026.9)
MAG_NED_GAUSS = np.array([_field.x, _field.y, _field.z]) / 1e5
GPS_LAG_US = 120_000  # the fixes describe the truth this long before their time stamp (EKF2_GPS_DELAY's default)


def pressure_hpa(alt_m: float) -> float:
    return 1013.25 * (1.0 - 2.25577e-5 * alt_m) ** 5.25588


class Synthetic:
    """Feeds an Estimator from a true state that the test moves."""

    def __init__(
        self,
        est: Estimator,
        seed: int = 0,
        gyro_bias=(0.0, 0.0, 0.0),
        accel_bias=(0.0, 0.0, 0.0),
        gyro_noise=0.003,
        accel_noise=0.03,
        mag_noise=0.003,
        gps_noise=0.1,
    ) -> None:
        self.est = est
        self.rng = np.random.default_rng(seed)
        self.t_us = 0
        self.q = np.array([1.0, 0.0, 0.0, 0.0])
        self.pos = np.zeros(3)
        self.vel = np.zeros(3)
        self.rate = np.zeros(3)  # body FRD rad/s
        self.acc = np.zeros(3)  # NED kinematic m/s^2
        self.gyro_bias = np.array(gyro_bias, dtype=float)
        self.accel_bias = np.array(accel_bias, dtype=float)
        self.gyro_noise, self.accel_noise = gyro_noise, accel_noise
        self.mag_noise, self.gps_noise = mag_noise, gps_noise
        self.gps_offset = np.zeros(3)  # a glitch
        self.gps_on = True
        self.mag_override: np.ndarray | None = None
        self._truth: deque = deque(maxlen=GPS_LAG_US // 4000 + 1)  # (position, velocity) of the last samples

    def run(self, seconds: float) -> None:
        for _ in range(int(round(seconds / 0.004))):
            self.step()

    def step(self) -> None:
        dt = 0.004
        self.t_us += 4000
        self.q = quat.integrate(self.q, self.rate, dt)
        self.pos = self.pos + self.vel * dt + 0.5 * self.acc * dt * dt
        self.vel = self.vel + self.acc * dt
        r = quat.to_matrix(self.q)
        n = self.rng.normal
        f = r.T @ (self.acc - np.array([0.0, 0.0, G])) + self.accel_bias + n(0, self.accel_noise, 3)
        w = self.rate + self.gyro_bias + n(0, self.gyro_noise, 3)
        mag = self.mag_override if self.mag_override is not None else r.T @ MAG_NED_GAUSS + n(0, self.mag_noise, 3)
        imu = ImuSample(self.t_us, f, w, mag, pressure_hpa(ALT0 - self.pos[2] + n(0, 0.05)), 20.0, 0)
        self._truth.append((self.pos.copy(), self.vel.copy()))
        if self.gps_on and self.t_us % 200_000 == 0:
            pos, vel = self._truth[0]  # the truth GPS_LAG_US ago: a receiver's latency, as the simulator's
            p = pos + self.gps_offset + np.array([n(0, self.gps_noise), n(0, self.gps_noise), n(0, 0.2)])
            lat = LAT0 + math.degrees(p[0] / EARTH_R)
            lon = LON0 + math.degrees(p[1] / (EARTH_R * math.cos(math.radians(LAT0))))
            self.est.update_gps(GpsSample(self.t_us, 3, lat, lon, ALT0 - p[2], vel + n(0, 0.05, 3), 0.11, 0.2, 12))
        self.est.update_imu(imu)

    def euler_errors_deg(self) -> tuple[float, float, float]:
        e = quat.to_euler(self.est.q)
        t = quat.to_euler(self.q)
        return tuple(abs(math.degrees(quat.wrap_pi(a - b))) for a, b in zip(e, t))


def make(group: int = 2, **kw) -> Synthetic:
    params = default_store()
    params.set("SYS_MC_EST_GROUP", group)
    return Synthetic(Estimator(params), **kw)


@pytest.mark.parametrize("group", [2, 1], ids=["ekf", "mahony"])
def test_at_rest_converges_to_level_and_true_heading(group):
    s = make(group, gyro_bias=(0.004, -0.003, 0.002))
    s.q = quat.from_euler(math.radians(3.0), math.radians(-2.0), math.radians(40.0))
    s.run(40.0)
    droll, dpitch, dyaw = s.euler_errors_deg()
    # Mahony's gravity reference carries the GPS velocity derivative's noise (0.05 m/s at 5 Hz).
    tilt_tol = 0.2 if group == 2 else 0.35
    assert droll < tilt_tol and dpitch < tilt_tol, (droll, dpitch)
    assert dyaw < 1.0, dyaw
    est = s.est.estimate()
    assert est.attitude_valid and est.position_valid
    assert np.linalg.norm(est.pos_ned_m[:2]) < 0.3


@pytest.mark.parametrize("group", [2, 1], ids=["ekf", "mahony"])
def test_gyro_bias_is_learned(group):
    bias = np.array([0.004, -0.003, 0.002])
    s = make(group, gyro_bias=bias)
    s.run(60.0)
    learned = s.est.ekf.bg if group == 2 else s.est.attitude.gyro_bias
    assert np.all(np.abs(learned - bias) < 0.001), (learned, bias)


def test_ekf_learns_accelerometer_bias_on_the_vertical_axis():
    s = make(2, accel_bias=(0.0, 0.0, 0.15))
    s.run(60.0)
    assert abs(s.est.ekf.ba[2] - 0.15) < 0.03, s.est.ekf.ba
    assert abs(s.est.estimate().pos_ned_m[2]) < 0.15


@pytest.mark.parametrize("group", [2, 1], ids=["ekf", "mahony"])
def test_a_known_rotation_sequence_is_tracked(group):
    s = make(group)
    s.run(20.0)
    worst = 0.0
    # Yaw at 90 deg/s for 2 s, then roll to 20 deg and back, then pitch, standing still.
    for rate, seconds in (
        ((0, 0, math.pi / 2), 2.0),
        ((0.7, 0, 0), 0.5),
        ((-0.7, 0, 0), 0.5),
        ((0, 0.7, 0), 0.5),
        ((0, -0.7, 0), 0.5),
    ):
        s.rate = np.array(rate, dtype=float)
        for _ in range(int(seconds / 0.004)):
            s.step()
            worst = max(worst, *s.euler_errors_deg()[:2])
        s.rate[:] = 0.0
    s.run(2.0)
    droll, dpitch, dyaw = s.euler_errors_deg()
    assert worst < 1.0, worst
    assert dyaw < 2.0, dyaw


def test_ekf_tracks_an_accelerating_vehicle():
    s = make(2)
    s.run(20.0)
    s.acc = np.array([1.0, 0.5, 0.0])
    s.q = quat.from_euler(math.atan(0.5 / G), -math.atan(1.0 / G), 0.0)  # tilted to produce it (approximately)
    s.run(5.0)
    s.acc[:] = 0.0
    s.run(3.0)
    est = s.est.estimate()
    assert np.linalg.norm(est.pos_ned_m - s.pos) < 0.5, (est.pos_ned_m, s.pos)
    assert np.linalg.norm(est.vel_ned_m_s - s.vel) < 0.2, (est.vel_ned_m_s, s.vel)


def test_gps_glitch_is_rejected_then_a_persistent_one_resets_cleanly():
    s = make(2)
    s.run(20.0)
    s.gps_offset = np.array([30.0, 0.0, 0.0])
    s.run(3.0)
    est = s.est.estimate()
    assert np.linalg.norm(est.pos_ned_m[:2] - s.pos[:2]) < 0.5, "a 30 m glitch moved the estimate"
    assert s.est.status().gps_glitch and est.position_valid and est.reset_count == 0
    assert any("GPS position rejected" in text for _, text in s.est.events)
    s.run(6.0)  # persists past the reset time (7 s in all): the filter believes GPS again
    est = s.est.estimate()
    assert est.reset_count == 1
    assert abs(est.reset_delta_ned_m[0] - 30.0) < 1.0, est.reset_delta_ned_m
    assert abs(est.pos_ned_m[0] - (s.pos[0] + 30.0)) < 1.0
    assert not s.est.status().gps_glitch
    assert any("position reset to GPS" in text for _, text in s.est.events)


def test_magnetometer_faults_are_detected_and_stop_heading_fusion():
    s = make(2)
    s.run(20.0)
    s.mag_override = s.est._mag.copy()  # stuck: the same reading again and again
    s.run(2.0)
    assert s.est.mag_fault and "stuck" in s.est.mag_fault_reason
    assert s.est.status().mag_fault
    s.mag_override = None
    s.run(6.0)
    assert not s.est.mag_fault
    s.mag_override = MAG_NED_GAUSS * 3.0  # a strong interference source: the field is three times too strong
    s.run(1.0)
    assert s.est.mag_fault and "field" in s.est.mag_fault_reason
    assert any(text.startswith("EKF:") and "magnetometer" in text for _, text in s.est.events)
    assert s.euler_errors_deg()[2] < 2.0  # heading held on the gyros


def test_arming_checks_wait_for_convergence():
    s = make(2)
    s.run(1.0)
    assert s.est.prearm_failures()
    s.run(30.0)
    assert s.est.prearm_failures() == []


def test_gps_loss_keeps_height_and_invalidates_position():
    s = make(2)
    s.run(20.0)
    s.est.set_in_air(True)
    s.gps_on = False
    s.run(10.0)
    est = s.est.estimate()
    assert not est.position_valid and est.height_valid
    assert abs(est.pos_ned_m[2] - s.pos[2]) < 0.3
    assert np.linalg.norm(est.vel_ned_m_s) < 0.5  # constant-position fusion keeps it from running away


def test_estimator_choice_is_a_live_parameter():
    params = default_store()
    est = Estimator(params)
    assert est.use_ekf
    params.set("SYS_MC_EST_GROUP", 1)
    assert not est.use_ekf
