"""The jerk-limited trajectory generator (autopilot/navigation/trajectory.py): limits, exact arrival, replanning."""

from __future__ import annotations

import numpy as np
import pytest

from autopilot.navigation.trajectory import AxisMove, Limits, LineProfile, Move, velocity_change

DT = 0.002
LIM = Limits(5.0, 4.0, 10.0)


def sampled(move: Move, dt: float = DT) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Times, positions, velocities, accelerations from the start to 0.5 s past the end."""
    t = np.arange(0.0, move.duration_s + 0.5, dt)
    rows = [move.sample(x) for x in t]
    return t, np.array([r[0] for r in rows]), np.array([r[1] for r in rows]), np.array([r[2] for r in rows])


def norms(a: np.ndarray) -> np.ndarray:
    return np.linalg.norm(a, axis=1)


@pytest.mark.parametrize(
    "goal",
    [(10.0, 0.0, 0.0), (25.0, -17.0, -3.0), (0.3, 0.2, 0.0), (-2.0, 1.0, 4.0)],
    ids=["10 m north", "long diagonal", "short hop", "down and back"],
)
def test_move_from_rest_keeps_every_limit_flies_a_straight_line_and_ends_exactly_at_rest(goal):
    start, goal = np.array([1.0, 2.0, -5.0]), np.array([1.0, 2.0, -5.0]) + goal
    move = Move(start, np.zeros(3), np.zeros(3), goal, LIM)
    t, p, v, a = sampled(move)
    assert norms(v).max() <= LIM.speed_m_s + 1e-9
    assert norms(a).max() <= LIM.accel_m_s2 + 1e-9
    jerk = norms(np.diff(a, axis=0)) / DT
    assert jerk.max() <= LIM.jerk_m_s3 * (1 + 1e-6)
    # continuous: the position moves as the velocity says, the velocity as the acceleration says
    assert norms(np.diff(p, axis=0)).max() <= LIM.speed_m_s * DT + 1e-9
    assert norms(np.diff(v, axis=0)).max() <= LIM.accel_m_s2 * DT + 1e-9
    direction = (goal - start) / np.linalg.norm(goal - start)
    off_line = (p - start) - np.outer((p - start) @ direction, direction)
    assert norms(off_line).max() < 1e-9
    assert ((p - start) @ direction).max() <= np.linalg.norm(goal - start) + 1e-9  # no overshoot
    end = t >= move.duration_s
    assert end.any() and np.array_equal(p[end][0], goal) and not v[end].any() and not a[end].any()
    # just before the end it is already there (no creeping tail)
    p_end, v_end, a_end = move.sample(move.duration_s - 1e-6)
    assert np.linalg.norm(p_end - goal) < 1e-6 and np.linalg.norm(v_end) < 1e-4 and np.linalg.norm(a_end) < 1e-4


def test_a_long_move_reaches_the_cruise_speed_and_the_acceleration_limit_and_takes_the_s_curve_time():
    move = Move(np.zeros(3), np.zeros(3), np.zeros(3), np.array([30.0, 0.0, 0.0]), LIM)
    _, _, v, a = sampled(move)
    assert norms(v).max() == pytest.approx(LIM.speed_m_s)
    assert norms(a).max() == pytest.approx(LIM.accel_m_s2)
    v_, a_, j_ = LIM.speed_m_s, LIM.accel_m_s2, LIM.jerk_m_s3
    assert move.duration_s == pytest.approx(30.0 / v_ + v_ / a_ + a_ / j_)


def test_a_goal_changed_mid_move_is_followed_smoothly_from_the_state_it_was_in():
    first = Move(np.zeros(3), np.zeros(3), np.zeros(3), np.array([20.0, 0.0, 0.0]), LIM)
    t_change = 1.2  # accelerating north
    p0, v0, a0 = first.sample(t_change)
    assert v0[0] > 1.0 and a0[0] > 1.0
    goal = np.array([p0[0], 8.0, 0.0])  # now due east of where it is
    second = Move(p0, v0, a0, goal, LIM)
    p1, v1, a1 = second.sample(0.0)
    assert p1 == pytest.approx(p0) and v1 == pytest.approx(v0) and a1 == pytest.approx(a0)  # no jump
    _, p, v, a = sampled(second)
    # each axis keeps its share of the limits; the norms may pass them by a little while the axis that was
    # accelerating ramps its acceleration down (the jerk limit) and the new one speeds up
    assert norms(v).max() <= 1.1 * LIM.speed_m_s
    assert norms(a).max() <= 1.1 * LIM.accel_m_s2
    assert (norms(np.diff(a, axis=0)) / DT).max() <= LIM.jerk_m_s3 * (1 + 1e-6)
    assert np.array_equal(p[-1], goal) and not v[-1].any()


def test_an_axis_braking_at_the_start_gets_the_share_it_needs_and_does_not_dive():
    # a go-to 15 m north sent as a take-off's climb brakes (0.1 m/s up, 1 m/s^2 down, NED), at the same height:
    # the vertical axis once got a 5 % share, needed 2 s to end the braking and dived 4.4 m
    start, goal = np.array([0.0, 0.0, -4.92]), np.array([15.0, 0.0, -4.98])
    move = Move(start, np.array([0.0, 0.0, -0.1]), np.array([0.0, 0.0, 1.0]), goal, LIM)
    _, p, v, a = sampled(move)
    assert p[:, 2].max() < -4.85 and p[:, 2].min() > -5.0  # within 7 cm of the start height, not below the goal
    assert norms(v).max() <= 1.1 * LIM.speed_m_s and norms(a).max() <= 1.1 * LIM.accel_m_s2
    assert np.array_equal(p[-1], goal) and not v[-1].any()


@pytest.mark.parametrize("seed", range(5))
def test_a_move_from_any_moving_state_reaches_its_goal_on_every_axis_without_a_jump(seed):
    # e.g. a climb asked while cruising north at full speed: the cruise needs the whole share of the limits,
    # and a version that gave the climb none kept it where it was and jumped to the goal at the end
    rng = np.random.default_rng(seed)
    cases = [(np.array([5.0, 0.0, 0.0]), np.zeros(3), np.array([20.0, 0.0, -10.0]))]
    cases += [(rng.uniform(-5, 5, 3), rng.uniform(-4, 4, 3), rng.uniform(-20, 20, 3)) for _ in range(6)]
    for vel, acc, goal in cases:
        move = Move(np.zeros(3), vel, acc, goal, LIM)
        assert all(ax.goal == g for ax, g in zip(move.axes, goal))  # every axis plans to its goal
        _, p, v, _ = sampled(move)
        assert (norms(np.diff(p, axis=0)) / DT).max() <= 2.0 * LIM.speed_m_s  # no step anywhere
        assert np.array_equal(p[-1], goal) and not v[-1].any()


@pytest.mark.parametrize("seed", range(3))
def test_one_axis_from_any_state_ends_on_its_goal_at_rest(seed):
    rng = np.random.default_rng(seed)
    for _ in range(100):
        lim = Limits(rng.uniform(0.5, 6.0), rng.uniform(0.5, 5.0), rng.uniform(1.0, 20.0))
        v0 = rng.uniform(-1.0, 1.0) * lim.speed_m_s
        a0 = rng.uniform(-1.0, 1.0) * lim.accel_m_s2
        goal = rng.uniform(-20.0, 20.0)
        ax = AxisMove(0.0, v0, a0, goal, lim)
        p, v, a, _ = ax.sample(ax.duration_s - 1e-9)
        assert abs(p - goal) < 1e-5 and abs(v) < 1e-5 and abs(a) < 1e-5
        _, v, a, j = np.abs(np.array([ax.sample(x) for x in np.linspace(0.0, ax.duration_s, 100)])).max(axis=0)
        # (an accelerating start passes the speed limit by what ramping the acceleration to zero adds)
        v_stop = abs(v0 + a0 * abs(a0) / (2 * lim.jerk_m_s3))
        assert v <= max(lim.speed_m_s, v_stop) + 1e-6 and a <= lim.accel_m_s2 + 1e-6 and j <= lim.jerk_m_s3 + 1e-9


def test_velocity_change_reaches_the_target_speed_with_zero_acceleration():
    for v0, a0, v1 in [(0.0, 0.0, 5.0), (3.0, 2.0, 0.0), (-1.0, -3.0, 4.0), (2.0, 1.0, 2.05)]:
        v, a = v0, a0
        for dur, j in velocity_change(v0, a0, v1, 4.0, 10.0):
            assert dur >= 0 and abs(j) <= 10.0
            v, a = v + a * dur + j * dur * dur / 2, a + j * dur
        assert v == pytest.approx(v1, abs=1e-9) and a == pytest.approx(0.0, abs=1e-9)


def test_shift_moves_the_whole_trajectory():
    move = Move(np.zeros(3), np.zeros(3), np.zeros(3), np.array([10.0, 0.0, 0.0]), LIM)
    before = move.sample(1.0)[0]
    move.shift(np.array([0.0, 2.0, -1.0]))
    assert move.sample(1.0)[0] - before == pytest.approx([0.0, 2.0, -1.0])
    assert np.array_equal(move.sample(99.0)[0], [10.0, 2.0, -1.0])


def test_no_distance_and_nan_start_state_give_a_move_that_is_already_over():
    move = Move(np.ones(3), np.full(3, np.nan), np.zeros(3), np.ones(3), LIM)
    assert move.duration_s == 0.0
    p, v, a = move.sample(0.0)
    assert np.array_equal(p, np.ones(3)) and not v.any() and not a.any()


def _line_samples(line: LineProfile, dt: float = 0.002) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Times from the start to ``duration_s`` (included) and distance, speed and acceleration at each."""
    times = np.append(np.arange(0.0, line.duration_s, dt), line.duration_s)
    rows = np.array([line.sample(float(t)) for t in times])
    return times, rows[:, 0], rows[:, 1], rows[:, 2]


