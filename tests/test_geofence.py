"""The geofence (autopilot.navigation.geofence): geometry from fence items, breach and predicted breach.

Fences are built from MISSION_ITEM_INTs at a real latitude (PX4's SITL home in Zurich), with
vertices placed by metres north/east of the origin, so the checks run in the frame the commander uses.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from autopilot.navigation.geofence import PARAMS, Breach, FenceError, Geofence, GfAction
from autopilot.parameters import ParamType
from mavsim_core import mission_items as mi
from mavsim_core.geodesy import ned_to_geodetic
from mavsim_core.mission_items import MissionItem

LAT0, LON0 = 47.397742, 8.545594
INC, EXC = mi.FENCE_POLYGON_INCLUSION, mi.FENCE_POLYGON_EXCLUSION
CINC, CEXC = mi.FENCE_CIRCLE_INCLUSION, mi.FENCE_CIRCLE_EXCLUSION
BRAKE = 2.0  # m/s^2


def item(seq: int, command: int, param1: float, north: float, east: float) -> MissionItem:
    lat, lon, _ = ned_to_geodetic(np.array([north, east, 0.0]), LAT0, LON0, 0.0)
    return MissionItem(
        seq, mi.FRAME_GLOBAL_INT, command, param1, x=round(lat * 1e7), y=round(lon * 1e7), mission_type=mi.FENCE
    )


def polygon(command: int, corners: list[tuple[float, float]], seq0: int = 0) -> list[MissionItem]:
    return [item(seq0 + k, command, len(corners), n, e) for k, (n, e) in enumerate(corners)]


def square(command: int, half: float, centre: tuple[float, float] = (0.0, 0.0), seq0: int = 0) -> list[MissionItem]:
    n, e = centre
    corners = [(n - half, e - half), (n - half, e + half), (n + half, e + half), (n + half, e - half)]
    return polygon(command, corners, seq0)


def fence(items: list[MissionItem]) -> Geofence:
    return Geofence.from_items(items, LAT0, LON0)


def at(north: float, east: float, down: float = -10.0) -> np.ndarray:
    return np.array([north, east, down])


def predicted(b: Breach | None) -> bool:
    """A predicted breach (the vehicle itself still inside)."""
    return b is not None and b.predicted


def check(
    f: Geofence, pos: np.ndarray, vel=(0.0, 0.0, 0.0), home=None, max_hor=0.0, max_ver=0.0, predict=True
) -> Breach | None:
    return f.check(pos, np.array(vel, dtype=float), home, max_hor, max_ver, predict, BRAKE)


# ------------------------------------------------------------------------------------------ parameters


def test_params_are_px4s():
    by_name = {p.name: p for p in PARAMS}
    assert set(by_name) == {"GF_ACTION", "GF_MAX_HOR_DIST", "GF_MAX_VER_DIST", "GF_PREDICT"}
    expected = {
        "GF_ACTION": (ParamType.INT32, 2, 0, 5),
        "GF_MAX_HOR_DIST": (ParamType.REAL32, 0, 0, 10000),
        "GF_MAX_VER_DIST": (ParamType.REAL32, 0, 0, 10000),
        "GF_PREDICT": (ParamType.INT32, 1, 0, 1),
    }
    for name, (ptype, default, lo, hi) in expected.items():
        d = by_name[name]
        assert (d.ptype, d.default, d.min, d.max) == (ptype, default, lo, hi), name
    assert by_name["GF_MAX_HOR_DIST"].unit == by_name["GF_MAX_VER_DIST"].unit == "m"


def test_gf_action_numbers_are_px4s():
    assert [(a.name, a.value) for a in GfAction] == [
        ("NONE", 0), ("WARNING", 1), ("HOLD", 2), ("RETURN", 3), ("TERMINATE", 4), ("LAND", 5)
    ]  # fmt: skip


# ------------------------------------------------------------------------------------------ inclusion polygon


def test_square_inclusion_inside_and_outside():
    f = fence(square(INC, 50.0))
    assert f.has_inclusion and not f.empty
    (poly,) = f.inclusion_polygons
    assert np.allclose(poly.bounds, (-50, -50, 50, 50), atol=0.02)  # degE7 rounding: ~1 cm
    for n, e in [(0.0, 0.0), (49.0, 49.0), (-49.0, 30.0), (0.0, -49.9)]:
        assert f.inside(at(n, e)), (n, e)
        assert check(f, at(n, e)) is None
    for n, e in [(51.0, 0.0), (0.0, -51.0), (100.0, 100.0), (-50.5, -50.5)]:
        assert not f.inside(at(n, e)), (n, e)
        assert check(f, at(n, e)) == Breach("Geofence: outside the inclusion polygon", predicted=False)


def test_predicted_breach_flying_toward_the_edge():
    """5 m/s with 2 m/s^2 stops in 6.25 m; with the 1 m margin the point 7.25 m ahead is checked.
    So 10 m from the edge is still fine at 5 m/s (7.25 < 10) and breaks at 7 m/s (12.25 + 1 m);
    7 m from the edge breaks at 5 m/s and not at 2 m/s (1 m + 1 m)."""
    f = fence(square(INC, 50.0))
    approaching = Breach("Geofence: approaching the inclusion polygon boundary", predicted=True)
    assert check(f, at(40, 0), (5, 0, 0)) is None
    assert check(f, at(40, 0), (7, 0, 0)) == approaching
    assert check(f, at(43, 0), (5, 0, 0)) == approaching
    assert check(f, at(43, 0), (2, 0, 0)) is None
    assert check(f, at(42, 0), (5, 0, 0)) is None  # 49.25: still inside
    assert check(f, at(43, 0), (5, 0, 0), predict=False) is None
    assert check(f, at(43, 0), (-5, 0, 0)) is None  # flying away
    assert check(f, at(0, -43), (0, -5, 0)) == approaching  # toward the west edge
    assert check(f, at(45, 45), (5 / math.sqrt(2), 5 / math.sqrt(2), 0)) == approaching  # toward the corner
    assert check(f, at(0, 45), (0, 0, -5)) is None  # climbing: the polygon is horizontal only


def test_outside_and_flying_back_in_is_an_actual_breach():
    f = fence(square(INC, 50.0))
    b = check(f, at(55, 0), (-10, 0, 0))
    assert b is not None and not b.predicted


def test_at_rest_only_the_position_counts():
    f = fence(square(INC, 50.0))
    assert check(f, at(49.5, 0)) is None  # 0.5 m from the edge, no margin at rest
    assert predicted(check(f, at(49.5, 0), (0.01, 0, 0)))  # moving: the 1 m margin applies


def test_zero_brake_does_not_divide_by_zero():
    """A braking acceleration <= 0 (a bad MPC_ACC_HOR) is taken as a small one: a long stopping distance."""
    f = fence(square(INC, 50.0))
    assert f.check(at(0, 0), np.array([5.0, 0, 0]), None, 0, 0, True, 0.0) == Breach(
        "Geofence: approaching the inclusion polygon boundary", True
    )


# ------------------------------------------------------------------------------------------ exclusions, circles


def test_exclusion_polygon():
    f = fence(square(EXC, 10.0, centre=(100.0, 0.0)))
    assert not f.has_inclusion and not f.empty
    assert f.inside(at(0, 0)) and f.inside(at(80, 0)) and f.inside(at(100, 20))
    assert not f.inside(at(100, 0)) and not f.inside(at(95, 5))
    assert check(f, at(95, 0)) == Breach("Geofence: inside the exclusion polygon", False)
    assert check(f, at(80, 0), (5, 0, 0)) is None  # 10 m away: 7.25 m ahead
    assert check(f, at(84, 0), (5, 0, 0)) == Breach("Geofence: approaching the exclusion polygon boundary", True)
    assert check(f, at(84, 0), (2, 0, 0)) is None


def test_inclusion_with_an_exclusion_inside():
    f = fence(square(INC, 50.0) + square(EXC, 5.0, seq0=4))
    assert f.inside(at(20, 20)) and not f.inside(at(0, 0)) and not f.inside(at(60, 0))


def test_inclusion_circle():
    f = fence([item(0, CINC, 50.0, 0.0, 0.0)])
    assert f.has_inclusion and f.inside(at(0, 0)) and f.inside(at(35, 35))  # 49.5 m
    assert not f.inside(at(36, 36))  # 50.9 m
    assert check(f, at(0, 60)) == Breach("Geofence: outside the inclusion circle", False)
    assert check(f, at(44, 0), (5, 0, 0)) == Breach("Geofence: approaching the inclusion circle boundary", True)
    assert check(f, at(44, 0), (2, 0, 0)) is None


def test_exclusion_circle():
    f = fence([item(0, CEXC, 20.0, 0.0, 100.0)])
    assert not f.has_inclusion and not f.empty
    assert f.inside(at(0, 0)) and f.inside(at(0, 79)) and not f.inside(at(0, 85)) and not f.inside(at(10, 100))
    assert check(f, at(0, 90)) == Breach("Geofence: inside the exclusion circle", False)
    assert check(f, at(0, 74), (0, 5, 0)) == Breach("Geofence: approaching the exclusion circle boundary", True)
    assert check(f, at(0, 74), (0, 2, 0)) is None


def test_two_inclusion_polygons_are_their_union():
    # east -50..50 and 40..140 overlap; a third one far north, apart from both
    items = square(INC, 50.0) + square(INC, 50.0, centre=(0.0, 90.0), seq0=4) + square(INC, 10.0, (300, 0), 8)
    f = fence(items)
    assert len(f.inclusion_polygons) == 3
    for n, e in [(0, 0), (0, 45), (0, 120), (300, 5)]:
        assert f.inside(at(n, e)), (n, e)
    for n, e in [(0, -60), (0, 150), (150, 0), (60, 45)]:
        assert not f.inside(at(n, e)), (n, e)
    assert check(f, at(0, 45), (0, 5, 0)) is None  # past the first's edge, inside the second
    assert predicted(check(f, at(0, 135), (0, 5, 0)))  # toward the second's far edge
    assert predicted(check(f, at(46, 0), (5, 0, 0)))  # toward the north edge of both


def test_polygon_and_circle_inclusions_are_named_together():
    f = fence(square(INC, 10.0) + [item(4, CINC, 10.0, 0.0, 100.0)])
    assert f.inside(at(0, 100)) and f.inside(at(5, 5)) and not f.inside(at(0, 50))
    assert check(f, at(0, 50)) == Breach("Geofence: outside the inclusion fence", False)


def zero_circle_at_0_0(seq: int, command: int = CINC) -> MissionItem:
    """What MAVSDK's users send for "no circle" (its GeofenceData carries polygons and circles together)."""
    return MissionItem(seq, mi.FRAME_GLOBAL_INT, command, 0.0, x=0, y=0, mission_type=mi.FENCE)


