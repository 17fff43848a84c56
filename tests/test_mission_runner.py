"""The mission runner and the commander's mission mode, on the commander bench (a point that follows
its setpoint): items in order, DO_JUMP repeats, speed changes, hold times, pause and resume at the same
item, the end of a mission, a mission refused while it is flown, DO_SET_HOME and the return to a rally
point."""

from __future__ import annotations

import math

import numpy as np

from autopilot.navigation.mission_leg import CORNER_OVERSHOOT_M, Leg, corner_speed
from mavsim_core import mission_items as mi
from mavsim_core.geodesy import ned_to_geodetic
from mavsim_core.mission_items import MissionItem
from mavsim_core.px4_modes import Mode

from test_commander import ORIGIN, Bench


def at(seq: int, north: float, east: float, alt: float = 5.0, command: int = mi.NAV_WAYPOINT, p1=0.0, p2=0.0,
       mtype: int = mi.MISSION) -> MissionItem:  # fmt: skip
    lat, lon, _ = ned_to_geodetic(np.array([north, east, 0.0]), ORIGIN[0], ORIGIN[1], ORIGIN[2])
    return MissionItem(seq, mi.FRAME_GLOBAL_RELATIVE_ALT_INT, command, p1, p2, 0, math.nan, round(lat * 1e7),
                       round(lon * 1e7), alt, mtype)  # fmt: skip


def flown(b: Bench, items: list[MissionItem], seconds: float = 120.0) -> Bench:
    b.run(1.0)
    assert b.cmd.plans.replace(mi.MISSION, items, False)[0] == mi.ACCEPTED
    b.cmd.arm()
    assert b.set_mode(Mode.AUTO_MISSION) == 0
    b.run(seconds)
    return b


def reached(b: Bench) -> list[int]:
    return [int(t.split()[2]) for t in b.texts() if t.startswith("Mission: item")]


def test_items_in_order_with_a_jump_repeated_and_the_landing():
    items = [at(0, 0, 0, command=mi.NAV_TAKEOFF), at(1, 10, 0), at(2, 10, 10),
             MissionItem(3, 2, mi.DO_JUMP, 1, 2), at(4, 0, 10), at(5, 0, 10, 0, mi.NAV_LAND)]  # fmt: skip
    b = flown(Bench(), items, 200)
    assert reached(b) == [0, 1, 2, 1, 2, 1, 2, 3, 4]  # jumped back twice, then the jump item is passed
    assert "Mission finished: landed" in b.texts() and not b.cmd.armed
    assert np.allclose(b.pos, [0, 10, 0], atol=0.3)


def test_speed_change_hold_time_and_the_end_holds():
    items = [at(0, 0, 0, command=mi.NAV_TAKEOFF), MissionItem(1, 2, mi.DO_CHANGE_SPEED, 1, 6.0, -1, 0),
             at(2, 30, 0, p1=4.0), at(3, 30, 30)]  # fmt: skip
    b = Bench()
    b.run(1.0)
    b.cmd.plans.replace(mi.MISSION, items, False)
    b.cmd.arm()
    b.set_mode(Mode.AUTO_MISSION)
    b.run(8.0)  # climbed, flying north at 6 m/s
    assert np.linalg.norm(b.vel[:2]) > 5.0
    while "Mission: item 2 reached" not in b.texts():
        b.run(0.1)
    b.run(2.0)
    assert np.linalg.norm(b.vel) < 0.01  # the 4 s hold at item 2
    b.run(30.0)
    assert b.cmd.status.mission.state.name == "COMPLETE" and b.cmd.armed and b.cmd.mode is Mode.AUTO_MISSION
    assert np.allclose(b.pos, [30, 30, -5], atol=0.3)


