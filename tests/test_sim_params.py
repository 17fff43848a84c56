"""The simulator's SIM_* parameter table: :class:`sitl.sim_params.SimParameters`, pure, tested directly.

List order, indices and defaults; sets that write the settings objects; refusals that change
nothing; the description table.  Scenario files are in tests/test_sim_scenarios.py, the MAVLink
service in tests/test_sim_param_server.py, the ``sitl`` command line and process in tests/test_sitl_cli.py.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass

import pytest

from sitl.sim_params import ParamRow, SimParamError, SimParameters, format_table
from sitl.sim_settings import SensorSettings, WindSettings, param_fields, sim_param

from sim_params_helpers import make_params  # tests/sim_params_helpers.py


def float32(x: float) -> float:
    return struct.unpack("<f", struct.pack("<f", x))[0]


# --------------------------------------------------------------------------- SimParameters


def test_list_order_indices_and_defaults():
    params, wind, sensors, motors = make_params()
    hold = params.param("SIM_HOLD_MS").owner  # the world's hold (sitl/hold.py), always last
    fields = [f for s in (wind, sensors, motors, hold) for f in param_fields(s)]
    assert len(params) == len(fields) and len(params) > 30
    assert params.names() == [f.metadata["param"] for f in fields]
    assert len(set(params.names())) == len(params)
    for i, p in enumerate(params):
        assert p.index == i and params.at(i) is p and params.param(p.name) is p
        assert params.get(p.name) == p.default
        assert len(p.name) <= 16 and p.name.startswith("SIM_")
    assert params.param("SIM_ENGINE_FAIL").type == "INT32"
    assert params.param("SIM_WIND_SPD").type == "REAL32"
    assert "SIM_WIND_SPD" in params and "NOPE" not in params


def test_set_writes_the_settings_objects():
    params, wind, sensors, motors = make_params()
    assert params.set("SIM_WIND_SPD", 5) == 5.0
    assert wind.speed_m_s == 5.0 and isinstance(wind.speed_m_s, float)
    assert params.set("SIM_ENGINE_FAIL", 3.0) == 3
    assert motors.fail_motor == 3 and isinstance(motors.fail_motor, int)  # INT32 stored as int
    params.set("SIM_GPS_LAG_MS", 200)
    assert sensors.gps_lag_ms == 200 and params.get("SIM_GPS_LAG_MS") == 200
    params.set("SIM_GPS_GLITCH_N", -1000)  # limits are inclusive
    assert sensors.gps_glitch_n_m == -1000.0
    # a limit that came through a float32 (0.1 -> 0.10000000149) is the limit
    assert params.set("SIM_GYR_NOISE", float32(0.1)) == 0.1


@pytest.mark.parametrize(
    "name, value, reason",
    [
        ("SIM_NOPE", 1.0, "unknown parameter"),
        ("SIM_WIND_SPD", math.nan, "finite"),
        ("SIM_WIND_SPD", math.inf, "finite"),
        ("SIM_WIND_SPD", -math.inf, "finite"),
        ("SIM_WIND_SPD", 30.5, "outside range [0, 30] m/s"),
        ("SIM_WIND_SPD", -0.1, "outside range"),
        ("SIM_GYR_NOISE", 0.1000002, "outside range"),
        ("SIM_ENGINE_FAIL", 13, "outside range [0, 12]"),
        ("SIM_ENGINE_FAIL", 2.5, "not an integer"),
        ("SIM_GPS_LAG_MS", 1e-45, "not an integer"),  # a byte-wise int mistaken for a float
        ("SIM_ENGINE_FAIL", "3", "expected a number"),
        ("SIM_GPS_DISABLE", True, "expected a number"),
        ("SIM_WIND_SPD", None, "expected a number"),
    ],
)
def test_refusals_change_nothing(name, value, reason):
    params, *_ = make_params()
    before = {n: params.get(n) for n in params.names()}
    with pytest.raises(SimParamError) as err:
        params.set(name, value)
    assert reason in err.value.reason and err.value.name == name
    assert str(err.value).startswith(f"{name}: ")
    assert {n: params.get(n) for n in params.names()} == before


def test_set_many_is_all_or_nothing_and_at_checks_index():
    params, wind, _, motors = make_params()
    with pytest.raises(SimParamError, match="SIM_ENGINE_FAIL"):
        params.set_many({"SIM_WIND_SPD": 4.0, "SIM_ENGINE_FAIL": 99})
    assert wind.speed_m_s == 0.0 and motors.fail_motor == 0
    params.set_many({"SIM_WIND_SPD": 4.0, "SIM_ENGINE_FAIL": 2})
    assert wind.speed_m_s == 4.0 and motors.fail_motor == 2
    for bad in (-1, len(params)):
        with pytest.raises(SimParamError, match="no parameter at index"):
            params.at(bad)


def test_describe_and_table():
    params, *_ = make_params()
    params.set("SIM_WIND_DIR", 270)
    rows = params.describe()
    assert len(rows) == len(params) and all(isinstance(r, ParamRow) for r in rows)
    row = next(r for r in rows if r.name == "SIM_WIND_DIR")
    assert (row.value, row.default, row.min, row.max, row.unit) == (270, 0.0, 0.0, 360.0, "deg")
    table = format_table(rows).splitlines()
    assert table[0].split()[:5] == ["NAME", "VALUE", "MIN", "MAX", "UNIT"]
    assert any(line.split()[:4] == ["SIM_WIND_DIR", "270", "0", "360"] for line in table)
    assert any(line.split()[:4] == ["SIM_ENGINE_FAIL", "0", "0", "12"] for line in table)


def test_int32_limits_must_survive_a_float():
    @dataclass
    class Huge:
        n: int = sim_param("SIM_HUGE", 0, 0, 2**31 - 1, "", "too wide for the float path", "INT32")

    with pytest.raises(ValueError, match="SIM_HUGE"):
        SimParameters(WindSettings(), SensorSettings(), Huge())
