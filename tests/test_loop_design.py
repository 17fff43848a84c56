"""Rate-loop design and margins (mavsim_core.loop_design), the outer loops (cascade_design), the step (cascade_sim)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mavsim_core.loop_design import (
    LoopFilters,
    PidGains,
    RatePlant,
    design_rate_pid,
    rate_loop_margins,
    rate_loop_response,
)
from sitl.cascade_design import design_attitude, design_position, design_velocity_xy, outer_grid_hz
from sitl.cascade_sim import OuterGains, simulate_xy_step, step_metrics

QUAD = RatePlant(effectiveness=1.0, motor_tau_s=0.01875, delay_s=0.0)


@pytest.mark.parametrize("pm", [45.0, 55.0])
def test_designed_loop_has_the_margins_asked_for(pm):
    gains = design_rate_pid(QUAD, phase_margin_deg=pm)
    m = rate_loop_margins(QUAD, gains)
    assert m.phase_margin_deg == pytest.approx(pm, abs=0.5)
    assert m.gain_margin_db >= 6.0
    assert gains.p > 0 and gains.i > 0 and gains.d >= 0


def test_asked_crossover_is_met():
    gains = design_rate_pid(QUAD, crossover_hz=4.0)
    assert rate_loop_margins(QUAD, gains).crossover_hz == pytest.approx(4.0, rel=0.02)


def test_more_delay_gives_a_lower_crossover():
    fast = rate_loop_margins(QUAD, design_rate_pid(QUAD))
    late = RatePlant(1.0, QUAD.motor_tau_s, 0.012)
    slow = rate_loop_margins(late, design_rate_pid(late))
    assert slow.crossover_hz < 0.9 * fast.crossover_hz
    assert slow.phase_margin_deg >= 54.5 and slow.gain_margin_db >= 6.0


def test_p_on_an_integrator_with_delay_matches_the_analytic_margins():
    """L = P e^{-s d} / s (no motor lag, no filters, a fast sample: its hold adds half a period to d).
    Crossover at P rad/s, phase margin 90 deg - P d, gain margin 20 log10(pi / (2 d P))."""
    p, d, fs = 20.0, 0.01, 20000.0
    plant = RatePlant(1.0, 1e-7, d)
    m = rate_loop_margins(plant, PidGains(p, 0.0, 0.0), sample_hz=fs, d_cutoff_hz=0.0, gyro_cutoff_hz=0.0)
    d_eff = d + 0.5 / fs
    assert m.crossover_hz == pytest.approx(p / (2 * math.pi), rel=1e-3)
    assert m.phase_margin_deg == pytest.approx(90.0 - math.degrees(p * d_eff), abs=0.2)
    assert m.gain_margin_db == pytest.approx(20 * math.log10(math.pi / (2 * d_eff * p)), abs=0.1)


def test_motor_lag_phase_matches_the_analytic_value():
    """L = P / (s (tau s + 1)): |L| = 1 at w^2 sqrt(1 + w^2 tau^2) ... phase margin 90 - atan(w tau)."""
    p, tau, fs = 30.0, 0.02, 20000.0
    m = rate_loop_margins(RatePlant(1.0, tau, 0.0), PidGains(p, 0.0, 0.0), fs, 0.0, 0.0)
    w = math.sqrt((-1 + math.sqrt(1 + 4 * (p * tau) ** 2)) / (2 * tau**2))  # |L(jw)| = 1
    assert m.crossover_hz == pytest.approx(w / (2 * math.pi), rel=1e-3)
    assert m.phase_margin_deg == pytest.approx(90.0 - math.degrees(math.atan(w * tau) + w * 0.5 / fs), abs=0.2)


def test_cascade_keeps_inner_loops_four_times_faster():
    f = outer_grid_hz()
    gains = design_rate_pid(QUAD)
    rate_closed = rate_loop_response(QUAD, gains, f)[1]
    att = design_attitude(rate_closed, f, 4.0, "roll angle")
    vel = design_velocity_xy(att.closed, f, 4.0)
    pos = design_position(vel, f, 4.0, "position xy")
    for loop in (att, vel, pos):
        assert loop.inner_bandwidth_hz / loop.bandwidth_hz >= 3.99
        assert loop.margins.phase_margin_deg > 45.0 and loop.margins.gain_margin_db > 6.0
    # and the predicted 10 m step of that cascade arrives without overshooting
    t, x = simulate_xy_step(QUAD, gains, att.p, OuterGains(pos.p, vel.p, vel.i, 5.0, 6.9), math.radians(220))
    step = step_metrics(t, x, 10.0)
    assert step.overshoot_pct < 3.0 and step.settle_s < 15.0


def test_step_metrics_of_a_first_order_response():
    k = 0.8
    t = np.arange(0, 30, 0.001)
    s = step_metrics(t, 10.0 * (1 - np.exp(-k * t)), 10.0)
    assert s.rise_s == pytest.approx(math.log(9) / k, abs=0.01)
    assert s.overshoot_pct == 0.0
    assert s.settle_s == pytest.approx(math.log(100) / k, abs=0.01)  # within 0.1 m of 10 m: 1 %


def test_a_bad_plant_is_refused():
    with pytest.raises(ValueError):
        design_rate_pid(RatePlant(0.0, 0.02, 0.0))
    with pytest.raises(ValueError):
        design_rate_pid(QUAD, filters=LoopFilters(250.0, 30.0, 30.0), crossover_hz=1000.0)
