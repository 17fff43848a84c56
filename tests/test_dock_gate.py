"""When the precision landing may dock (autopilot/navigation/dock_gate.py, PLD_DOCK_CHK) and the deck's turn
rhythm it reads (autopilot/navigation/turn_rhythm.py).

On a figure-8 the deck reverses its turn every lobe; a docking that meets a reversal, or a vehicle still turning
past the deck's heading, touches the deck turned 20-40 deg off square, a foot over its edge.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from autopilot.navigation.deck_heading import DeckHeading, square
from autopilot.navigation.dock_gate import ABORT_ABOVE_M, LATE_S, RHYTHM_MARGIN_S, DockGate, yaw_rate_ned
from autopilot.navigation.turn_rhythm import OVERDUE_S, TurnRhythm

S = 1_000_000  # us
FIX_US = 50_000  # the deck's fixes at 20 Hz
LOBE_S = 2 * math.pi  # a figure-8 of 2 m lobes at 2 m/s: each lobe 6.28 s at +-1 rad/s


def figure8_rate(t_s: float) -> float:
    """The deck model's turn rate on a figure-8: +1 rad/s, then -1, reversed within 0.2 s at each crossing."""
    lobe, into = divmod(t_s, LOBE_S)
    sign = 1.0 if int(lobe) % 2 == 0 else -1.0
    return sign * (1.0 if into >= 0.2 or lobe == 0 else -1.0 + 2.0 * into / 0.2)


def fed(rhythm: TurnRhythm, rate, until_s: float, noise: float = 0.05, seed: int = 1) -> TurnRhythm:
    rng = np.random.default_rng(seed)
    for k in range(int(until_s * S / FIX_US)):
        t_us = k * FIX_US
        rhythm.add(t_us, rate(t_us * 1e-6) + float(rng.normal(0.0, noise)))
    return rhythm


def test_a_figure8s_next_reversal_is_expected_one_lobe_after_the_last():
    rhythm = fed(TurnRhythm(), figure8_rate, 1.6 * LOBE_S)
    assert rhythm.next_change_us(int(1.6 * LOBE_S * S)) is None  # one reversal seen: no rhythm yet
    rhythm = fed(TurnRhythm(), figure8_rate, 2.5 * LOBE_S)
    due = rhythm.next_change_us(int(2.5 * LOBE_S * S))
    assert due is not None and due * 1e-6 == pytest.approx(3 * LOBE_S, abs=0.15)
    # blocked within the span before it, clear long before it
    assert not rhythm.clear(int((3 * LOBE_S - 1.0) * S), 1.4)
    assert rhythm.clear(int((3 * LOBE_S - 3.0) * S), 1.4)


def test_a_circle_a_weave_and_an_overdue_change_expect_nothing():
    assert fed(TurnRhythm(), lambda t: 1.0, 30.0).next_change_us(30 * S) is None
    weave = fed(TurnRhythm(), lambda t: 0.3 * math.sin(2.0 * t), 30.0)  # a straight drive's weave, +-0.3 rad/s
    assert weave.next_change_us(30 * S) is None
    # two reversals, then the deck drives on a circle: the third is expected, then dropped once overdue
    rhythm = fed(TurnRhythm(), lambda t: figure8_rate(min(t, 2.5 * LOBE_S)), 3 * LOBE_S + 2 * OVERDUE_S)
    assert rhythm.next_change_us(int(3 * LOBE_S * S)) is not None
    assert rhythm.next_change_us(int((3 * LOBE_S + 2 * OVERDUE_S) * S)) is None


def test_bad_samples_are_ignored():
    rhythm = fed(TurnRhythm(), figure8_rate, 2.5 * LOBE_S)
    due = rhythm.next_change_us(int(2.5 * LOBE_S * S))
    rhythm.add(int(2.5 * LOBE_S * S) + FIX_US, math.nan)
    rhythm.add(0, -5.0)  # out of time order
    assert rhythm.next_change_us(int(2.5 * LOBE_S * S)) == due


def turning_deck(turn_rad_s: float) -> DeckHeading:
    h = DeckHeading(yaw_rad=0.0, enabled=True)
    h.observe(0, 0.0, np.zeros(3), turn_rad_s)  # square at 0 deg now, turning
    return h


