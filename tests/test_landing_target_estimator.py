"""The landing-target Kalman estimator and the polynomial predictor, on synthetic tracks."""

import math

import numpy as np
import pytest

from autopilot.navigation.landing_target_estimator import (
    PARAMS,
    RESET_AFTER_REJECTS,
    LandingTargetEstimator,
    LandingTargetSettings,
)
from autopilot.navigation.target_predictor import PolynomialTargetPredictor
from autopilot.topics import LandingTargetMeasurement

DT_US = 33_333  # 30 Hz
HEIGHT_M = 2.8


def _meas(t_us, rel_ne, noise=0.0, rng=None):
    n = rng.normal(0.0, noise, 2) if rng is not None else np.zeros(2)
    return LandingTargetMeasurement(t_us, np.array([rel_ne[0] + n[0], rel_ne[1] + n[1], HEIGHT_M]), math.nan, 12, True)


def _run(est, target_vel, seconds, noise, rng, start=(2.0, -1.0)):
    """Vehicle hovers at the origin; the target starts at ``start`` and moves at ``target_vel``."""
    t = 0
    for k in range(int(seconds * 1e6 / DT_US)):
        t = k * DT_US
        est.predict(t, np.zeros(3))
        est.update(_meas(t, np.array(start) + np.array(target_vel) * t * 1e-6, noise, rng))
    return t


def test_parameters_are_pxs_names_and_defaults():
    d = {p.name: p.default for p in PARAMS}
    assert d["LTEST_MODE"] == 0 and d["LTEST_ACC_UNC"] == 10.0 and d["LTEST_MEAS_UNC"] == 0.005
    assert d["LTEST_POS_UNC_IN"] == 0.1 and d["LTEST_VEL_UNC_IN"] == 0.1
    assert LandingTargetSettings.from_params(d.__getitem__) == LandingTargetSettings()


def test_converges_on_a_static_target():
    rng = np.random.default_rng(1)
    est = LandingTargetEstimator()
    est.update(_meas(0, (2.0, -1.0), 0.1, rng))
    first = est.estimate(0)
    t = _run(est, (0.0, 0.0), 3.0, 0.1, rng)
    last = est.estimate(t, np.zeros(3))
    assert last.valid and first.valid
    assert np.linalg.norm(last.rel_pos_ned_m[:2] - [2.0, -1.0]) < 0.05
    assert np.all(last.rel_pos_var_m2 < 0.2 * first.rel_pos_var_m2)
    assert np.linalg.norm(last.target_vel_ned_m_s) < 0.1


def test_tracks_moving_targets_velocity():
    for speed in (1.0, 3.0):
        rng = np.random.default_rng(2)
        est = LandingTargetEstimator()
        vel = np.array([speed * 0.6, speed * 0.8])
        t = _run(est, vel, 4.0, 0.03, rng)
        e = est.estimate(t, np.zeros(3))
        assert np.linalg.norm(e.rel_vel_ned_m_s[:2] - vel) < 0.1, (speed, e.rel_vel_ned_m_s)
        np.testing.assert_allclose(e.target_vel_ned_m_s[:2], vel, atol=0.1)


def test_rejects_a_5m_outlier():
    rng = np.random.default_rng(3)
    est = LandingTargetEstimator()
    t = _run(est, (0.0, 0.0), 2.0, 0.05, rng)
    before = est.estimate(t).rel_pos_ned_m
    assert not est.update(_meas(t + DT_US, (7.0, -1.0)))
    assert est.rejected_count == 1
    after = est.estimate(t + DT_US).rel_pos_ned_m
    assert np.linalg.norm(after[:2] - before[:2]) < 0.05


def test_invalid_after_the_timeout_and_reinitialised_by_the_next_measurement():
    est = LandingTargetEstimator(LandingTargetSettings(timeout_s=2.0))
    assert not est.estimate(0).valid
    t = _run(est, (0.0, 0.0), 1.0, 0.0, None)
    assert est.estimate(t + 1_900_000).valid
    assert not est.estimate(t + 2_100_000).valid
    assert est.update(_meas(t + 2_100_000, (-3.0, 4.0)))  # far away, but a fresh start: accepted
    np.testing.assert_allclose(est.estimate(t + 2_100_000).rel_pos_ned_m[:2], [-3.0, 4.0])


def _circle(t_s, radius=5.0, speed=1.0):
    w = speed / radius
    return np.array([radius * math.cos(w * t_s), radius * math.sin(w * t_s), 0.0])


