"""The precision landing's heading square to the deck (autopilot/navigation/deck_heading.py) and where it comes
from: LANDING_TARGET's target orientation (autopilot/mavlink/landing_target.py) or the deck's velocity."""

from __future__ import annotations

import math
import os

os.environ["MAVLINK20"] = "1"

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mav

from autopilot.mavlink.landing_target import decode_landing_target, square_yaw
from autopilot.navigation.deck_heading import STALE_S, DeckHeading, nearest_square, square
from mavsim_core import quaternion as quat


def _turned_face_up(yaw_rad: float) -> list[float]:
    """A marker lying face up (its z axis up: rolled 180 deg), turned yaw_rad: (w, x, y, z)."""
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    return list(quat.from_matrix(np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]]) @ np.diag([1.0, -1.0, -1.0])))


DEG = math.pi / 180.0
S = 1_000_000  # us


def test_square_and_nearest_square():
    assert square(50 * DEG) == pytest.approx(-40 * DEG)
    assert square(-45 * DEG) == pytest.approx(-45 * DEG) and square(45 * DEG) == pytest.approx(-45 * DEG)
    assert square(170 * DEG) == pytest.approx(-10 * DEG)
    assert nearest_square(-40 * DEG, 100 * DEG) == pytest.approx(140 * DEG)
    assert nearest_square(10 * DEG, 179 * DEG) == pytest.approx(-170 * DEG)  # wrapped, nearer than 190


def test_the_heading_turns_square_to_a_driving_deck_and_with_its_turn():
    h = DeckHeading(yaw_rad=0.0, enabled=True)
    assert h.setpoint(0, 0.3) == (0.0, 0.0)  # no deck yet: the landing's own heading
    h.observe(0, None, np.array([1.0, 1.0, 0.0]), None)  # driving north-east, no orientation sent
    yaw, rate = h.setpoint(0, 0.0)
    assert yaw in (pytest.approx(-15 * DEG), pytest.approx(15 * DEG)) and rate == 0.0  # 15 deg at a time
    assert not h.aligned(0, 0.0) and h.aligned(0, 47 * DEG) and h.aligned(0, -137 * DEG)
    # turning at 0.5 rad/s: moved on between fixes, its rate fed forward
    h = DeckHeading(yaw_rad=0.0, enabled=True)
    h.observe(0, 10 * DEG, np.zeros(3), 0.5)
    assert h.deck_square(S) == pytest.approx(square(10 * DEG + 0.5))
    # of the four square headings (10 + 29 deg + k 90) the one nearest to the vehicle's (-40 deg), and at most
    # 15 deg ahead of the vehicle (from 100 deg: 129 deg is 29 deg away)
    assert h.setpoint(S, -40 * DEG) == (pytest.approx(10 * DEG + 0.5 - math.pi / 2), 0.5)
    assert h.setpoint(S, 100 * DEG) == (pytest.approx(115 * DEG), 0.5)
    h.observe(S, 0.0, np.zeros(3), 9.0)  # a turn rate beyond any deck's is fed forward only up to 2.5 rad/s
    assert h.setpoint(S, 0.0) == (0.0, 2.5)


def test_a_slow_deck_without_orientation_and_the_parameter_off_keep_the_own_heading():
    h = DeckHeading(yaw_rad=1.0, enabled=True)
    h.observe(0, None, np.array([0.3, 0.1, 0.0]), 0.0)  # slower than HEADING_SPEED_M_S
    assert h.setpoint(0, 0.2) == (1.0, 0.0) and h.aligned(0, 0.3)
    off = DeckHeading(yaw_rad=1.0, enabled=False)
    off.observe(0, 20 * DEG, np.array([2.0, 0.0, 0.0]), 0.3)
    assert off.setpoint(0, 0.2) == (1.0, 0.0) and off.aligned(0, 0.3)


def test_a_stale_deck_heading_holds_the_last_setpoint():
    h = DeckHeading(yaw_rad=0.0, enabled=True)
    h.observe(0, 30 * DEG, np.zeros(3), 0.0)
    assert h.setpoint(S, 20 * DEG) == (pytest.approx(30 * DEG), 0.0)
    later = int((STALE_S + 1) * S)
    assert h.deck_square(later) is None and h.setpoint(later, 1.0) == (pytest.approx(30 * DEG), 0.0)
    assert h.aligned(later, 2.0)


def _target(frame: int, q) -> mav.MAVLink_landing_target_message:
    return mav.MAVLink_landing_target_message(1, 0, frame, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 2.0, q, 0, 1)


def test_landing_target_q_gives_the_decks_square_heading():
    level = np.array([1.0, 0.0, 0.0, 0.0])
    # a marker turned 100 deg in NED: square heading 10 deg
    m = decode_landing_target(_target(mav.MAV_FRAME_LOCAL_NED, _turned_face_up(100 * DEG)), level, 2.0, np.zeros(3))
    assert m.square_yaw_rad == pytest.approx(10 * DEG)
    # the body form: the same marker seen from a vehicle heading 70 deg (marker turned 30 deg in FRD)
    att = np.asarray(quat.from_euler(0.0, 0.0, 70 * DEG))
    m = decode_landing_target(_target(mav.MAV_FRAME_BODY_FRD, _turned_face_up(30 * DEG)), att, 2.0)
    assert m.square_yaw_rad == pytest.approx(10 * DEG)
    # no orientation: zeros (what many senders fill), not finite, or a marker standing on its edge
    for q in ([0.0, 0.0, 0.0, 0.0], [math.nan, 0.0, 0.0, 1.0], list(quat.from_euler(math.pi / 2, 0.0, 0.0))):
        m = decode_landing_target(_target(mav.MAV_FRAME_LOCAL_NED, q), level, 2.0, np.zeros(3))
        assert m.square_yaw_rad is None, q
    assert square_yaw([1.0, 0.0, 0.0, 0.0], mav.MAV_FRAME_BODY_NED, np.eye(3)) is None  # a frame without axes
