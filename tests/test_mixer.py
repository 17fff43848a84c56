"""The mixer (autopilot.control.mixer): allocation from the vehicle file, saturation, yaw cut first.

No sockets, no processes, no clocks.  (From tests/test_units.py, split by subject.)
"""

from __future__ import annotations

import numpy as np
import pytest

from autopilot.control.mixer import Mixer

# [Q 2.9]: Motor = Thrust +- Yaw +- Pitch +- Roll, rows (front right, front left, back right, back left).
SEED_TABLE = {  # motor: (yaw, pitch, roll) sign
    "FR": (+1, +1, +1),
    "FL": (-1, +1, -1),
    "BR": (-1, -1, +1),
    "BL": (+1, -1, -1),
}
# quad_x.toml lists its rotors in PX4's order: front right, rear left, front left, rear right.
QUAD_ORDER = ("FR", "BL", "FL", "BR")


def test_quad_x_allocation_reproduces_seed_000_mixing_table(quad):
    b = Mixer(quad).b  # rows roll, pitch, yaw torque (N m, FRD), thrust (N); one column per rotor
    assert b.shape == (4, 4)
    seed = np.array([SEED_TABLE[m] for m in QUAD_ORDER]).T  # rows yaw, pitch, roll
    # Same pattern as [Q]'s table on every axis (each axis' overall sign is a convention):
    for row, seed_row in ((b[2], seed[0]), (b[1], seed[1]), (b[0], seed[2])):
        signs = np.sign(row)
        assert np.array_equal(signs, seed_row) or np.array_equal(signs, -seed_row)
    yaw = dict(zip(QUAD_ORDER, np.sign(b[2])))
    assert yaw["FR"] == yaw["BL"] != yaw["FL"] == yaw["BR"]  # diagonal pairs share a spin direction
    # In FRD, with the physics fixed: more thrust on the right rolls left (negative roll torque),
    # more thrust in front pitches up, a CCW rotor (FR, BL) yaws the body clockwise = positive FRD yaw.
    roll, pitch = dict(zip(QUAD_ORDER, b[0])), dict(zip(QUAD_ORDER, b[1]))
    assert roll["FR"] < 0 and roll["BR"] < 0 and roll["FL"] > 0 and roll["BL"] > 0
    assert pitch["FR"] > 0 and pitch["FL"] > 0 and pitch["BR"] < 0 and pitch["BL"] < 0
    assert yaw["FR"] > 0
    assert np.all(b[3] == 1.0)
    arm = 0.46
    assert np.allclose(np.abs(b[0:2]), arm) and np.allclose(np.abs(b[2]), quad.k_moment)


def test_mix_reproduces_requested_wrench_when_not_saturated(quad):
    mixer = Mixer(quad)
    hover_n = quad.mass_kg * 9.80665
    for torque in ([0.0, 0.0, 0.0], [0.5, -0.3, 0.04], [-0.8, 0.6, -0.05]):
        out = mixer.mix(np.array(torque), hover_n)
        assert mixer.wrench(out.thrusts_n) == pytest.approx([*torque, hover_n], abs=1e-9)
        assert not out.sat_pos.any() and not out.sat_neg.any() and not out.thrust_saturated
        # Commands map linearly to rotor speed: T = T_max u^2.
        assert out.commands**2 * quad.max_thrust_per_rotor_n == pytest.approx(out.thrusts_n)
        assert np.all((out.commands >= 0) & (out.commands <= 1))
    hover = mixer.mix(np.zeros(3), hover_n).commands
    assert hover == pytest.approx(np.full(4, quad.hover_speed_rad_s / quad.max_speed_rad_s))


@pytest.mark.parametrize("roll_nm", [50.0, -50.0])
def test_huge_roll_keeps_its_sign_shifts_thrust_and_flags_saturation(quad, roll_nm):
    mixer = Mixer(quad)
    hover_n = quad.mass_kg * 9.80665
    out = mixer.mix(np.array([roll_nm, 0.0, 0.0]), hover_n)
    roll, pitch, yaw, thrust = mixer.wrench(out.thrusts_n)
    assert np.sign(roll) == np.sign(roll_nm) and abs(roll) < abs(roll_nm)
    assert abs(roll) == pytest.approx(2 * 0.46 * quad.max_thrust_per_rotor_n)  # the most a quad can give
    assert pitch == pytest.approx(0.0, abs=1e-9) and yaw == pytest.approx(0.0, abs=1e-9)
    assert out.thrust_saturated and thrust != pytest.approx(hover_n)
    assert np.all((out.thrusts_n >= 0) & (out.thrusts_n <= quad.max_thrust_per_rotor_n + 1e-12))
    assert out.sat_pos[0] == (roll_nm > 0) and out.sat_neg[0] == (roll_nm < 0)
    assert not out.sat_pos[1] and not out.sat_neg[1]


def test_yaw_is_cut_first(quad):
    mixer = Mixer(quad)
    hover_n = quad.mass_kg * 9.80665
    for yaw_nm in (0.5, -0.5):
        out = mixer.mix(np.array([0.6, -0.4, yaw_nm]), hover_n)
        roll, pitch, yaw, thrust = mixer.wrench(out.thrusts_n)
        assert (roll, pitch, thrust) == pytest.approx((0.6, -0.4, hover_n))  # fully delivered
        assert 0 < yaw / yaw_nm < 1  # same sign, less of it
        assert out.sat_pos[2] == (yaw_nm > 0) and out.sat_neg[2] == (yaw_nm < 0)
        assert not out.sat_pos[:2].any() and not out.sat_neg[:2].any() and not out.thrust_saturated


def test_full_thrust_request_is_limited(quad):
    mixer = Mixer(quad)
    out = mixer.mix(np.zeros(3), 1000.0)
    assert out.thrust_saturated
    assert out.commands == pytest.approx(np.ones(4))
