"""Position control (autopilot.control.position_control): hover feed-forward, thrust, tilt limit.

No sockets, no processes, no clocks.  (From tests/test_units.py, split by subject.)
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from autopilot.control.gains_from_params import position_control_from_params
from autopilot.control.position_control import PositionControl, PositionSetpoint, attitude_from_thrust
from mavsim_core import quaternion as quat
from mavsim_core.constants import GRAVITY_M_S2


def make_position_control(params, quad) -> PositionControl:
    return position_control_from_params(params, quad.mass_kg, len(quad.rotors) * quad.max_thrust_per_rotor_n)


def test_position_control_hover_feed_forward_at_zero_error(params, quad):
    pc = make_position_control(params, quad)
    here = np.array([3.0, -2.0, -5.0])
    sp = PositionSetpoint(here.copy(), np.zeros(3), 0.3)
    for _ in range(20):
        thrust = pc.update(here, np.zeros(3), sp, 0.02)
        assert thrust == pytest.approx([0.0, 0.0, -quad.mass_kg * GRAVITY_M_S2])


def test_position_control_thrust_is_mass_times_acceleration_minus_gravity(params, quad):
    pc = make_position_control(params, quad)
    sp = PositionSetpoint(np.array([1.0, 0.5, -5.3]), np.zeros(3), 0.0)
    thrust = pc.update(np.array([0.0, 0.0, -5.0]), np.zeros(3), sp, 0.02)
    assert thrust == pytest.approx(quad.mass_kg * (pc.acc_sp - np.array([0.0, 0.0, GRAVITY_M_S2])))
    assert thrust[0] > 0 and thrust[1] > 0 and -thrust[2] > quad.mass_kg * GRAVITY_M_S2  # toward the goal, climbing


def test_position_control_respects_tilt_limit(params, quad):
    pc = make_position_control(params, quad)
    for tilt_max in (35.0, 20.0):
        params.set("MPC_TILTMAX_AIR", tilt_max)
        pc.reset()
        sp = PositionSetpoint(np.array([200.0, -100.0, -5.0]), np.zeros(3), 0.0)
        for _ in range(100):
            thrust = pc.update(np.array([0.0, 0.0, -5.0]), np.zeros(3), sp, 0.02)
            tilt = math.degrees(math.atan2(math.hypot(thrust[0], thrust[1]), -thrust[2]))
            assert tilt <= tilt_max + 1e-6
        assert tilt == pytest.approx(tilt_max)
        assert math.atan2(thrust[1], thrust[0]) == pytest.approx(math.atan2(-100.0, 200.0))  # toward the goal
        assert np.linalg.norm(thrust) <= len(quad.rotors) * quad.max_thrust_per_rotor_n + 1e-9


def test_attitude_from_thrust_points_body_down_against_thrust():
    thrust = np.array([2.0, -1.0, -13.0])
    for yaw in (0.0, 1.0, -2.5):
        r = attitude_from_thrust(thrust, yaw)
        assert r.T @ r == pytest.approx(np.eye(3), abs=1e-12)
        assert -r[:, 2] == pytest.approx(thrust / np.linalg.norm(thrust))
        level_yaw = quat.to_euler(quat.from_matrix(attitude_from_thrust(np.array([0.0, 0.0, -10.0]), yaw)))
        assert level_yaw == pytest.approx((0.0, 0.0, yaw))


def test_a_setpoints_band_keeps_a_chase_out_of_the_horizontal_integrator(params, quad):
    """With ``int_band_m_s`` a horizontal velocity error beyond it (a chase) is not stored, a small steady one
    is; without it (the default) the integrator learns from any error, as before."""
    band = 0.5
    here = np.array([0.0, 0.0, -5.0])

    def integrated(vel_sp: tuple[float, float, float], band_m_s: float) -> list[float]:
        pc = make_position_control(params, quad)
        sp = PositionSetpoint(np.full(3, np.nan), np.array(vel_sp), 0.0, None, band_m_s)
        for _ in range(50):
            pc.update(here, np.zeros(3), sp, 0.02)
        return pc.vel_int[:2].tolist()

    assert integrated((band + 0.5, 0.0, 0.0), band) == [0.0, 0.0]
    chase_unbanded = integrated((band + 0.5, 0.0, 0.0), math.inf)
    assert chase_unbanded[0] > 0.0
    steady = integrated((0.0, 0.5 * band, 0.0), band)
    assert steady[0] == 0.0 and steady[1] > 0.0


def test_a_setpoints_axis_cone_shortens_the_horizontal_thrust_and_holds_the_integrator(params, quad):
    """A chase 1 m above a deck 0.4 m north, with a body-fixed camera's cone (36.85 - 8 deg around the line of sight,
    view_limited_catchup): the position controller tilts north no more than the cone allows (7 deg, not 35), keeps
    the vertical thrust, and reports the horizontal axes saturated (their integrators held)."""
    from autopilot.control.thrust_cone import AxisCone

    pc = make_position_control(params, quad)
    cone = AxisCone((0.4, 0.0, 1.0), math.radians(36.85 - 8.0))
    sp = PositionSetpoint(np.array([20.0, 0.0, -5.0]), np.zeros(3), 0.0, axis_cone=cone)
    out = pc.control(np.array([0.0, 0.0, -5.0]), np.zeros(3), sp, 0.02)
    t = out.thrust_ned_n
    tilt = math.degrees(math.atan2(math.hypot(t[0], t[1]), -t[2]))
    assert tilt == pytest.approx(36.85 - 8.0 - math.degrees(math.atan(0.4)), abs=0.1)
    assert t[0] > 0.0 and out.saturated[:2] == (True, True)
    free = make_position_control(params, quad).control(
        np.array([0.0, 0.0, -5.0]), np.zeros(3), PositionSetpoint(sp.pos_ned_m, np.zeros(3), 0.0), 0.02
    )
    assert t[2] == pytest.approx(free.thrust_ned_n[2])  # the vertical thrust kept
    assert math.degrees(math.atan2(math.hypot(*free.thrust_ned_n[:2]), -free.thrust_ned_n[2])) > 30.0


def test_a_setpoints_acceleration_slew_swings_the_horizontal_thrust_no_faster_than_it_allows(params, quad):
    """A hover, then a setpoint 20 m east (the tilt limit at once without a slew): with 20 m/s^3 the horizontal
    thrust per unit mass grows by 0.4 m/s^2 a 20 ms step, the horizontal axes reported saturated meanwhile; then
    back toward the hover at the same rate; inf (the default) is the step."""
    here = np.array([0.0, 0.0, -5.0])
    slewed, free = make_position_control(params, quad), make_position_control(params, quad)
    hover = PositionSetpoint(here.copy(), np.zeros(3), 0.0, acc_slew_m_s3=20.0)
    east = PositionSetpoint(np.array([0.0, 20.0, -5.0]), np.zeros(3), 0.0, acc_slew_m_s3=20.0)
    slewed.control(here, np.zeros(3), hover, 0.02)
    side = []
    for _ in range(5):
        out = slewed.control(here, np.zeros(3), east, 0.02)
        side.append(out.thrust_ned_n[1] / quad.mass_kg)
        assert out.saturated[:2] == (True, True)
    assert side == pytest.approx([0.4, 0.8, 1.2, 1.6, 2.0])
    back = slewed.control(here, np.zeros(3), hover, 0.02).thrust_ned_n[1] / quad.mass_kg
    assert back == pytest.approx(1.6)
    step = free.control(here, np.zeros(3), PositionSetpoint(east.pos_ned_m, np.zeros(3), 0.0), 0.02)
    tilt = math.degrees(math.atan2(math.hypot(*step.thrust_ned_n[:2]), -step.thrust_ned_n[2]))
    assert tilt == pytest.approx(params.get("MPC_TILTMAX_AIR"))
