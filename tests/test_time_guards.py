"""Time that goes back or jumps never reaches an integrator, and a restarted sensor clock restarts the flight
controller's state (issue 18, finding 1); home is set only from a vehicle at rest (finding 2).

No processes: the controllers, the flight controller, the commander and the small state machines of the
simulator link (:mod:`autopilot.sim_link_watch`) and of rest detection
(:mod:`autopilot.estimation.rest_detector`) driven with hand-made samples.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink

from autopilot.control.position_control import MAX_DT_S as POS_MAX_DT_S
from autopilot.control.position_control import PositionSetpoint
from autopilot.control.rate_control import MAX_DT_S as RATE_MAX_DT_S
from autopilot.control.rate_control import RateControl, RateGains
from autopilot.estimation.rest_detector import GPS_SPEED_MAX_M_S, RestDetector
from autopilot.flight_controller import MAX_SENSOR_GAP_US, FlightController
from autopilot.param_catalogue import default_store
from autopilot.sim_link_watch import SimLinkWatch
from autopilot.topics import GpsSample, ImuSample
from params.vehicle import load_vehicle

from test_commander import Bench  # tests/test_commander.py: a commander and a point that follows it

BAD_DTS = (0.0, -0.004, -10.0, math.nan, math.inf, 1e3)


# --------------------------------------------------------------------------- the controllers


def rate_control() -> RateControl:
    return RateControl(RateGains((0.15, 0.15, 0.2), (0.2, 0.2, 0.1), (0.003, 0.003, 0.0), (0.3, 0.3, 0.3), 50.0))


@pytest.mark.parametrize("dt", BAD_DTS)
def test_rate_control_integrates_nothing_on_a_bad_dt(dt):
    rc = rate_control()
    for _ in range(50):
        rc.update(np.array([0.1, -0.1, 0.0]), np.zeros(3), 0.004)
    integral, d = list(rc.integral), list(rc.d_filtered)
    out = rc.update(np.array([0.5, -0.5, 0.2]), np.zeros(3), dt)
    assert rc.integral == integral and rc.d_filtered == d
    assert np.all(np.isfinite(out))
    rc.update(np.array([0.5, -0.5, 0.2]), np.zeros(3), 0.004)  # the derivative starts again from that rate
    assert rc.d_filtered == d
    assert 0.0 < 0.004 <= RATE_MAX_DT_S


@pytest.mark.parametrize("dt", BAD_DTS)
def test_position_control_integrates_nothing_on_a_bad_dt(dt):
    """A negative dt once swapped the jerk limit's clip bounds: the feed-forward ran away (the fly-away)."""
    pc = FlightController(load_vehicle("quad_x"), default_store()).gains.position_control(1.5, 30.0)
    sp = PositionSetpoint(np.array([5.0, 0.0, -3.0]), np.full(3, np.nan), 0.0, np.array([1.0, 0.0, -2.0]))
    for _ in range(20):
        pc.control(np.zeros(3), np.array([0.2, 0.0, -0.1]), sp, 0.02)
    vel_int, acc_ff, d_filt = pc.vel_int.copy(), pc.acc_ff.copy(), pc.d_filt.copy()
    out = pc.control(np.zeros(3), np.array([0.2, 0.0, -0.1]), sp, dt)
    assert np.array_equal(pc.vel_int, vel_int) and np.array_equal(pc.acc_ff, acc_ff)
    assert np.array_equal(pc.d_filt, d_filt)
    assert np.all(np.isfinite(out.thrust_ned_n)) and np.linalg.norm(out.thrust_ned_n) < 40.0
    assert 0.02 <= POS_MAX_DT_S


# --------------------------------------------------------------------------- the flight controller


def imu(t_us: int) -> ImuSample:
    return ImuSample(t_us, np.array([0.0, 0.0, -9.81]), np.zeros(3), np.array([0.2, 0.0, 0.4]), 1013.25, 20.0, 0x1FFF)


def run(fc: FlightController, t0_us: int, n: int) -> int:
    t = t0_us
    for _ in range(n):
        t += 4000
        fc.step(imu(t), None)
        fc.after_step()
    return t


@pytest.mark.parametrize("jump_us", [-4_000_000, -4000, 0, MAX_SENSOR_GAP_US + 4000])
def test_a_restarted_sensor_clock_resets_everything_and_disarms(jump_us):
    fc = FlightController(load_vehicle("quad_x"), default_store())
    t = run(fc, 4_000_000, 100)
    assert fc.commander.arm(force=True) == mavlink.MAV_RESULT_ACCEPTED
    run(fc, t, 10)
    t += 40_000
    fc.commander.pop_events()
    estimator = fc.estimator
    fc.step(imu(t + jump_us), None)
    status = fc.commander.status
    assert not status.armed and status.home is None
    texts = [text for _, text in fc.commander.pop_events()]
    assert "Disarmed (sensor data restarted)" in texts
    assert any(text.startswith("Sensor time jumped") and text.endswith("state reset, disarmed") for text in texts)
    assert all(len(text) <= 50 for text in texts)
    assert fc.estimator is estimator and estimator.last_imu_us == t + jump_us  # restarted in place
    assert fc.last_outer_us == t + jump_us  # the outer loop started again at the new time
    fc.after_step()
    run(fc, t + jump_us, 5)  # and flies on from there
    assert not fc.commander.status.armed