def test_a_circle_of_radius_0_encloses_nothing_and_is_left_out():
    """Issue 36: a polygon with MAVSDK's zero circle at (0, 0) is the polygon's fence; zero circles alone, none."""
    f = fence(square(INC, 10.0) + [zero_circle_at_0_0(4)])
    assert f.inside(at(5, 5)) and not f.inside(at(0, 50))
    assert check(f, at(0, 50)) == Breach("Geofence: outside the inclusion polygon", False)  # a polygon's only
    alone = fence([zero_circle_at_0_0(0), zero_circle_at_0_0(1, CEXC)])
    assert alone.empty and not alone.has_inclusion and alone.inside(at(0, 0))


def test_consecutive_polygons_of_the_same_kind():
    f = fence(square(EXC, 5.0, (20, 0)) + square(EXC, 5.0, (-20, 0), seq0=4))
    assert len(f.exclusion_polygons) == 2
    assert not f.inside(at(20, 0)) and not f.inside(at(-20, 0)) and f.inside(at(0, 0))


# ------------------------------------------------------------------------------------------ home limits


def test_empty_fence():
    f = fence([])
    assert f.empty and not f.has_inclusion and f.inside(at(1e4, -1e4))
    assert check(f, at(1e4, 0), (20, 0, -20)) is None  # no home limits either