def test_polynomial_predictor_predicts_a_circle_segment_ahead():
    rng = np.random.default_rng(4)
    pred = PolynomialTargetPredictor()
    vehicle = np.array([1.0, 1.0, -3.0])
    for k in range(150):
        t_us = k * DT_US
        pred.add_sample(t_us, _circle(t_us * 1e-6) + np.append(rng.normal(0, 0.005, 2), 0.0))
    now = 149 * DT_US
    e = pred.predict(now, 0.5, vehicle, np.zeros(3))
    truth = _circle(now * 1e-6 + 0.5)
    assert e.valid
    assert np.linalg.norm(e.rel_pos_ned_m - (truth - vehicle)) < 0.05
    assert np.linalg.norm(e.target_vel_ned_m_s[:2]) == pytest.approx(1.0, abs=0.1)


def test_polynomial_predictor_is_invalid_with_fewer_than_100_samples():
    pred = PolynomialTargetPredictor()
    for k in range(99):
        pred.add_sample(k * DT_US, _circle(k * DT_US * 1e-6))
    assert not pred.predict(99 * DT_US, 0.5, np.zeros(3)).valid
    pred.add_sample(99 * DT_US, _circle(99 * DT_US * 1e-6))
    assert pred.predict(99 * DT_US, 0.5, np.zeros(3)).valid


def test_vehicle_acceleration_drives_the_prediction():
    """Vehicle accelerating north at 1 m/s^2 over a static target: the relative state
    predicted 1 s past the last measurement follows the vehicle's acceleration."""
    rng = np.random.default_rng(5)
    est = LandingTargetEstimator()
    a = 1.0
    t = 0
    for k in range(int(3e6 / DT_US)):
        t = k * DT_US
        ts = t * 1e-6
        est.predict(t, np.array([a, 0.0, 0.0]))
        if k % 3 == 0:
            est.update(_meas(t, (4.0 - 0.5 * a * ts * ts, 0.0), 0.02, rng))
    ts = t * 1e-6
    e = est.estimate(t + 1_000_000)
    t2 = ts + 1.0  # 1 s ahead: the acceleration alone moves it 0.5 m
    assert abs(e.rel_pos_ned_m[0] - (4.0 - 0.5 * a * t2 * t2)) < 0.15
    assert abs(e.rel_vel_ned_m_s[0] + a * t2) < 0.15


def test_a_newly_seen_target_starts_still_over_the_ground():
    """A vehicle still braking at 1.2 m/s north when it first sees a standing deck: the filter starts with the
    target still over the ground (relative velocity -1.2 m/s, as PX4's), not moving with the vehicle."""
    vehicle_vel = np.array([1.2, -0.5, 0.0])
    est = LandingTargetEstimator(LandingTargetSettings(vel_unc_in=4.0))
    assert est.update(_meas(0, (2.0, -1.0)), vehicle_vel)
    e = est.estimate(0, vehicle_vel)
    np.testing.assert_allclose(e.rel_vel_ned_m_s[:2], -vehicle_vel[:2])
    np.testing.assert_allclose(e.target_vel_ned_m_s[:2], 0.0, atol=1e-12)
    assert LandingTargetEstimator().update(_meas(0, (2.0, -1.0)))  # no velocity given: relative velocity 0


def test_a_target_that_sets_off_unmodelled_restarts_the_filter_after_three_refusals():
    """Held still by the filter, the deck is seen 1.5 m further on (it drove off while out of view): the first
    RESET_AFTER_REJECTS fixes are refused as outliers, the next one restarts the filter on it (PX4's filter
    would refuse every fix until LTEST_TIMEOUT, the marker in view all the while)."""
    est = LandingTargetEstimator()
    t = _run(est, (0.0, 0.0), 1.0, 0.0, None)
    for k in range(1, RESET_AFTER_REJECTS + 1):
        assert not est.update(_meas(t + k * DT_US, (3.5, -1.0)))
    assert est.rejected_count == RESET_AFTER_REJECTS
    t += (RESET_AFTER_REJECTS + 1) * DT_US
    assert est.update(_meas(t, (3.5, -1.0)), np.array([0.5, 0.0, 0.0]))
    e = est.estimate(t, np.array([0.5, 0.0, 0.0]))
    np.testing.assert_allclose(e.rel_pos_ned_m[:2], [3.5, -1.0])
    np.testing.assert_allclose(e.target_vel_ned_m_s[:2], 0.0, atol=1e-12)
    assert est.update(_meas(t + DT_US, (7.0, -1.0))) is False  # an outlier after that is refused again