def test_pause_and_resume_at_the_same_item_and_no_new_mission_while_flying_it():
    items = [at(0, 0, 0, command=mi.NAV_TAKEOFF), at(1, 40, 0), at(2, 40, 40)]
    b = Bench()
    b.run(1.0)
    b.cmd.plans.replace(mi.MISSION, items, False)
    b.cmd.arm()
    b.set_mode(Mode.AUTO_MISSION)
    b.run(10.0)
    assert b.cmd.plans.current == 1
    assert b.cmd.plans.replace(mi.MISSION, items[:2], True)[0] == mi.DENIED
    b.set_mode(Mode.AUTO_LOITER)
    b.run(5.0)
    held = b.pos.copy()
    b.run(5.0)
    assert np.allclose(b.pos, held, atol=0.05) and b.cmd.status.mission.state.name == "PAUSED"
    b.set_mode(Mode.AUTO_MISSION)
    b.run(60.0)
    assert reached(b) == [0, 1, 2]


def test_a_corner_is_flown_without_stopping():
    items = [at(0, 0, 0, command=mi.NAV_TAKEOFF), at(1, 20, 0), at(2, 20, 20), at(3, 0, 20)]
    b = Bench()
    b.run(1.0)
    b.cmd.plans.replace(mi.MISSION, items, False)
    b.cmd.arm()
    b.set_mode(Mode.AUTO_MISSION)
    slowest = math.inf
    for _ in range(400):
        b.run(0.1)
        if np.linalg.norm(b.pos[:2] - [20, 0]) < 3.0:
            slowest = min(slowest, float(np.linalg.norm(b.vel[:2])))
    assert 0.5 < slowest  # a 90 degree corner at half the cruise speed, not a stop
    assert corner_speed(3.0, np.array([1.0, 0, 0]), np.array([0, 1.0, 0])) == 1.5


def test_corner_speed_keeps_the_swing_past_a_sharp_corner_small_and_straight_on_is_cruise():
    north, east = np.array([1.0, 0, 0]), np.array([0, 1.0, 0])
    v = corner_speed(5.0, north, east, 4.0)  # a 90 degree corner: v^2 / 2a = CORNER_OVERSHOOT_M
    assert math.isclose(v * v / (2 * 4.0), CORNER_OVERSHOOT_M)
    assert corner_speed(5.0, north, north, 4.0) == 5.0
    assert corner_speed(5.0, north, -north, 4.0) == 0.0
    shallow = np.array([math.cos(0.2), math.sin(0.2), 0.0])
    assert corner_speed(5.0, north, shallow, 4.0) == corner_speed(5.0, north, shallow)  # cos^2 rule is lower


def test_leg_profile_enters_and_leaves_at_speed():
    leg = Leg(np.zeros(3), np.array([10.0, 0, 0]), 1.0, 1.5, 3.0, 2.0, 0)
    s0, v0, _ = leg.profile(0.0)
    s1, v1, _ = leg.profile(leg.duration_s)
    assert (s0, v0) == (0.0, 1.0) and s1 == 10.0 and math.isclose(v1, 1.5)
    assert max(leg.profile(t / 10)[1] for t in range(int(leg.duration_s * 10))) <= 3.0 + 1e-9


def test_return_goes_to_the_closer_rally_point_and_do_set_home_moves_home():
    b = Bench()
    b.run(1.0)
    b.cmd.plans.replace(mi.RALLY, [at(0, 25, 0, 0, mi.RALLY_POINT, mtype=mi.RALLY)], False)
    items = [at(0, 0, 0, command=mi.NAV_TAKEOFF), at(1, 20, 0), MissionItem(2, 2, mi.DO_SET_HOME, 1),
             at(3, 20, 5)]  # fmt: skip
    flown(b, items, 40)
    assert np.allclose(b.cmd.home.pos_ned_m[:2], [20, 0], atol=0.5)  # DO_SET_HOME 1: here
    b.cmd.home = b.cmd.home.__class__(ORIGIN[0], ORIGIN[1], ORIGIN[2], np.zeros(3), 0.0)  # home back at the start
    b.set_mode(Mode.AUTO_RTL)
    b.run(60)
    assert np.allclose(b.pos, [25, 0, 0], atol=0.3) and not b.cmd.armed