def test_max_horizontal_distance():
    f = fence([])
    home = np.array([10.0, 0.0, 0.0])
    assert check(f, at(55, 0), home=home, max_hor=50) is None  # 45 m from home
    assert check(f, at(65, 0), home=home, max_hor=50) == Breach("Geofence: beyond max distance 50 m from home", False)
    assert check(f, at(54, 0), (5, 0, 0), home=home, max_hor=50) == Breach(
        "Geofence: approaching max distance 50 m from home", True
    )
    assert check(f, at(54, 0), (5, 0, 0), home=home, max_hor=50, predict=False) is None
    assert check(f, at(54, 0), (2, 0, 0), home=home, max_hor=50) is None
    assert check(f, at(65, 0), home=None, max_hor=50) is None  # no home: not checked
    assert check(f, at(65, 0), home=home, max_hor=0) is None  # 0: disabled


def test_max_height():
    f = fence([])
    home = np.array([0.0, 0.0, 2.0])  # home 2 m below the origin
    assert check(f, at(0, 0, -27), home=home, max_ver=30) is None  # 29 m above home
    assert check(f, at(0, 0, -29), home=home, max_ver=30) == Breach("Geofence: above max height 30 m", False)
    assert check(f, at(0, 0, -23), (0, 0, -5), home=home, max_ver=30) == Breach(
        "Geofence: approaching max height 30 m", True
    )  # 25 m + 6.25 m + 1 m
    assert check(f, at(0, 0, -20), (0, 0, -5), home=home, max_ver=30) is None  # 22 m + 7.25 m
    assert check(f, at(0, 0, -23), (0, 0, -5), home=home, max_ver=30, predict=False) is None
    assert check(f, at(0, 0, -23), (0, 0, -2), home=home, max_ver=30) is None  # 25 m + 1 m + 1 m
    assert check(f, at(0, 0, -27), (0, 0, 5), home=home, max_ver=30) is None  # descending: only upward counts
    assert check(f, at(0, 0, -27), (30, 0, 0), home=home, max_ver=30) is None  # horizontal speed: not upward
    assert check(f, at(0, 0, -40), home=None, max_ver=30) is None
    assert check(f, at(0, 0, -40), home=home, max_ver=0) is None


