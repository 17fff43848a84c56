"""The simulated battery (sitl.battery): voltage sag under load and with discharge.

No sockets, no processes, no clocks.  (From tests/test_units.py, split by subject.)
"""

from __future__ import annotations

import pytest

from sitl.battery import Battery


def test_battery_sags_with_load_and_falls_with_discharge():
    light, heavy = Battery(), Battery()
    light.step(50.0, 0.004)
    heavy.step(400.0, 0.004)
    assert heavy.current_a > light.current_a
    assert heavy.voltage_v < light.voltage_v < light.open_circuit_v() + 1e-9
    full_v = Battery().voltage_v
    assert full_v == pytest.approx(4 * 4.2)  # 4 cells, full, no load yet
    assert full_v - heavy.voltage_v == pytest.approx(heavy.current_a * heavy.r_ohm)  # sag = I R
    b = Battery()
    voltages = []
    for _ in range(10):
        for _ in range(60):  # one simulated minute at hover-like power per outer step
            b.step(200.0, 1.0)
        voltages.append(b.open_circuit_v())
    assert all(a > c for a, c in zip(voltages, voltages[1:]))  # strictly falling
    assert b.remaining_frac < 0.5
    assert b.consumed_mah == pytest.approx(b.used_as / 3.6)
