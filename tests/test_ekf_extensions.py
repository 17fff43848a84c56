"""What issue 21 added to the EKF, on synthetic sensor data (no simulator): bias learning, three-axis
magnetometer fusion, GPS fusion at the receiver's delay, and the guards against NaN and old samples.

The generator is tests/test_estimators.py's: IMU with bias and noise, magnetometer from the World
Magnetic Model's field, barometer, 5 Hz GPS describing the truth 120 ms before its time stamp.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np
import pytest
from test_estimators import G, Synthetic, make

from autopilot.estimation.ekf import ErrorStateEkf
from autopilot.estimation.state_history import state_at
from autopilot.topics import GpsSample, ImuSample


def test_a_constant_gyro_bias_is_learned_within_half_a_milliradian_per_second_in_30_s():
    bias = np.array([0.01, -0.008, 0.005])  # rad/s: twice the simulator's turn-on spread
    s = make(2, gyro_bias=bias)
    s.run(30.0)
    assert np.all(np.abs(s.est.ekf.bg - bias) < 5e-4), (s.est.ekf.bg, bias)


@pytest.mark.parametrize("mag_type", [0, 1], ids=["three-axis", "heading"])
def test_three_axis_magnetometer_fusion_tells_a_horizontal_accelerometer_bias_from_a_tilt(mag_type):
    """At rest with a fixed heading (north), gravity alone cannot tell a horizontal accelerometer bias
    from a tilt (both tip the measured gravity); the magnetometer's field direction can, for a bias
    along magnetic north (here body x: a pitch).  (Across it, a tilt about the field's own axis leaves
    the field unchanged: that one needs a turn or GPS in acceleration.)"""
    bias = np.array([0.08, 0.0, 0.0])  # m/s^2
    s = make(2, accel_bias=bias)
    s.est.params.set("EKF2_MAG_TYPE", mag_type)
    s.run(60.0)
    _, dpitch, _ = s.euler_errors_deg()
    learned = float(s.est.ekf.ba[0])
    if mag_type == 0:
        assert abs(learned - bias[0]) < 0.02, learned
        assert dpitch < 0.1, dpitch
    else:  # heading only: the bias is taken for a tilt of bias/g (0.47 deg)
        assert abs(learned - bias[0]) > 0.05, learned
        assert dpitch > 0.3, dpitch


def _cruise_position_error_m(delay_ms: float) -> float:
    """Horizontal position error (m RMS) flying north at 5 m/s, the GPS 120 ms late, the EKF told
    ``delay_ms``."""
    s = make(2)
    s.est.params.set("EKF2_GPS_DELAY", delay_ms)
    s.run(20.0)
    s.acc = np.array([1.0, 0.0, 0.0])
    s.run(5.0)
    s.acc[:] = 0.0
    errors = []
    for _ in range(10):
        s.run(1.0)
        errors.append(float(np.linalg.norm(s.est.estimate().pos_ned_m[:2] - s.pos[:2])))
    return math.sqrt(float(np.mean(np.square(errors))))


def test_a_delayed_gps_fix_is_fused_at_the_time_it_describes():
    at_its_time = _cruise_position_error_m(120.0)
    as_if_current = _cruise_position_error_m(0.0)
    assert at_its_time < 0.15, at_its_time  # (the generator's samples describe the end of their period)
    assert as_if_current > 4 * at_its_time, (as_if_current, at_its_time)  # 0.12 s x 5 m/s of lag


def test_the_delayed_state_is_interpolated_between_filter_runs():
    history = deque([(0, np.zeros(3), np.zeros(3)), (20_000, np.full(3, 2.0), np.full(3, 1.0))])
    pos, vel = state_at(history, 5_000)
    assert np.allclose(pos, 0.5) and np.allclose(vel, 0.25)
    assert state_at(history, -50_000)[0] is not None  # just before the oldest: the oldest
    assert state_at(history, -70_000) == (None, None)  # too old
    assert state_at(deque(), 0) == (None, None)


def test_a_fix_older_than_the_filters_history_is_not_fused():
    s = make(2)
    s.run(20.0)
    gps = s.est.gps
    before = s.est.ekf.p.copy()
    old = GpsSample(s.t_us - 2_000_000, 3, 47.4, 8.55, 600.0, np.zeros(3), 0.11, 0.2, 12)  # far from here
    s.est.update_gps(old)
    assert gps.old_fixes == 1
    assert np.allclose(s.est.ekf.p, before), "an old fix moved the estimate"
    assert not s.est.gps.glitch


def test_nan_in_a_gps_fix_or_an_imu_sample_never_reaches_the_filter():
    s = make(2)
    s.run(20.0)
    e = s.est
    for fix in (
        GpsSample(s.t_us, 3, math.nan, 8.545594, 488.0, np.zeros(3), 0.11, 0.2, 12),
        GpsSample(s.t_us, 3, 47.397742, 8.545594, 488.0, np.array([0.0, math.nan, 0.0]), 0.11, 0.2, 12),
    ):
        e.update_gps(fix)
    for bad in (
        ImuSample(s.t_us + 4000, np.array([math.nan, 0.0, -G]), np.zeros(3), np.zeros(3), 955.0, 20.0, 0),
        ImuSample(s.t_us + 8000, np.array([0.0, 0.0, -G]), np.array([0.0, math.inf, 0.0]), np.zeros(3), 955.0, 20, 0),
    ):
        e.update_imu(bad)
    s.t_us += 8000
    s.run(1.0)
    assert np.all(np.isfinite(e.ekf.p)) and np.all(np.isfinite(e.ekf.v)) and np.all(np.isfinite(e.ekf.q))
    assert np.all(np.isfinite(e.ekf.cov))
    assert e.estimate().position_valid


def test_a_sample_whose_time_stamp_goes_back_is_not_integrated():
    s = make(2)
    s.run(10.0)
    q = s.est.q.copy()
    s.est.update_imu(
        ImuSample(s.t_us - 4000, np.array([0.0, 0.0, -G]), np.array([5.0, 0, 0]), np.zeros(3), 955.0, 20, 0)
    )
    assert np.allclose(s.est.q, q)


def test_an_inertial_solution_gone_wrong_is_reset_to_gps_and_recovers():
    """A sudden 6 deg attitude error (a gyro that missed a rotation) while accelerating: GPS velocity
    keeps failing its gate, so after a second velocity and position are reset to GPS and the tilt
    uncertainty widened; the filter then follows GPS again instead of rejecting it for good."""
    s: Synthetic = make(2)
    s.run(20.0)
    s.acc = np.array([1.0, 0.5, 0.0])
    s.q = np.array([0.99863, 0.0254, -0.0455, 0.0])  # about 3 deg roll, -5 deg pitch, not seen by the gyro
    s.q /= np.linalg.norm(s.q)
    s.run(5.0)
    assert any("velocity reset to GPS" in text for _, text in s.est.events)
    s.run(3.0)
    est = s.est.estimate()
    assert np.linalg.norm(est.vel_ned_m_s - s.vel) < 0.2, (est.vel_ned_m_s, s.vel)
    assert np.linalg.norm(est.pos_ned_m - s.pos) < 0.5, (est.pos_ned_m, s.pos)


def test_reset_velocity_widens_only_the_tilt_and_moves_the_history_with_it():
    ekf = ErrorStateEkf()
    ekf.initialise(np.array([1.0, 0.0, 0.0, 0.0]))
    ekf.history.append((0, np.zeros(3), np.array([1.0, 0.0, 0.0])))
    yaw_var = ekf.cov[8, 8]
    ekf.reset_velocity(np.array([3.0, 0.0, 0.0]), 0.01, math.radians(3.0))
    assert ekf.cov[6, 6] >= math.radians(3.0) ** 2 and ekf.cov[7, 7] >= math.radians(3.0) ** 2
    assert ekf.cov[8, 8] == yaw_var
    assert np.allclose(ekf.history[0][2], [4.0, 0.0, 0.0])  # moved by the same 3 m/s
