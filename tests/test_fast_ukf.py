"""autopilot/navigation/fast_ukf.py: filterpy's UKF with its per-sigma-point loops on whole arrays is the same filter,
to rounding, as filterpy's own (issue 38), on the deck turn filter's model and measurements."""

from __future__ import annotations

import math

import numpy as np
import pytest
from filterpy.kalman import IMMEstimator, MerweScaledSigmaPoints, UnscentedKalmanFilter
from filterpy.stats import logpdf

from autopilot.navigation.deck_turn_filter import _heading_off_square, _measure, turn_step, turn_step_rows
from autopilot.navigation.fast_ukf import RowsMerweSigmaPoints, RowsUKF, gaussian_log_density

N = 6  # the deck turn filter's state with the marker's lag


def _pair():
    """(filterpy's UKFs and IMM, ours), started alike: a steady and a manoeuvring model."""
    x0 = np.array([0.1, -0.2, 1.8, 0.4, 0.6, 0.1])
    p0 = np.diag([0.1, 0.1, 4.0, 4.0, 0.5, 0.05])
    theirs = [UnscentedKalmanFilter(N, 2, 0.05, _measure, turn_step, MerweScaledSigmaPoints(N, 0.3, 2.0, 0.0))]
    theirs.append(UnscentedKalmanFilter(N, 2, 0.05, _measure, turn_step, MerweScaledSigmaPoints(N, 0.3, 2.0, 0.0)))
    ours = [RowsUKF(N, 2, 0.05, _measure, turn_step_rows, RowsMerweSigmaPoints(N, 0.3, 2.0, 0.0)) for _ in range(2)]
    switch = np.array([[0.995, 0.005], [0.005, 0.995]])
    for f in theirs + ours:
        f.x, f.P = x0.copy(), p0.copy()
    return (theirs, IMMEstimator(theirs, np.array([0.5, 0.5]), switch)), (
        ours,
        IMMEstimator(ours, np.array([0.5, 0.5]), switch),
    )


def test_turn_step_rows_is_turn_step_of_each_row_straight_or_turning():
    rng = np.random.default_rng(4)
    xs = rng.normal(0.0, 2.0, (13, N))
    xs[3, 4], xs[7, 4] = 0.0, 5e-5  # straight drives (the rate below STRAIGHT_BELOW_RAD_S)
    for dt in (0.0, 0.05, 0.7):
        rows = turn_step_rows(xs, dt)
        for x, row in zip(xs, rows):
            np.testing.assert_allclose(row, turn_step(x, dt), rtol=1e-12, atol=1e-12)


def test_the_sigma_points_are_filterpys():
    rng = np.random.default_rng(5)
    a = rng.normal(size=(N, N))
    p = a @ a.T + 0.1 * np.eye(N)
    x = rng.normal(size=N)
    theirs = MerweScaledSigmaPoints(N, 0.3, 2.0, 0.0)
    ours = RowsMerweSigmaPoints(N, 0.3, 2.0, 0.0)
    np.testing.assert_allclose(ours.sigma_points(x, p), theirs.sigma_points(x, p), rtol=1e-12, atol=1e-12)
    np.testing.assert_array_equal(ours.Wm, theirs.Wm)
    np.testing.assert_array_equal(ours.Wc, theirs.Wc)


@pytest.mark.parametrize("size", [1, 2, 3])
def test_the_log_likelihood_is_scipys(size):
    rng = np.random.default_rng(size)
    for _ in range(20):
        a = rng.normal(size=(size, size))
        cov = a @ a.T + 0.05 * np.eye(size)
        y = rng.normal(size=size)
        assert gaussian_log_density(y, cov) == pytest.approx(float(logpdf(x=y, cov=cov)), rel=1e-10, abs=1e-10)
    assert gaussian_log_density(np.array([1.0, 0.0]), np.zeros((2, 2))) == -math.inf


def test_the_imm_of_row_filters_tracks_as_filterpys_through_fixes_headings_and_a_reversed_turn():
    (theirs, imm_t), (ours, imm_o) = _pair()
    rng = np.random.default_rng(7)
    r_pos, r_hdg = np.eye(2) * 4e-4, np.array([[math.radians(3.0) ** 2]])
    for k in range(1, 120):
        t = k * 0.075
        w = 1.0 if t < 4.5 else -1.0  # a figure-8's crossing: the turn reverses
        z = np.array([2.0 * math.sin(w * t), 2.0 * (1.0 - math.cos(w * t))]) + rng.normal(0.0, 0.02, 2)
        yaw = rng.uniform(-0.7, 0.7)
        for fs in (theirs, ours):
            for f, qw in zip(fs, (0.05, 100.0)):
                q = np.eye(N) * 1e-4
                q[4, 4] = qw * 0.075**2
                f._dt, f.Q, f.R = 0.075, q, r_pos
        for imm, fs in ((imm_t, theirs), (imm_o, ours)):
            imm.predict()
            imm.update(z)
            for f in fs:  # the heading, fused as DeckTurnFilter._fuse_heading does
                f.sigmas_f = f.points_fn.sigma_points(f.x, f.P)
                f.update(np.zeros(1), R=r_hdg, hx=_heading_off_square, square_yaw_rad=yaw)
        for a, b in zip(theirs, ours):
            assert b.likelihood == pytest.approx(a.likelihood, rel=1e-7)
        np.testing.assert_allclose(imm_o.x, imm_t.x, rtol=1e-8, atol=1e-9)
        np.testing.assert_allclose(imm_o.P, imm_t.P, rtol=1e-7, atol=1e-10)
        np.testing.assert_allclose(imm_o.mu, imm_t.mu, rtol=1e-7, atol=1e-10)
    assert imm_o.mu[1] > 0.0 and abs(float(imm_o.x[4])) > 0.1  # (it did track a turn, through the reversal)


def test_the_measurements_of_all_sigma_points_at_once_are_those_of_each():
    rng = np.random.default_rng(9)
    xs = rng.normal(0.0, 2.0, (13, N))
    xs[:, 5] = rng.uniform(-0.5, 0.5, 13)
    for yaw in (-3.0, -0.7, 0.0, 0.78, 2.9):
        got = _heading_off_square.rows(xs, square_yaw_rad=yaw)
        want = np.array([_heading_off_square(x, yaw) for x in xs])
        np.testing.assert_allclose(got, want, rtol=0, atol=1e-12)
        assert np.all(np.abs(got) <= math.pi / 4 + 1e-12)
    np.testing.assert_array_equal(_measure.rows(xs), np.array([_measure(x) for x in xs]))
