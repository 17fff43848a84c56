"""autopilot.navigation.target_coast: the landing target moved on while unseen (NED, m, s)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from autopilot.navigation.target_coast import (
    MAX_TURN_RATE_RAD_S,
    TURN_WINDOW_S,
    TURNING_FROM_M_S,
    TurnRate,
    coast,
)

R_M, V_M_S = 2.0, 1.0  # the landing benchmark's circle at 1 m/s
W = V_M_S / R_M


def on_circle(t_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Position and velocity of a deck driving clockwise (seen from above) round a centre R_M east of its
    start, starting north-bound."""
    a = W * t_s
    return np.array([R_M * math.sin(a), R_M - R_M * math.cos(a), 0.0]), V_M_S * np.array([math.cos(a), math.sin(a), 0])


@pytest.mark.parametrize("t_s", [0.5, 1.0, 2.0])
def test_a_turning_deck_is_moved_on_along_its_circle(t_s):
    vel, acc = np.array([V_M_S, 0.0, 0.0]), np.array([0.0, V_M_S * W, 0.0])  # centripetal, toward the centre
    pos, v, a = coast(np.zeros(3), vel, acc, t_s, W)
    np.testing.assert_allclose(pos, on_circle(t_s)[0], atol=1e-9)
    np.testing.assert_allclose(v, on_circle(t_s)[1], atol=1e-9)
    np.testing.assert_allclose(a, [-V_M_S * W * math.sin(W * t_s), V_M_S * W * math.cos(W * t_s), 0.0], atol=1e-9)
    straight = np.linalg.norm(vel * t_s - on_circle(t_s)[0])  # what moving on straight would miss
    assert straight > 0.1 * t_s * t_s


def test_the_turn_rate_is_the_measured_headings_change_and_noise_on_a_straight_drive_is_not_a_turn():
    turning, straight = TurnRate(), TurnRate()
    rng = np.random.default_rng(0)
    for k in range(100):  # 2 s at 50 Hz
        t_us = k * 20_000
        turning.add(t_us, on_circle(k * 0.02)[1])
        straight.add(t_us, np.array([1.0, 0.0, 0.0]) + rng.normal(0.0, 0.02, 3))  # 2 cm/s of velocity noise
    assert turning.rate() == pytest.approx(W, rel=1e-6)
    assert straight.rate() == 0.0
    fresh = TurnRate()
    fresh.add(0, np.array([1.0, 0.0, 0.0]))
    fresh.add(int(0.4 * TURN_WINDOW_S * 1e6), np.array([0.0, 1.0, 0.0]))
    assert fresh.rate() == 0.0  # less than half a window of headings
    fresh.add(int(0.6 * TURN_WINDOW_S * 1e6), np.array([-1.0, 0.0, 0.0]))  # half a turn in 0.6 s
    assert fresh.rate() == MAX_TURN_RATE_RAD_S
    fresh.add(10**6, np.array([0.9 * TURNING_FROM_M_S, 0.0, 0.0]))  # slow: forgotten
    assert fresh.rate() == 0.0


def test_a_slow_deck_moves_on_straight_whatever_the_rate():
    slow = np.array([0.9 * TURNING_FROM_M_S, 0.0, 0.0])
    pos, v, _ = coast(np.zeros(3), slow, np.zeros(3), 1.0, 0.5)
    np.testing.assert_allclose(pos, slow)
    np.testing.assert_allclose(v, slow)
    fast = np.array([3.0, 0.0, -0.2])
    pos, v, _ = coast(np.ones(3), fast, np.zeros(3), 1.0, 0.0)
    np.testing.assert_allclose(pos, np.ones(3) + fast)
    np.testing.assert_allclose(v, fast)
    assert coast(np.ones(3), fast, np.zeros(3), 0.0, 0.5)[0].tolist() == [1.0, 1.0, 1.0]


def test_a_deck_models_turn_rate_is_used_instead_of_the_headings_within_the_dead_bands():
    """PLD_DECK_MDL 1 hands the turn filter's rate on: used at once (no window of headings to wait for), still
    zero inside the dead bands and held to MAX_TURN_RATE_RAD_S."""
    from autopilot.navigation.target_coast import MAX_TURN_RATE_RAD_S

    turn = TurnRate()
    turn.add(0, np.array([2.0, 0.0, 0.0]), 1.0)
    assert turn.rate() == 1.0
    turn.add(50_000, np.array([2.0, 0.0, 0.0]), 0.05)  # 0.1 m/s^2 across a straight drive: its weave
    assert turn.rate() == 0.0
    turn.add(100_000, np.array([2.0, 0.0, 0.0]), -5.0)
    assert turn.rate() == -MAX_TURN_RATE_RAD_S
    turn.add(150_000, np.array([0.1, 0.0, 0.0]), 1.0)  # too slow to turn
    assert turn.rate() == 0.0