def test_docking_is_timed_to_touch_square_whatever_the_heading_now():
    gate, deck = DockGate(), turning_deck(1.0)
    assert gate.hold_reason(0, deck, 0.0, 1.0, 1.0) == ""  # turning with the deck
    # square now, but turning 0.3 rad/s slower than the deck: 17 deg off at the touch a second later
    assert "at the touch" in gate.hold_reason(0, deck, 0.0, 0.7, 1.0)
    # 20 deg ahead of square now, turning 0.35 rad/s slower: square at the touch
    assert gate.hold_reason(0, deck, math.radians(20.0), 1.0 - math.radians(20.0), 1.0) == ""
    # without the timing (bit 1): square now, within 10 deg, whatever it will be
    assert DockGate(checks=0).hold_reason(0, deck, 0.0, 0.7, 1.0) == ""
    assert DockGate(checks=0).hold_reason(0, deck, math.radians(20.0), 0.65, 1.0) == "heading off square"


def test_nor_while_turning_fast_against_the_deck_or_just_after_its_turn_changed():
    """Both come right after a figure-8's reversal, when the deck model's turn rate is still settling and the timed
    heading's prediction was 8-17 deg off."""
    gate, deck = DockGate(), turning_deck(1.0)
    # 40 deg ahead of square, turning 0.7 rad/s slower than the deck: square at the touch, but too fast a sweep
    assert "too fast" in gate.hold_reason(0, deck, math.radians(40.0), 1.0 - math.radians(40.0), 1.0)
    gate.rhythm = fed(gate.rhythm, figure8_rate, 2 * LOBE_S + 0.5)  # the deck reversed half a second ago
    now_us = int((2 * LOBE_S + 0.5) * S)
    assert "just changed" in gate.hold_reason(now_us, turning_deck(-1.0), 0.0, -1.0, 1.0)
    assert gate.hold_reason(now_us + S, turning_deck(-1.0), 0.0, -1.0, 1.0) == ""


def test_the_docking_heading_turns_on_at_the_rate_that_touches_square():
    gate, deck = DockGate(), turning_deck(1.0)
    gate.start(0, deck, math.radians(5.0), 0.9, 1.0)  # 5 deg ahead, 0.1 rad/s slower: 0.7 deg ahead at the touch
    yaw, rate = gate.yaw_setpoint(S)
    assert square(yaw - deck.deck_square(S)) == pytest.approx(0.0, abs=1e-6) and rate == pytest.approx(
        0.9 - math.radians(5.0 - 5.73), abs=1e-3
    )
    assert gate.yaw_setpoint(S // 2)[0] == pytest.approx(math.radians(5.0) + rate / 2)
    assert gate.yaw_setpoint(int((1.0 + LATE_S) * S)) is not None
    assert gate.yaw_setpoint(int((1.0 + LATE_S) * S) + 1000) is None  # a late touch: square to the deck again
    off = DockGate(checks=6)
    off.start(0, deck, math.radians(5.0), 0.9, 1.0)
    assert off.yaw_setpoint(S) is None  # bit 1 off: the deck's heading (DeckHeading) is flown


def test_docking_waits_out_the_decks_turn_change():
    gate, deck = DockGate(), turning_deck(-1.0)
    gate.rhythm = fed(gate.rhythm, figure8_rate, 2.5 * LOBE_S)
    due_s = 3 * LOBE_S
    assert "turn changes" in gate.hold_reason(int((due_s - 1.0) * S), deck, 0.0, -1.0, 1.0)
    assert gate.hold_reason(int((due_s - 1.0 - RHYTHM_MARGIN_S - 0.3) * S), deck, 0.0, -1.0, 1.0) == ""
    assert DockGate(checks=1).hold_reason(int((due_s - 1.0) * S), deck, 0.0, -1.0, 1.0) == ""


def test_a_docking_that_will_touch_off_square_climbs_out_while_it_still_can():
    gate, deck = DockGate(), turning_deck(1.0)
    assert gate.abort_reason(0, deck, 0.0, 1.0, 0.6, 0.5) == ""
    assert "off square" in gate.abort_reason(0, deck, 0.0, 0.3, 0.6, 0.5)  # 24 deg behind at the touch
    assert gate.abort_reason(0, deck, 0.0, 0.3, 0.6, ABORT_ABOVE_M - 0.01) == ""  # too low to stop: on
    assert DockGate(checks=3).abort_reason(0, deck, 0.0, 0.3, 0.6, 0.5) == ""


def test_the_yaw_rate_from_body_rates():
    assert yaw_rate_ned(np.array([0.0, 0.0, 0.5]), 0.0, 0.0) == pytest.approx(0.5)
    # rolled 30 deg: the body's q and r both turn the heading
    roll = math.radians(30.0)
    assert yaw_rate_ned(np.array([0.0, 0.2, 0.4]), roll, 0.0) == pytest.approx(0.2 * 0.5 + 0.4 * math.cos(roll))
