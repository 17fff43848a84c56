"""gcs/launcher/deck_stance.py: when a multicopter on the UGV's deck is a landing a pilot would call one (all
feet on the deck, level within 2 cm of its stance on flat ground) and when it rests on the deck's edge."""

from __future__ import annotations

import math

import numpy as np
import pytest

from gcs.launcher.deck_stance import LEVEL_TOLERANCE_M, feet_ned, in_deck, stance
from mavsim_core import quaternion as quat
from params.vehicle import load_vehicle
from sitl.ugv import UgvGeometry

GEOM = UgvGeometry()
QUAD = load_vehicle("quad_x")
LEGS = (QUAD.leg_positions_frd_m, QUAD.leg_size_m)
LEVEL_Q = (1.0, 0.0, 0.0, 0.0)
UGV = (4.0, 1.0, -0.02)  # NED m: the UGV's body on flat ground
REST_DZ = 0.0 - UGV[2]  # the multicopter's z (0: where it started) minus the UGV's, both on flat ground


def standing_z(dz_m: float = 0.0) -> float:
    """The multicopter's NED z when it stands level on the deck, ``dz_m`` higher."""
    return UGV[2] + REST_DZ - GEOM.deck_top_m - dz_m


def test_a_level_vehicle_centred_on_the_deck_is_a_landing():
    s = stance((UGV[0], UGV[1], standing_z()), LEVEL_Q, UGV, 0.3, GEOM, LEGS, REST_DZ)
    assert s.standing and s.feet_on_deck == s.feet == 4 and s.problem() == ""
    assert s.level_error_m == pytest.approx(0.0, abs=1e-12)


def test_propped_up_on_the_edge_is_a_failure_that_says_by_how_much():
    s = stance((UGV[0], UGV[1], standing_z(0.065)), LEVEL_Q, UGV, 0.0, GEOM, LEGS, REST_DZ)
    assert not s.standing and s.centre_on_deck and s.level_error_m == pytest.approx(0.065)
    assert s.problem() == "on the deck's edge: +6.5 cm from a level stance"
    within = stance((UGV[0], UGV[1], standing_z(0.9 * LEVEL_TOLERANCE_M)), LEVEL_Q, UGV, 0.0, GEOM, LEGS, REST_DZ)
    assert within.standing


def test_a_foot_over_the_edge_is_a_failure_though_the_centre_is_on_the_deck():
    # quad_x's feet are 0.65 m from its centre on the diagonals: turned 30 deg to the deck and 0.1 m to one side,
    # one foot is 0.73 m out, past the deck's half side (0.65 m)
    q = quat.from_euler(0.0, 0.0, math.radians(30.0))
    s = stance((UGV[0], UGV[1] + 0.1, standing_z()), q, UGV, 0.0, GEOM, LEGS, REST_DZ)
    assert s.centre_on_deck and s.feet_on_deck == 3 and not s.standing
    assert s.problem() == "on the deck's edge: 1 of 4 feet off the deck"
    aligned = stance((UGV[0], UGV[1] + 0.1, standing_z()), LEVEL_Q, UGV, 0.0, GEOM, LEGS, REST_DZ)
    assert aligned.standing  # square to the deck: 0.145 m of room each way


def test_quad_x_turned_45_deg_to_the_deck_has_every_foot_just_past_its_edge():
    """A geometric fact the landing campaign meets: quad_x's feet are sqrt(2) * 0.46 = 0.6505 m from its centre,
    the deck's half side 0.65 m, so centred on the deck but turned 45 deg to it, every foot's centre is 0.5 mm
    over the edge (half of each 9 cm foot on the deck)."""
    q = quat.from_euler(0.0, 0.0, math.radians(45.0))
    s = stance((UGV[0], UGV[1], standing_z()), q, UGV, 0.0, GEOM, LEGS, REST_DZ)
    assert s.feet_on_deck == 0 and s.problem() == "on the deck's edge: 4 of 4 feet off the deck"


def test_off_the_deck_and_without_references():
    off = stance((UGV[0] + 1.0, UGV[1], 0.0), LEVEL_Q, UGV, 0.0, GEOM, LEGS, REST_DZ)
    assert not off.centre_on_deck and off.problem() == "off the deck"
    no_rest = stance((UGV[0], UGV[1], standing_z()), LEVEL_Q, UGV, 0.0, GEOM, LEGS, None)
    assert not no_rest.standing and "level unknown" in no_rest.problem()
    no_attitude = stance((UGV[0], UGV[1], standing_z()), None, UGV, 0.0, GEOM, LEGS, REST_DZ)
    assert no_attitude.feet_on_deck == 0 and not no_attitude.standing


def test_feet_follow_the_attitude_and_the_deck_follows_the_ugv_yaw():
    feet = feet_ned((0.0, 0.0, 0.0), LEVEL_Q, LEGS[0], LEGS[1])
    assert feet.shape == (4, 3) and np.allclose(feet[:, 2], QUAD.leg_size_m[2] / 2)
    rolled = feet_ned((0.0, 0.0, 0.0), quat.from_euler(math.radians(10.0), 0.0, 0.0), LEGS[0], LEGS[1])
    assert not np.allclose(rolled[:, 2], feet[:, 2])  # a roll lifts one side's feet and lowers the other's
    half = GEOM.deck_side_m / 2
    assert in_deck((half - 0.01, 0.0), (0.0, 0.0), 0.0, GEOM)
    assert not in_deck((half - 0.01, half - 0.01), (0.0, 0.0), math.radians(45.0), GEOM)


def test_the_heading_off_square_to_the_deck():
    for rel_deg, off in ((0.0, 0.0), (30.0, 30.0), (-100.0, 10.0), (135.0, 45.0), (80.0, 10.0)):
        q = quat.from_euler(0.0, 0.0, math.radians(20.0 + rel_deg))
        st = stance((UGV[0], UGV[1], standing_z()), q, UGV, math.radians(20.0), GEOM, LEGS, REST_DZ)
        assert st.square_off_deg == pytest.approx(off), rel_deg
    assert math.isnan(stance((UGV[0], UGV[1], standing_z()), None, UGV, 0.0, GEOM, LEGS, REST_DZ).square_off_deg)
