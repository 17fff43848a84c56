"""The mission's landing (issue 36, item 3): MAV_CMD_DO_LAND_START as a command, the return types RTL_TYPE
1-3 as PX4 1.14 defines them, and a mission's precision landing kept in AUTO.MISSION.

The commander of ``test_commander.Bench`` (a point that goes where the setpoint says, home at the origin,
the ground at down = 0); commands go through the MAVLink command table as a ground station's would, and
the tests read what a ground station sees: the MAV_RESULT, the STATUSTEXTs, the mode, where it landed.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink
from test_commander_precland import _fly_with_target
from test_mission_runner import at, reached

from autopilot.navigation.mission_checks import check_item
from autopilot.navigation.rtl_mission import ReturnKind, choose_return, landing_sequence, reverse_items
from autopilot.topics import HomePosition
from mavsim_core import mission_items as mi
from mavsim_core.mission_items import MissionItem
from mavsim_core.px4_modes import Mode

from test_commander import ACCEPTED, DENIED, ORIGIN, Bench

LAND_START = mavlink.MAV_CMD_DO_LAND_START


def marker(seq: int) -> MissionItem:
    return MissionItem(seq, mi.FRAME_MISSION, mi.DO_LAND_START)


# A survey out to the north-east, then its landing sequence: a marker, an approach point and the landing.
SURVEY = [at(0, 0, 0, command=mi.NAV_TAKEOFF), at(1, 20, 0), at(2, 20, 20), at(3, 40, 20), marker(4),
          at(5, 10, 10), at(6, 10, 10, 0, mi.NAV_LAND)]  # fmt: skip


def airborne_with(items: list[MissionItem], params: dict[str, float] | None = None) -> Bench:
    """Holding at MIS_TAKEOFF_ALT over home with ``items`` stored as the mission."""
    b = Bench()
    for name, value in (params or {}).items():
        b.params.set(name, value)
    b.fly_up()
    assert b.cmd.plans.replace(mi.MISSION, items, False)[0] == mi.ACCEPTED
    return b


def run_until_landed(b: Bench, seconds: float = 120.0) -> list[Mode]:
    """Run until disarmed (at most ``seconds``); the modes flown, in order."""
    modes: list[Mode] = []
    for _ in range(round(seconds / 0.5)):
        b.run(0.5)
        if not modes or modes[-1] is not b.cmd.mode:
            modes.append(b.cmd.mode)
        if not b.cmd.armed:
            break
    return modes


def closest(track: list[np.ndarray], north: float, east: float) -> float:
    return min(math.hypot(p[0] - north, p[1] - east) for p in track)


def test_landing_sequence_is_the_first_marker_a_landing_follows_else_the_first_landing():
    land = at(0, 5, 5, 0, mi.NAV_LAND)
    wp = at(0, 1, 1)
    assert landing_sequence(SURVEY) == (4, 6)
    assert landing_sequence([wp, land.renumbered(1)]) == (1, 1)  # no marker: the NAV_LAND itself (PX4)
    assert landing_sequence([wp, marker(1), wp.renumbered(2)]) is None  # a marker without a landing after it
    assert landing_sequence([land, marker(1), wp.renumbered(2), land.renumbered(3)]) == (1, 3)
    assert landing_sequence([wp]) is None and landing_sequence([]) is None


def test_a_do_land_start_marker_is_accepted_at_upload_in_any_frame_a_position_in_a_global_one():
    for frame in (mi.FRAME_MISSION, mi.FRAME_GLOBAL_RELATIVE_ALT, mi.FRAME_GLOBAL_INT):  # QGC and MAVProxy send 2 or 3
        assert check_item(MissionItem(0, frame, mi.DO_LAND_START), ORIGIN[2], 1000.0)[0] == mi.ACCEPTED
    with_position = MissionItem(0, mi.FRAME_MISSION, mi.DO_LAND_START, x=473977420, y=85455940)
    assert check_item(with_position, ORIGIN[2], 1000.0)[0] == mi.UNSUPPORTED_FRAME


@pytest.mark.parametrize(
    "rtl_type, landing, rally, has_mission, kind, to",
    [
        (0, (30, 0), [], True, ReturnKind.DIRECT, (0, 0)),  # the mission landing is not considered
        (0, None, [(45, 0)], True, ReturnKind.DIRECT, (45, 0)),  # a rally point closer than home
        (1, (-30, 0), [], True, ReturnKind.MISSION_LANDING, (-30, 0)),  # even farther than home
        (1, (-30, 0), [(45, 0)], True, ReturnKind.DIRECT, (45, 0)),  # a rally point closer than the landing
        (1, None, [], True, ReturnKind.DIRECT, (0, 0)),  # neither: home
        (2, (-30, 0), [(45, 0)], True, ReturnKind.MISSION_FORWARD, (-30, 0)),  # no rally points in type 2
        (2, None, [], True, ReturnKind.MISSION_REVERSE, (0, 0)),
        (2, None, [], False, ReturnKind.DIRECT, (0, 0)),  # no mission at all: straight home
        (3, (45, 0), [(-40, 0)], True, ReturnKind.MISSION_LANDING, (45, 0)),  # closest of the three
        (3, (-30, 0), [], True, ReturnKind.DIRECT, (0, 0)),
    ],
)
def test_choose_return_as_px4_rtl_type(rtl_type, landing, rally, has_mission, kind, to):
    pos = np.array([50.0, 0.0, -10.0])
    got = choose_return(
        rtl_type,
        pos,
        np.zeros(3),
        [np.array([*p, 0.0]) for p in rally],
        None if landing is None else np.array([*landing, 0.0]),
        has_mission,
    )
    assert got[0] is kind and np.allclose(got[1][:2], to)


def test_reverse_items_go_back_through_the_positions_then_land_at_home():
    home = HomePosition(ORIGIN[0], ORIGIN[1], ORIGIN[2], np.zeros(3), 0.0)
    items = [at(0, 0, 0, command=mi.NAV_TAKEOFF), at(1, 20, 0, p1=5.0), MissionItem(2, 2, mi.DO_JUMP, 1, 1),
             at(3, 20, 20, command=mi.NAV_LOITER_TIME, p1=30.0), at(4, 40, 20)]  # fmt: skip
    back = reverse_items(items, 3, home)
    assert [it.command for it in back] == [mi.NAV_WAYPOINT, mi.NAV_WAYPOINT, mi.NAV_WAYPOINT, mi.NAV_LAND]
    assert [it.seq for it in back] == [0, 1, 2, 3] and all(it.param1 == 0 for it in back)  # no holds, no loiter
    assert (back[0].x, back[1].x, back[2].x) == (items[3].x, items[1].x, items[0].x)
    assert (back[-1].lat_deg, back[-1].lon_deg) == pytest.approx(ORIGIN[:2])


# ---------------------------------------------------------------------------------- DO_LAND_START


def test_do_land_start_is_refused_on_the_ground_and_without_a_landing_with_a_reason():
    b = Bench()
    b.run(1.0)
    b.cmd.plans.replace(mi.MISSION, SURVEY, False)
    assert b.command(LAND_START) == DENIED
    assert b.texts()[-1] == "Mission landing denied: vehicle not flying"
    b = airborne_with(SURVEY[:4])  # no landing in it
    assert b.command(LAND_START) == DENIED
    assert b.texts()[-1] == "Mission landing denied: the mission has no landing (DO_LAND_START, NAV_LAND)"
    assert b.cmd.status.mode is Mode.AUTO_LOITER  # nothing changed


def test_do_land_start_in_a_mission_skips_to_the_landing_sequence_and_lands_where_the_mission_says():
    b = Bench()
    b.run(1.0)
    b.cmd.plans.replace(mi.MISSION, SURVEY, False)
    b.cmd.arm()
    b.set_mode(Mode.AUTO_MISSION)
    while "Mission: item 1 reached" not in b.texts():
        b.run(0.1)
    assert b.command(LAND_START) == ACCEPTED
    assert "Mission landing: from item 4, landing at item 6" in b.texts()
    track = []
    for k in range(600):
        b.run(0.2)
        track.append(b.pos.copy())
        if k == 10:
            assert b.command(LAND_START) == ACCEPTED  # again on the way: it goes on
        if not b.cmd.armed:
            break
    assert "Mission landing: already flying it" in b.texts()
    assert reached(b) == [0, 1, 4, 5] and "Mission finished: landed" in b.texts()  # 2, 3 skipped
    assert np.allclose(b.pos, [10, 10, 0], atol=0.3) and not b.cmd.armed
    assert closest(track, 20, 20) > 5.0 and closest(track, 40, 20) > 10.0  # the rest of the survey skipped


def test_do_land_start_from_a_hold_flies_the_landing_in_auto_mission():
    b = airborne_with(SURVEY)
    assert b.command(LAND_START) == ACCEPTED
    assert b.cmd.status.mode is Mode.AUTO_MISSION
    assert run_until_landed(b)[-1] is Mode.AUTO_MISSION
    assert np.allclose(b.pos, [10, 10, 0], atol=0.3) and reached(b) == [4, 5]


# ---------------------------------------------------------------------------------- RTL_TYPE


def test_rtl_type_1_climbs_then_flies_the_mission_landing_in_auto_rtl():
    b = airborne_with(SURVEY, {"RTL_TYPE": 1, "RTL_RETURN_ALT": 8.0})
    assert b.set_mode(Mode.AUTO_RTL) == ACCEPTED
    assert "Return: through the mission landing (items 4-6)" in b.texts()
    track = _fly_until_disarmed(b)
    assert b.cmd.mode is Mode.AUTO_RTL and np.allclose(b.pos, [10, 10, 0], atol=0.3) and not b.cmd.armed
    assert min(p[2] for p in track) == pytest.approx(-8.0, abs=0.3)  # climbed to RTL_RETURN_ALT first ...
    climb_end = next(k for k, p in enumerate(track) if p[2] < -7.9)
    assert np.linalg.norm(track[climb_end][:2]) < 0.3  # ... where it was
    assert b.cmd.plans.current == 0 and reached(b) == []  # the stored mission's progress is left alone


def test_rtl_type_1_without_a_mission_landing_goes_home_and_type_0_ignores_the_landing():
    for rtl_type, items in ((1, SURVEY[:4]), (0, SURVEY)):
        b = airborne_with(items, {"RTL_TYPE": rtl_type})
        b.command(mavlink.MAV_CMD_DO_REPOSITION, -1, 1, 0, math.nan, *_latlon(15, 5), math.nan)
        b.run(15.0)
        assert b.set_mode(Mode.AUTO_RTL) == ACCEPTED
        run_until_landed(b)
        assert np.allclose(b.pos, [0, 0, 0], atol=0.3) and not b.cmd.armed, rtl_type


def _rtl_type_2_after(mission: list, reached: int):
    """A bench flying ``mission`` with RTL_TYPE 2, switched to AUTO.RTL once item ``reached`` is reached."""
    b = Bench()
    b.params.set("RTL_TYPE", 2)
    b.run(1.0)
    b.cmd.plans.replace(mi.MISSION, mission, False)
    b.cmd.arm()
    b.set_mode(Mode.AUTO_MISSION)
    while f"Mission: item {reached} reached" not in b.texts():
        b.run(0.1)
    assert b.set_mode(Mode.AUTO_RTL) == ACCEPTED
    return b


def test_rtl_type_2_flies_the_rest_of_the_mission_to_its_landing():
    b = _rtl_type_2_after(SURVEY, 1)
    assert "Return: along the mission from item 2 to its landing (item 6)" in b.texts()
    track = _fly_until_disarmed(b)
    assert closest(track, 20, 20) < 2.0 and closest(track, 40, 20) < 2.0  # items 2 and 3 flown ...
    assert np.allclose(b.pos, [10, 10, 0], atol=0.3) and b.cmd.mode is Mode.AUTO_RTL  # ... then the landing


def test_rtl_type_2_without_a_landing_flies_the_mission_backwards_then_lands_at_home():
    b = _rtl_type_2_after(SURVEY[:4], 2)
    assert "Return: the mission backwards from item 2, then home" in b.texts()
    track = _fly_until_disarmed(b)
    assert closest(track, 20, 0) < 1.0 and closest(track, 40, 20) > 15.0  # back through item 1, not on to 3
    assert np.allclose(b.pos, [0, 0, 0], atol=0.3) and not b.cmd.armed


def _latlon(north: float, east: float) -> tuple[float, float]:
    from mavsim_core.geodesy import ned_to_geodetic

    lat, lon, _ = ned_to_geodetic(np.array([north, east, 0.0]), *ORIGIN)
    return lat, lon


# ---------------------------------------------------------------------------------- precision landing


def test_a_missions_precision_landing_stays_in_auto_mission_and_docks():
    pad = np.array([10.3, 9.8, -0.3])  # a deck 0.3 m up beside the mission's landing point
    land = at(2, 10, 10, 0, mi.NAV_LAND, p2=2)  # param2 2: required precision landing
    b = airborne_with([at(0, 0, 0, command=mi.NAV_TAKEOFF), at(1, 10, 10), land])
    assert b.set_mode(Mode.AUTO_MISSION) == ACCEPTED
    modes = {b.cmd.mode}
    for _ in range(60 * 5):
        _fly_with_target(b, pad, 0.2)
        modes.add(b.cmd.mode)
        if b.cmd.status.landed_state.name == "LANDING":
            assert b.cmd.task.phase is not None or b.cmd.task.land is not None
        if not b.cmd.armed:
            break
    assert modes == {Mode.AUTO_MISSION}  # never AUTO.PRECLAND, as PX4's mission keeps its mode
    assert any(t.startswith("Precland: docking") for t in b.texts())
    assert "Disarmed (docked on the landing target)" in b.texts() and "Mission finished: landed" in b.texts()
    assert np.linalg.norm(b.pos[:2] - pad[:2]) < 0.05
    assert b.cmd.status.mission.state.name == "COMPLETE"


def _fly_until_disarmed(b, most_s: float = 120.0) -> list:
    """The positions every 0.2 simulated seconds until the vehicle disarms (at most ``most_s``)."""
    track = []
    for _ in range(round(most_s / 0.2)):
        b.run(0.2)
        track.append(b.pos.copy())
        if not b.cmd.armed:
            break
    return track