def test_an_actual_breach_comes_before_a_predicted_one():
    f = fence(square(INC, 50.0))
    home = np.zeros(3)
    b = check(f, at(46, 0, -31), (5, 0, 0), home=home, max_ver=30)
    assert b == Breach("Geofence: above max height 30 m", False)


# ------------------------------------------------------------------------------------------ bad fences


def bow_tie() -> list[MissionItem]:
    return polygon(INC, [(0, 0), (10, 10), (10, 0), (0, 10)])


@pytest.mark.parametrize(
    ("items", "seq", "why"),
    [
        (square(INC, 10.0)[:3], 0, "only 3"),  # 3 vertices of a polygon of 4
        (square(INC, 10.0)[:2] + square(EXC, 10.0)[2:], 0, "item 2 ends it"),  # the kind changes
        (square(INC, 10.0) + square(INC, 10.0, seq0=4)[:1], 4, "only 1"),  # one vertex too many
        (polygon(INC, [(0, 0), (10, 0)]), 0, ">= 3"),
        ([item(0, INC, float("nan"), 0, 0)] * 3, 0, ">= 3"),
        ([*square(INC, 10.0)[:3], item(3, INC, 5, 10, -10)], 0, "only 3"),  # a count that differs
        (bow_tie(), 0, "not simple"),
        ([item(0, CINC, 50.0, 0, 0), item(1, CINC, -0.5, 0, 0)], 1, "radius"),
        ([item(0, CEXC, -5.0, 0, 0)], 0, "radius"),
        ([item(0, CINC, float("nan"), 0, 0)], 0, "radius"),
        ([item(0, CEXC, float("inf"), 0, 0)], 0, "radius"),
        ([item(0, CINC, 50.0, 0, 0), item(1, mi.NAV_WAYPOINT, 0.0, 0, 0)], 1, "not a fence item"),
    ],
)
def test_bad_fences_raise_fence_error(items, seq, why):
    with pytest.raises(FenceError) as err:
        fence(items)
    assert f"item {seq} " in str(err.value) and why in str(err.value)
    assert isinstance(err.value, ValueError)
