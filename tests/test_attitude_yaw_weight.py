"""Yaw after roll and pitch in the attitude controller (PX4's reduced attitude and MC_YAW_WEIGHT; issue 36).

With the plain quaternion error a large heading error turns the tilt correction about the thrust axis by half the
heading error: at 150 deg the vehicle was told to correct its tilt 75 deg off the tilt it had, and the
quadcopter rocked 34 deg and lost 2.9 m of height in a fast heading change (benchmarks/heading_benchmark.py with
MPC_YAWRAUTO_MAX and _ACC at 360).  Weighted, the tilt is corrected first and only ``yaw_weight`` of the heading
error beside it (the yaw gain divided by the weight, so a small heading error is corrected as before).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from autopilot.control.attitude_control import AttitudeControl, AttitudeGains, yaw_weighted
from autopilot.control.gains_from_params import attitude_gains
from autopilot.param_catalogue import default_store
from mavsim_core import quaternion as quat

P = (10.7, 10.7, 1.54)  # quad_x's MC_ROLL_P, MC_PITCH_P, MC_YAW_P
NO_LIMIT = (100.0, 100.0, 100.0)


def q_of(roll_deg: float, pitch_deg: float, yaw_deg: float) -> list[float]:
    return quat.from_euler(*(math.radians(a) for a in (roll_deg, pitch_deg, yaw_deg))).tolist()


def rates(weight: float, q: list[float], q_sp: list[float]) -> np.ndarray:
    return np.array(AttitudeControl(AttitudeGains(P, NO_LIMIT, weight)).update_floats(q, q_sp))


def test_weight_one_is_the_plain_quaternion_error():
    q, q_sp = q_of(4.0, -3.0, 20.0), q_of(-2.0, 6.0, 140.0)
    w, x, y, z = q
    e = quat.mul(np.array([w, -x, -y, -z]), np.array(q_sp))
    plain = 2.0 * math.copysign(1.0, e[0]) * e[1:] * np.array(P)
    np.testing.assert_allclose(rates(1.0, q, q_sp), plain, atol=1e-12)


@pytest.mark.parametrize(("q", "q_sp"), [((0, 0, 0), (3, 0, 5)), ((2, -1, 30), (0, 2, 33)), ((3, -2, 0), (0, 0, 0))])
def test_small_errors_are_corrected_as_without_the_weight(q, q_sp):
    """A few degrees: the same rates to a few percent (the two differ in second order only)."""
    plain = rates(1.0, q_of(*q), q_of(*q_sp))
    np.testing.assert_allclose(rates(0.4, q_of(*q), q_of(*q_sp)), plain, atol=0.03 * np.linalg.norm(plain))


@pytest.mark.parametrize("heading_deg", [90.0, 150.0, -150.0])
def test_a_large_heading_error_leaves_the_tilt_correction_where_the_tilt_is(heading_deg):
    """Rolled 10 deg right, told to be level at another heading: the roll must come out (p < 0, q = 0)."""
    q, q_sp = q_of(10.0, 0.0, 0.0), q_of(0.0, 0.0, heading_deg)
    off = {}
    for weight in (1.0, 0.4):
        p, q_rate, _ = rates(weight, q, q_sp)
        off[weight] = abs(math.degrees(math.atan2(q_rate, -p)))  # the tilt correction's direction from -roll
    assert off[1.0] == pytest.approx(abs(heading_deg) / 2, abs=3.0)  # half the heading error off
    assert off[0.4] <= 0.4 * abs(heading_deg) / 2 + 3.0  # the weight's share of it


def test_the_weighted_setpoint_keeps_the_setpoints_thrust_axis_and_part_of_its_heading():
    q, q_sp = q_of(8.0, -5.0, 10.0), q_of(-4.0, 7.0, 130.0)
    out = np.array(yaw_weighted(q, q_sp, 0.4))
    np.testing.assert_allclose(quat.to_matrix(out)[:, 2], quat.to_matrix(np.array(q_sp))[:, 2], atol=1e-12)
    level = np.array(yaw_weighted(q_of(0, 0, 0), q_of(0, 0, 100.0), 0.4))
    assert math.degrees(quat.to_euler(level)[2]) == pytest.approx(40.0)
    upside_down = q_of(180.0, 0.0, 0.0)  # thrust axes opposite: no tilt is unique, the setpoint as it is
    assert yaw_weighted(q_of(0, 0, 0), upside_down, 0.4) == tuple(upside_down)


def test_mc_yaw_weight_reaches_the_controller_and_divides_the_yaw_gain():
    params = default_store()
    assert params.get("MC_YAW_WEIGHT") == pytest.approx(0.4)  # PX4's default
    g = attitude_gains(params.get)
    assert g.yaw_weight == pytest.approx(0.4)
    ac = AttitudeControl(g)
    small = ac.update_floats(q_of(0, 0, 0), q_of(0, 0, 1.0))[2]  # 1 deg: the yaw gain as given
    assert small == pytest.approx(params.get("MC_YAW_P") * math.radians(1.0), rel=1e-3)
