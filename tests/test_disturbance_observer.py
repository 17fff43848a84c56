"""The disturbance observer (autopilot/control/disturbance_observer.py) on a point-mass model."""

from __future__ import annotations

import math

import numpy as np
import pytest

from autopilot.control.disturbance_observer import DisturbanceObserver, MotorLag
from autopilot.control.gains_from_params import GainsFromParams, position_gains
from autopilot.control.position_control import PositionControl, PositionSetpoint
from autopilot.param_catalogue import default_store
from mavsim_core.constants import GRAVITY_M_S2

G = np.array([0.0, 0.0, GRAVITY_M_S2])
MASS = 1.5
DT = 0.02


def point_mass_estimate(force: np.ndarray, seconds: float, cutoff_hz: float = 2.0) -> np.ndarray:
    """The observer's estimate after ``seconds`` of a point mass pushed by ``force`` (N) under random thrust."""
    dob = DisturbanceObserver(MASS, cutoff_hz)
    rng = np.random.default_rng(1)
    for _ in range(int(seconds / DT)):
        thrust = np.array([0.0, 0.0, -MASS * GRAVITY_M_S2]) + rng.normal(0.0, 1.0, 3)
        kinematic = (thrust + force) / MASS + G  # m a = T + m g + F
        dob.update(kinematic, thrust, DT)
    return dob.estimate


def test_the_external_acceleration_of_a_constant_force_is_found_within_one_percent():
    force = np.array([2.4, -1.1, 0.3])
    est = point_mass_estimate(force, 4.0)
    assert est == pytest.approx(force / MASS, rel=0.01)
    early = point_mass_estimate(force, 10 * DT)  # a first-order low-pass: 1 - (1 - k)^n of it after n steps
    k = DT / (DT + 1.0 / (2 * math.pi * 2.0))
    assert early == pytest.approx(force / MASS * (1 - (1 - k) ** 10), rel=1e-6)


def test_nan_inputs_change_nothing_and_reset_starts_again():
    dob = DisturbanceObserver(MASS, 2.0)
    thrust = np.array([0.0, 0.0, -MASS * GRAVITY_M_S2])
    for _ in range(100):
        dob.update(np.array([1.0, 0.0, 0.0]), thrust, DT)  # hover thrust, yet accelerating 1 m/s^2 north
    before = dob.estimate.copy()
    assert before[0] == pytest.approx(1.0, rel=0.01)
    dob.update(np.array([np.nan, 0.0, 0.0]), thrust, DT)
    dob.update(np.array([1.0, 0.0, 0.0]), np.array([np.inf, 0.0, 0.0]), DT)
    dob.update(np.array([5.0, 0.0, 0.0]), thrust, float("nan"))
    dob.update(np.array([5.0, 0.0, 0.0]), thrust, 1.0)  # a gap
    assert np.array_equal(dob.estimate, before)
    dob.reset()
    assert not dob.estimate.any() and not dob.valid


def test_the_estimate_is_clamped():
    dob = DisturbanceObserver(MASS, 50.0, limit_m_s2=3.0)
    thrust = np.zeros(3)
    for _ in range(50):
        dob.update(np.array([30.0, 40.0, 50.0]) + G, thrust, DT)
    assert np.linalg.norm(dob.estimate[:2]) == pytest.approx(3.0) and dob.estimate[2] == pytest.approx(3.0)


def test_the_ground_carrying_the_vehicle_is_no_disturbance_and_bounces_are_held_out():
    """Issue 21: a tilted vehicle on its legs (thrust 40 % of its weight, 8 deg tilted, not moving) reads as a
    sideways push; fed forward it rocked the vehicle on its legs.  The ground's upward push (> CONTACT_M_S2)
    resets the estimate and holds it at zero CONTACT_HOLD_S after the last contact; then it works again."""
    from autopilot.control.disturbance_observer import CONTACT_HOLD_S

    dob = DisturbanceObserver(MASS, 2.0)
    tilt = math.radians(8.0)
    on_legs = 0.4 * MASS * GRAVITY_M_S2 * np.array([math.sin(tilt), 0.0, -math.cos(tilt)])
    assert not dob.in_contact
    for _ in range(100):
        assert not np.any(dob.update(np.zeros(3), on_legs, DT))  # at rest on the ground: a = 0
    assert dob.in_contact  # (a precision landing's docking reads this: legs on the deck)
    hover = np.array([0.0, 0.0, -MASS * GRAVITY_M_S2])
    wind = np.array([1.0, 0.0, 0.0])  # m/s^2, in the air again (a hop)
    for _ in range(int(CONTACT_HOLD_S / DT) - 1):
        assert not np.any(dob.update(wind, hover, DT)) and dob.in_contact
    for _ in range(100):
        est = dob.update(wind, hover, DT)
    assert est == pytest.approx(wind, abs=1e-6) and not dob.in_contact


def test_motor_lag_follows_the_command_with_its_time_constant():
    lag = MotorLag(0.05)
    for _ in range(25):  # 0.05 s
        lag.step(10.0, 0.002)
    assert lag.thrust_n == pytest.approx(10.0 * (1 - math.exp(-1.0)), rel=1e-6)
    lag.step(float("nan"), 0.002)
    assert lag.thrust_n == pytest.approx(10.0 * (1 - math.exp(-1.0)), rel=1e-6)


def test_feed_forward_only_in_the_air_and_only_when_enabled_and_horizontal_only():
    params = default_store()
    ff = GainsFromParams(params).disturbance_feed_forward(MASS, 0.02)
    hover = MASS * GRAVITY_M_S2
    for _ in range(200):
        ff.motors(hover, 0.004)
    push = np.array([0.8, -0.4, 0.5])  # m/s^2 sideways and down
    accel = push  # level, hover thrust: it cancels g, the push remains
    for _ in range(100):
        out = ff.update(accel, np.eye(3), True, DT)
    assert out == pytest.approx([0.8, -0.4, 0.0], rel=0.01)
    assert ff.update(accel, np.eye(3), False, DT) is None and not ff.observer.valid  # landed: reset
    params.set("MPC_DOB_EN", 0)
    assert ff.update(accel, np.eye(3), True, DT) is None


def test_the_position_controller_cancels_a_fed_forward_disturbance():
    pc = PositionControl(position_gains(default_store().get), MASS, 4 * MASS * GRAVITY_M_S2)
    sp = PositionSetpoint(np.zeros(3), np.full(3, np.nan), 0.0)
    plain = pc.control(np.zeros(3), np.zeros(3), sp, DT).thrust_ned_n
    pc.reset()
    pushed = pc.control(np.zeros(3), np.zeros(3), sp, DT, np.array([1.0, -0.5, 0.0])).thrust_ned_n
    assert (pushed - plain) / MASS == pytest.approx([-1.0, 0.5, 0.0])
    pc.reset()
    nan = pc.control(np.zeros(3), np.zeros(3), sp, DT, np.array([np.nan, 0.0, 0.0])).thrust_ned_n
    assert nan == pytest.approx(plain)
