"""The rate controller (autopilot.control.rate_control): integrator anti-windup and NaN safety.

No sockets, no processes, no clocks.  (From tests/test_units.py, split by subject.)
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from autopilot.control.gains_from_params import rate_control_from_params as make_rate_control


def test_rate_integrator_stops_growing_toward_saturated_side(params):
    rc = make_rate_control(params)
    err = np.array([1.0, -1.0, 0.5])  # rate setpoint minus rate
    sat_pos = np.array([True, False, True])
    sat_neg = np.array([False, True, False])
    for _ in range(50):
        rc.update(np.zeros(3), err, 0.004, sat_pos, sat_neg)
    assert np.asarray(rc.integral) == pytest.approx(np.zeros(3))
    # The other way out of saturation still integrates.
    for _ in range(50):
        rc.update(np.zeros(3), -err, 0.004, sat_pos, sat_neg)
    i = np.asarray(rc.integral)
    assert i[0] < 0 and i[1] > 0 and i[2] < 0
    # And without saturation it integrates I * e * dt.
    rc.reset()
    rc.update(np.zeros(3), err, 0.004)
    assert np.asarray(rc.integral) == pytest.approx(err * 0.004 * np.array([6.0, 6.0, 2.0]))


def test_rate_integrator_clamped_at_int_lim(params):
    rc = make_rate_control(params)
    for _ in range(5000):
        rc.update(np.zeros(3), np.array([5.0, -5.0, 5.0]), 0.004)
    assert np.asarray(rc.integral) == pytest.approx(
        [params.get("MC_RR_INT_LIM"), -params.get("MC_PR_INT_LIM"), params.get("MC_YR_INT_LIM")]
    )
    params.set("MC_RR_INT_LIM", 1.5)  # a changed limit applies at once
    rc.update(np.zeros(3), np.array([5.0, -5.0, 5.0]), 0.004)
    assert rc.integral[0] == pytest.approx(1.5)


def test_nan_input_does_not_poison_the_integrator(params):
    rc = make_rate_control(params)
    for _ in range(10):
        rc.update(np.zeros(3), np.array([1.0, 1.0, 1.0]), 0.004)
    before = np.asarray(rc.integral).copy()
    out = rc.update(np.array([math.nan, 0.0, 0.0]), np.zeros(3), 0.004)
    assert np.all(np.isfinite(out))
    out = rc.update(np.zeros(3), np.array([0.0, math.inf, 0.0]), 0.004)
    assert np.all(np.isfinite(out))
    assert np.asarray(rc.integral) == pytest.approx(before)
    out = rc.update(np.zeros(3), np.array([1.0, 1.0, 1.0]), 0.004)
    assert np.all(np.isfinite(out)) and np.all(np.isfinite(rc.integral))
