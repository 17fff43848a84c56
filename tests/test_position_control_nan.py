"""Position control with NaN setpoint components (PX4's convention: NaN = not controlled), and the
one path from parameters to controller gains.  Pure parts only: no sockets, no processes, no clocks."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from autopilot.control.gains_from_params import GainsFromParams, position_control_from_params, position_gains
from autopilot.control.position_control import PositionControl, PositionSetpoint
from autopilot.param_catalogue import default_store
from mavsim_core.constants import GRAVITY_M_S2
from params.vehicle import load_vehicle

NAN3 = np.full(3, math.nan)
DT = 0.02


@pytest.fixture(scope="module")
def quad():
    return load_vehicle("quad_x")


def make(quad, params=None) -> PositionControl:
    return position_control_from_params(
        params or default_store(), quad.mass_kg, len(quad.rotors) * quad.max_thrust_per_rotor_n
    )


def hover_thrust(quad) -> list[float]:
    return [0.0, 0.0, -quad.mass_kg * GRAVITY_M_S2]


def test_nan_position_flies_the_velocity_setpoint(quad):
    pc = make(quad)
    vel_sp = np.array([1.0, -0.5, 0.3])
    sp = PositionSetpoint(NAN3.copy(), vel_sp, 0.0)
    out = pc.control(np.array([3.0, 4.0, -5.0]), vel_sp.copy(), sp, DT)
    assert out.pos_controlled == (False, False, False)
    assert out.vel_controlled == (True, True, True)
    assert out.vel_sp_ned_m_s == pytest.approx(vel_sp)
    assert out.thrust_ned_n == pytest.approx(hover_thrust(quad))  # flying the wanted velocity: no correction
    # Position held horizontally, descent on velocity (the landing task's setpoint).
    sp = PositionSetpoint(np.array([3.0, 4.0, math.nan]), np.array([0.0, 0.0, 0.7]), 0.0)
    out = pc.control(np.array([3.5, 4.0, -5.0]), np.zeros(3), sp, DT)
    assert out.pos_controlled == (True, True, False)
    assert out.vel_sp_ned_m_s == pytest.approx([-0.5 * pc.gains.pos_p_per_s[0], 0.0, 0.7])
    assert np.all(np.isfinite(out.thrust_ned_n)) and np.all(np.isfinite(pc.vel_int))


def test_nan_everything_holds_with_zero_acceleration(quad):
    pc = make(quad)
    sp = PositionSetpoint(NAN3.copy(), NAN3.copy(), math.nan, NAN3.copy())
    for _ in range(50):
        out = pc.control(np.array([1.0, 2.0, -3.0]), np.zeros(3), sp, DT)
        assert out.pos_controlled == (False, False, False)
        assert out.vel_sp_ned_m_s == pytest.approx(np.zeros(3))
        assert out.acc_sp_ned_m_s2 == pytest.approx(np.zeros(3))
        assert out.thrust_ned_n == pytest.approx(hover_thrust(quad))
    assert pc.vel_int == pytest.approx(np.zeros(3))
    # Moving: it brakes (holds), it does not coast.
    out = pc.control(np.array([1.0, 2.0, -3.0]), np.array([2.0, 0.0, 0.0]), sp, DT)
    assert out.acc_sp_ned_m_s2[0] < 0.0 and out.thrust_ned_n[0] < 0.0


def test_nan_position_and_velocity_leave_the_axis_to_its_acceleration_setpoint(quad):
    pc = make(quad)
    acc = np.array([1.0, math.nan, math.nan])
    sp = PositionSetpoint(np.array([math.nan, 0.0, -5.0]), np.array([math.nan, 0.0, 0.0]), 0.0, acc)
    for _ in range(100):  # 2 s: past the jerk limit's ramp
        out = pc.control(np.array([0.0, 0.0, -5.0]), np.array([3.0, 0.0, 0.0]), sp, DT)
    assert out.vel_controlled == (False, True, True) and out.pos_controlled == (False, True, True)
    assert math.isnan(out.vel_sp_ned_m_s[0])  # not controlled
    assert out.acc_sp_ned_m_s2 == pytest.approx([1.0, 0.0, 0.0])  # the 3 m/s north is not braked
    assert pc.vel_int[0] == 0.0  # no velocity loop on that axis: nothing integrated
    assert np.all(np.isfinite(out.thrust_ned_n))


def test_nan_estimate_never_reaches_an_integrator(quad):
    pc = make(quad)
    sp = PositionSetpoint(np.array([1.0, 2.0, -5.0]), np.zeros(3), 0.0)
    for k in range(200):
        vel = np.array([math.nan, 0.1, math.inf]) if k % 3 else np.array([0.1, math.nan, -0.2])
        pos = np.array([0.0, math.nan, -4.0]) if k % 2 else NAN3.copy()
        out = pc.control(pos, vel, sp, DT)
        assert np.all(np.isfinite(out.thrust_ned_n)) and np.all(np.isfinite(out.acc_sp_ned_m_s2))
        assert np.all(np.isfinite(pc.vel_int)) and np.all(np.isfinite(pc.d_filt))
        assert np.all(np.abs(pc.vel_int) <= np.array(pc.gains.vel_int_lim_m_s2))
    # Good estimates again: it flies to the setpoint as usual.
    out = pc.control(np.array([0.0, 0.0, -5.0]), np.zeros(3), sp, DT)
    assert out.pos_controlled == (True, True, True)
    assert out.thrust_ned_n[0] > 0 and out.thrust_ned_n[1] > 0


def test_a_parameter_reaches_its_controller_through_set_gains_only_when_its_own(quad):
    params = default_store()
    gains = GainsFromParams(params)
    pc = gains.position_control(quad.mass_kg, len(quad.rotors) * quad.max_thrust_per_rotor_n)
    ac, rc, gf = gains.attitude_control(), gains.rate_control(), gains.gyro_filter()
    before = (pc.gains, ac.gains, rc.gains, gf.settings)
    params.set("MPC_TILTMAX_AIR", 20.0)
    assert pc.gains.tilt_max_rad == pytest.approx(math.radians(20.0))  # degrees converted once, here
    assert pc.gains == position_gains(params.get)
    assert (ac.gains, rc.gains, gf.settings) == before[1:] and ac.gains is before[1]
    params.set("MC_YAWRATE_MAX", 90.0)
    assert ac.gains.rate_max_rad_s[2] == pytest.approx(math.pi / 2) and rc.gains is before[2]
    params.set("MC_ROLLRATE_P", 20.0)
    assert rc.gains.p_per_s == (20.0, 12.0, 6.0)
    params.set("IMU_GYRO_CUTOFF", 0.0)
    assert gf.settings.cutoff_hz == 0.0 and gf.apply([0.3, -0.2, 0.1]) == [0.3, -0.2, 0.1]  # no filter
    with pytest.raises(dataclasses.FrozenInstanceError):
        pc.gains.tilt_max_rad = 1.0  # type: ignore[misc]
