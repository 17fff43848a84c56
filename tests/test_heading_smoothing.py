"""Automatic heading changes (issue 36): the heading trajectory of autopilot/navigation/heading_smoothing.py, the
go-to that flies it, and the yaw axis of each vehicle flying a go-to's heading change through the real attitude
and rate controllers and mixer.

The last is the mechanism: a heading handed to the attitude loop as a step makes it ask for MC_YAW_P x the error
(up to MC_YAWRATE_MAX); the vehicle speeds up as fast as its yaw authority lets it and, slowing down later than
that authority can stop it, sails past the heading (17 deg on the quadcopter, 40 deg on the hexacopter in
benchmarks/heading_benchmark.py).  A heading that turns at MPC_YAWRAUTO_MAX and MPC_YAWRAUTO_ACC, its rate fed
forward, stops on it.  Radians and seconds inside, degrees in the figures.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from autopilot.control.attitude_control import with_yaw_rate
from autopilot.control.gains_from_params import GainsFromParams
from autopilot.control.mixer import Mixer
from autopilot.navigation.goto import GotoTask
from autopilot.navigation.heading_smoothing import (
    HeadingLimits,
    HeadingSmoothing,
    stopping_rate,
    yaw_rate_of,
)
from autopilot.param_catalogue import default_store
from autopilot.param_storage import load_file
from autopilot.topics import VehicleEstimate
from mavsim_core.constants import GRAVITY_M_S2
from mavsim_core.quaternion import from_euler, wrap_pi
from params.vehicle import load_vehicle

DT_S = 0.02  # the commander's outer loop
LIMITS = HeadingLimits(math.radians(45.0), math.radians(60.0))  # PX4's MPC_YAWRAUTO_MAX and _ACC defaults
VEHICLES = Path(__file__).resolve().parents[1] / "params" / "vehicles"


def fly(h: HeadingSmoothing, target: float, seconds: float, shortest: bool = True) -> np.ndarray:
    """(heading unwrapped, rate) after each step of ``seconds`` of steps toward ``target``."""
    out = []
    for _ in range(round(seconds / DT_S)):
        h.update(target, DT_S, shortest)
        out.append((h.heading_rad, h.rate_rad_s))
    return np.array(out)


@pytest.mark.parametrize("turn_deg", [90.0, -90.0, 150.0, 10.0, -179.0])
def test_a_turn_keeps_to_the_rate_and_acceleration_and_stops_on_the_heading(turn_deg):
    start = 0.3
    target = wrap_pi(start + math.radians(turn_deg))
    h = HeadingSmoothing(LIMITS, start)
    path = fly(h, target, 6.0)
    heading, rate = path[:, 0], path[:, 1]
    acc = np.diff(np.concatenate([[0.0], rate])) / DT_S
    assert np.abs(rate).max() <= LIMITS.rate_rad_s + 1e-12
    assert np.abs(acc).max() <= LIMITS.acc_rad_s2 * (1 + 1e-9)
    past = math.copysign(1.0, turn_deg) * (heading - (start + math.radians(turn_deg)))
    assert past.max() <= math.radians(0.01)  # never past the target (by a hundredth of a degree at most)
    assert h.on_target and h.rate_rad_s == 0.0 and h.yaw_rad == target  # stopped exactly on it
    # as fast as the limits allow: at MPC_YAWRAUTO_MAX once up to speed, done within a step of the plan
    turn, v, a = abs(math.radians(turn_deg)), LIMITS.rate_rad_s, LIMITS.acc_rad_s2
    plan = turn / v + v / a if turn >= v * v / a else 2 * math.sqrt(turn / a)
    arrived = DT_S * (1 + int(np.argmax(np.isclose(heading, start + math.radians(turn_deg), atol=1e-12))))
    assert arrived == pytest.approx(plan, abs=2 * DT_S)


def test_the_shorter_way_round_across_180_and_any_way_when_told():
    h = HeadingSmoothing(LIMITS, math.radians(170.0))
    path = fly(h, math.radians(-170.0), 3.0)  # 20 deg clockwise across 180, not 340 the other way
    turning = path[path[:, 1] != 0.0, 0]
    assert np.all(np.diff(turning) > 0) and math.degrees(turning.max()) == pytest.approx(190.0, abs=0.1)
    assert h.on_target and h.yaw_rad == math.radians(-170.0)
    h = HeadingSmoothing(LIMITS, 0.0)
    path = fly(h, math.radians(-300.0), 9.0, shortest=False)  # 300 deg counter-clockwise, as given
    assert np.all(np.diff(path[:, 0]) <= 1e-12) and math.degrees(h.heading_rad) == pytest.approx(-300.0)


def test_started_turning_the_other_way_it_slows_down_at_the_limit_first():
    h = HeadingSmoothing(LIMITS, 0.0, rate_rad_s=-LIMITS.rate_rad_s)
    path = fly(h, math.radians(90.0), 6.0)
    acc = np.diff(np.concatenate([[-LIMITS.rate_rad_s], path[:, 1]])) / DT_S
    assert np.abs(acc).max() <= LIMITS.acc_rad_s2 * (1 + 1e-9)
    assert path[:, 0].min() == pytest.approx(-(LIMITS.rate_rad_s**2) / (2 * LIMITS.acc_rad_s2), rel=0.05)
    assert h.on_target and h.heading_rad == pytest.approx(math.radians(90.0))


def test_no_target_or_no_time_leaves_it_where_it_is():
    h = HeadingSmoothing(LIMITS, 1.0, rate_rad_s=0.2)
    for target, dt in ((math.nan, DT_S), (2.0, 0.0), (2.0, -DT_S)):
        assert h.update(target, dt) == 1.0 and h.rate_rad_s == 0.2


def test_the_braking_curve_stops_within_the_distance():
    a, dt = math.radians(60.0), DT_S
    for dist in (0.0, 1e-4, 0.01, 0.3, 2.0):
        v, covered = stopping_rate(dist, a, dt), 0.0
        while v > 1e-12:
            covered += v * dt
            v = max(0.0, v - a * dt)
        assert covered == pytest.approx(dist, abs=1e-12)  # exactly: stopping on the target, not past it


def test_the_vehicles_yaw_rate_about_down_whatever_its_attitude():
    level = from_euler(0.0, 0.0, 1.0)
    assert yaw_rate_of(level, np.array([0.3, -0.2, 0.5])) == pytest.approx(0.5)
    rolled = from_euler(math.pi / 2, 0.0, 0.0)  # rolled right 90 deg: NED down is body y
    assert yaw_rate_of(rolled, np.array([0.0, 0.4, 0.0])) == pytest.approx(0.4)


def estimate(t_us: int, yaw: float, rate: float = 0.0) -> VehicleEstimate:
    return VehicleEstimate(
        timestamp_us=t_us, q_wxyz=from_euler(0.0, 0.0, yaw), rate_frd_rad_s=np.array([0.0, 0.0, rate]),
        accel_ned_m_s2=np.zeros(3), pos_ned_m=np.array([0.0, 0.0, -5.0]), vel_ned_m_s=np.zeros(3),
        attitude_valid=True, position_valid=True, origin_lat_deg=47.4, origin_lon_deg=8.5, origin_alt_amsl_m=500.0,
        yaw_rad=yaw,
    )  # fmt: skip


def test_a_goto_turns_its_heading_at_the_limits_and_feeds_its_rate_forward():
    """DO_REPOSITION with only a new yaw: the setpoint's heading moves at most MPC_YAWRAUTO_MAX (it was a step of
    90 deg to the attitude loop before issue 36), its rate is the setpoint's yaw_rate_rad_s, and it ends on the
    heading asked for."""
    task = GotoTask(np.array([0.0, 0.0, -5.0]), math.radians(90.0), 5.0, 4.0, heading=LIMITS)
    t = 1_000_000
    task.activate(estimate(t, 0.0), t)
    yaws, rates = [], []
    for _ in range(200):
        t += round(DT_S * 1e6)
        sp = task.update(estimate(t, 0.0), t)
        yaws.append(sp.yaw_rad)
        rates.append(sp.yaw_rate_rad_s)
    steps = np.diff(np.concatenate([[0.0], yaws]))
    assert np.abs(steps).max() <= LIMITS.rate_rad_s * DT_S + 1e-12  # no step: at most the rate limit's
    # the rate fed forward is the heading's own (the step that lands on the heading reports the rest after it)
    landed = rates.index(0.0)
    np.testing.assert_allclose(steps[:landed] / DT_S, rates[:landed], atol=1e-9)
    assert abs(steps[landed] / DT_S) <= LIMITS.acc_rad_s2 * DT_S and not np.any(steps[landed + 1 :])
    assert yaws[-1] == pytest.approx(math.radians(90.0)) and rates[-1] == 0.0


def vehicle_params(name: str):
    params = default_store()
    applied, problems = load_file(params, VEHICLES / f"{name}.params", as_defaults=True)
    assert applied and not problems
    return params


def fly_yaw_axis(name: str, turn_deg: float, seconds: float) -> tuple[np.ndarray, float]:
    """A go-to's heading change of ``turn_deg`` flown by vehicle ``name`` level in a hover: its attitude and rate
    controllers and mixer with its parameters, a yaw-only rigid body with its inertia and rotors (first-order
    rotor speed, thrust k_T w^2); the true heading every 4 ms (unwrapped, rad) and the ideal turn (s)."""
    spec, params = load_vehicle(name), vehicle_params(name)
    gains = GainsFromParams(params)
    att, rate_ctl, mixer = gains.attitude_control(), gains.rate_control(), Mixer(spec)
    jz = float(spec.inertia_kg_m2[2])
    weight = spec.mass_kg * GRAVITY_M_S2
    yaw_row = mixer.b[2]
    w_max, tau_up, tau_down = spec.max_speed_rad_s, spec.time_constant_up_s, spec.time_constant_down_s
    w = np.full(len(spec.rotors), spec.hover_speed_rad_s)
    limits = HeadingLimits.from_params(params)
    task = GotoTask(np.array([0.0, 0.0, -5.0]), math.radians(turn_deg), 5.0, 4.0, heading=limits)
    dt, t_us, yaw, r = 0.004, 0, 0.0, 0.0
    sat = ((False,) * 3, (False,) * 3)
    task.activate(estimate(t_us, yaw), t_us)
    out = []
    for k in range(round(seconds / dt)):
        if k % 5 == 0:  # the outer loop at 50 Hz
            sp = task.update(estimate(t_us, wrap_pi(yaw), r), t_us)
            q_sp, ff = from_euler(0.0, 0.0, sp.yaw_rad).tolist(), sp.yaw_rate_rad_s
        q = from_euler(0.0, 0.0, wrap_pi(yaw)).tolist()
        rate_sp = with_yaw_rate(att.update_floats(q, q_sp), q, ff)
        alpha = rate_ctl.update_floats([0.0, 0.0, r], rate_sp, dt, *sat)
        cmd, _, sat_pos, sat_neg, _ = mixer.mix_floats(0.0, 0.0, jz * alpha[2], weight)
        sat = (sat_pos, sat_neg)
        w_cmd = np.asarray(cmd) * w_max
        tau = np.where(w_cmd > w, tau_up, tau_down)
        w = w + (w_cmd - w) * (1.0 - np.exp(-dt / tau))
        r += float(yaw_row @ (spec.k_thrust * w * w)) / jz * dt
        yaw += r * dt
        t_us += round(dt * 1e6)
        out.append(yaw)
    return np.array(out), abs(turn_deg) / math.degrees(limits.rate_rad_s)


@pytest.mark.parametrize("vehicle", ["quad_x", "firefly"])
@pytest.mark.parametrize("turn_deg", [90.0, -150.0])
def test_each_vehicle_stops_on_the_heading_of_a_goto(vehicle, turn_deg):
    """Issue 36's target on the yaw axis alone: at most 3 deg past the heading, and within 3 deg of it 1 s after
    the turn at MPC_YAWRAUTO_MAX would end, for good."""
    yaw, ideal_s = fly_yaw_axis(vehicle, turn_deg, 10.0)
    err = np.degrees(yaw) - turn_deg
    overshoot = max(0.0, float((math.copysign(1.0, turn_deg) * err).max()))
    late = np.abs(err[round((ideal_s + 1.0) / 0.004) :])
    print(f"{vehicle} {turn_deg:+.0f} deg: overshoot {overshoot:.2f} deg, {late.max():.2f} deg 1 s after the turn")
    assert overshoot <= 3.0
    assert late.max() <= 3.0