def test_a_continuous_clock_keeps_the_state():
    fc = FlightController(load_vehicle("quad_x"), default_store())
    t = run(fc, 0, 100)
    assert fc.commander.arm(force=True) == mavlink.MAV_RESULT_ACCEPTED
    fc.step(imu(t + MAX_SENSOR_GAP_US), None)  # a long pause, but the time still goes on
    assert fc.commander.status.armed


def test_simulator_link_lost_says_so_and_heartbeat_is_critical():
    from autopilot.mavlink.vehicle_interface import FlightControllerVehicle

    fc = FlightController(load_vehicle("quad_x"), default_store())
    vehicle = FlightControllerVehicle(fc)
    run(fc, 0, 100)
    assert vehicle.snapshot().system_status == mavlink.MAV_STATE_STANDBY
    fc.on_sim_link_lost()
    assert fc.commander.pop_events() == [(mavlink.MAV_SEVERITY_CRITICAL, "Simulator link lost")]
    assert vehicle.snapshot().system_status == mavlink.MAV_STATE_CRITICAL
    assert fc.commander.arm() == mavlink.MAV_RESULT_DENIED  # nothing to arm on
    assert "no sensor data (simulator link lost)" in fc.commander.pop_events()[-1][1]
    fc.on_sim_link_regained()
    assert fc.commander.pop_events() == [(mavlink.MAV_SEVERITY_WARNING, "Simulator link regained")]
    assert vehicle.snapshot().system_status == mavlink.MAV_STATE_STANDBY


# --------------------------------------------------------------------------- the link watch


def test_sim_link_watch_loses_on_close_or_silence_and_runs_the_link_on_the_wall_clock():
    w = SimLinkWatch(loss_timeout_s=1.0)
    assert not w.check(100.0, closed=True)  # never connected: nothing to lose
    assert not w.on_sensor(8_000_000, 100.0)
    assert not w.check(100.9, closed=False) and w.link_time_us(100.9) == 8_000_000  # a pause: time stands
    assert w.check(101.0, closed=False) and w.lost  # silent for the timeout
    assert not w.check(101.5, closed=True)  # said once
    assert w.link_time_us(103.5) == 11_500_000  # the ground-station link goes on with the wall clock
    assert w.on_sensor(4000, 104.0) and not w.lost  # regained (by a simulator whose clock restarted)
    assert w.link_time_us(110.0) == 4000
    assert w.check(104.1, closed=True)  # closing loses it at once


# --------------------------------------------------------------------------- rest and home


def test_rest_detector_still_free_fall_and_gps_speed():
    r = RestDetector()
    still, fall = np.array([0.05, -0.02, -9.8]), np.array([0.0, 0.0, -0.3])
    t = 0

    def feed(accel: np.ndarray, seconds: float) -> None:
        nonlocal t
        for _ in range(round(seconds / 0.004)):
            t += 4000
            r.update_imu(t, accel, np.zeros(3))

    feed(still, 0.996)  # the first sample starts the still stretch: 0.992 s of it
    assert not r.at_rest and not r.moving
    feed(still, 0.008)
    assert r.at_rest
    feed(fall, 0.08)
    assert not r.at_rest and not r.moving  # not yet MOVING_TIME_S
    feed(fall, 0.04)
    assert r.moving and not r.at_rest
    feed(still, 1.1)
    assert r.at_rest and not r.moving
    r.update_gps(t, np.array([0.0, 0.0, GPS_SPEED_MAX_M_S + 0.1]))  # the GPS says it moves: not at rest
    feed(still, 0.5)
    assert r.moving and not r.at_rest
    feed(still, 0.6)
    assert r.at_rest
    r.update_imu(t + 4000, np.full(3, np.nan), np.zeros(3))  # a missing sensor says nothing
    assert r.at_rest


def test_home_is_set_only_at_rest():
    b = Bench()
    b.cmd.at_rest = False  # a falling vehicle whose position is already valid
    b.run(1.0)
    assert b.cmd.status.home is None and not any("Home set" in t for t in b.texts())
    b.cmd.at_rest = True
    b.run(0.1)
    assert b.cmd.status.home is not None and any("Home set" in t for t in b.texts())


def test_flight_controller_restarted_falling_reports_it_and_waits_for_rest():
    """Free fall from the first sample (a flight controller restarted in the air): no home, reported once."""
    fc = FlightController(load_vehicle("quad_x"), default_store())
    fall = ImuSample(0, np.array([0.0, 0.0, -0.2]), np.zeros(3), np.array([0.2, 0.0, 0.4]), 1013.25, 20.0, 0x1FFF)
    gps = GpsSample(0, 3, 47.397742, 8.545594, 498.0, np.array([0.0, 0.0, 6.0]), 0.5, 0.8, 12)
    t = 0
    for k in range(250):
        t += 4000
        fc.step(dataclasses.replace(fall, timestamp_us=t), gps if k % 50 == 0 else None)
        fc.after_step()
    texts = [text for _, text in fc.commander.pop_events()]
    assert texts.count("Moving while disarmed: restarted in flight?") == 1
    assert fc.commander.home is None and not fc.commander.at_rest
