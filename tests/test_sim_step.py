"""A physics sanity check of the MuJoCo model through sitl.simulation.Simulation.

No sockets, no processes, no clocks.  (From tests/test_units.py, split by subject.)
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from mavsim_core import quaternion as quat
from sitl.simulation import LOCKSTEP_DT_S, Simulation

HOME = (47.397742, 8.545594, 488.0)
G = 9.80665  # standard gravity, m/s^2


def tilt_deg(q: np.ndarray) -> float:
    """Angle between the body z axis and the world z axis."""
    return math.degrees(math.acos(max(-1.0, min(1.0, quat.to_matrix(q)[2, 2]))))


@pytest.fixture
def sim(quad):
    return Simulation(quad, HOME, seed=1)


def test_vehicle_starts_level_on_its_legs_facing_north(sim):
    t = sim.truth()
    assert t.pos_ned_m[:2] == pytest.approx([0.0, 0.0], abs=1e-6)
    assert -t.pos_ned_m[2] == pytest.approx(0.2, abs=0.01)  # centre of mass above the feet
    assert quat.to_euler(t.q_ned_frd) == pytest.approx((0.0, 0.0, 0.0), abs=1e-6)
    assert t.specific_force_frd_m_s2 == pytest.approx([0.0, 0.0, -G], abs=1e-3)  # the accelerometer feels the ground


def test_hover_command_holds_it_level_and_balances_weight(sim, quad):
    sim.data.qpos[2] = 5.0  # start in the air
    hover = np.full(4, quad.hover_speed_rad_s / quad.max_speed_rad_s)
    for _ in range(round(0.5 / LOCKSTEP_DT_S)):  # spin-up
        sim.step(hover)
    v_start = sim.truth().vel_ned_m_s
    for _ in range(round(2.0 / LOCKSTEP_DT_S)):
        sim.step(hover)
    t = sim.truth()
    assert tilt_deg(t.q_ned_frd) < 0.5
    assert np.abs(t.rate_frd_rad_s).max() < 0.01
    assert t.specific_force_frd_m_s2 == pytest.approx([0.0, 0.0, -G], abs=0.01)  # thrust = weight
    assert t.vel_ned_m_s == pytest.approx(v_start, abs=0.02)  # no acceleration
    assert abs(t.vel_ned_m_s[2]) < 0.3 and -t.pos_ned_m[2] > 4.0
