"""The simulator's rotor model (sitl.rotors): T = k_T w^2 and the motor lag.

No sockets, no processes, no clocks.  (From tests/test_units.py, split by subject.)
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sitl.rotors import RotorModel


def test_rotor_thrust_is_k_t_omega_squared(quad):
    rotors = RotorModel(quad)
    u = 0.6
    for _ in range(2000):  # 2 s: long past the lag
        thrusts = rotors.step(np.full(4, u), 0.001)
    w = u * quad.max_speed_rad_s
    assert rotors.speed_rad_s == pytest.approx(np.full(4, w))
    assert thrusts == pytest.approx(np.full(4, quad.k_thrust * w * w))
    assert rotors.drag_torque_nm() == pytest.approx(quad.k_moment * np.array(thrusts))


def test_motor_lag_63_percent_in_one_time_constant_slower_down(quad):
    rotors = RotorModel(quad)
    w_max = quad.max_speed_rad_s
    dt = quad.time_constant_up_s / 50
    for _ in range(50):
        rotors.step(np.ones(4), dt)
    assert rotors.speed_rad_s / w_max == pytest.approx(np.full(4, 1 - math.exp(-1)), abs=1e-9)
    for _ in range(5000):
        rotors.step(np.ones(4), dt)
    assert rotors.speed_rad_s == pytest.approx(np.full(4, w_max))
    for _ in range(50):  # one *up* time constant of slowing down: less than 63 % of the way
        rotors.step(np.zeros(4), dt)
    fallen = 1 - rotors.speed_rad_s / w_max
    assert np.all(fallen < 1 - math.exp(-1))
    assert fallen == pytest.approx(np.full(4, 1 - math.exp(-quad.time_constant_up_s / quad.time_constant_down_s)))
    assert quad.time_constant_down_s > quad.time_constant_up_s
    assert rotors.commanded_speed([1.5, -0.2, 0.5, 1.0]) == pytest.approx([w_max, 0.0, w_max / 2, w_max])