@pytest.mark.parametrize(
    ("length", "v_in", "v_out"),
    [(10.0, 1.0, 1.5), (30.0, 0.0, 0.0), (30.0, 5.0, 2.5), (40.0, 5.0, 5.0), (3.0, 0.0, 0.0)],
)
def test_a_line_profile_enters_and_leaves_at_speed_within_every_limit(length, v_in, v_out):
    """A mission leg's speed along its line: from v_in to v_out (both at zero acceleration), the distance
    ending exactly on the line's end, speed, acceleration and jerk within the limits, no acceleration step."""
    lim = Limits(5.0, 2.0, 4.0)
    line = LineProfile(length, v_in, v_out, lim)
    t, s, v, a = _line_samples(line)
    assert (line.v_in, line.v_out) == (v_in, v_out)
    assert line.sample(0.0) == (0.0, v_in, 0.0) and line.sample(line.duration_s) == (length, v_out, 0.0)
    assert s[-1] == length and np.all(np.diff(s) >= -1e-12)
    assert v.max() <= lim.speed_m_s + 1e-9 and np.abs(a).max() <= lim.accel_m_s2 + 1e-9
    assert np.all(np.abs(np.diff(a)) <= lim.jerk_m_s3 * np.diff(t) + 1e-9)  # continuous: the jerk bounds each step
    np.testing.assert_allclose(np.diff(s), (v[1:] + v[:-1]) / 2 * np.diff(t), atol=1e-5)  # speed is the slope


def test_a_line_too_short_for_the_speeds_lowers_them_rather_than_overshoot():
    lim = Limits(5.0, 2.0, 4.0)
    faster = LineProfile(1.0, 0.0, 5.0, lim)  # cannot reach 5 m/s in 1 m
    assert 0.0 < faster.v_out < 5.0 and faster.sample(faster.duration_s)[0] == 1.0
    assert max(_line_samples(faster)[1]) <= 1.0
    braking = LineProfile(1.0, 5.0, 0.0, lim)  # cannot stop from 5 m/s in 1 m: the entry speed is lowered
    assert 0.0 < braking.v_in < 5.0 and braking.v_out == 0.0
    assert max(_line_samples(braking)[1]) <= 1.0
    still = LineProfile(0.0, 0.0, 0.0, lim)
    assert still.duration_s == 0.0 and still.sample(1.0) == (0.0, 0.0, 0.0)
