"""The parameter store (autopilot.parameters) and the declared parameters.

No sockets, no processes, no clocks.  (From tests/test_units.py, split by subject.)
"""

from __future__ import annotations

import math
import struct

import pytest

from autopilot.parameters import ParamDef, ParamError, ParameterStore, ParamType, param


def test_parameter_store_refuses_bad_sets_and_changes_nothing():
    store = ParameterStore(
        {
            "TEST_GAIN": ParamDef("TEST_GAIN", ParamType.REAL32, 1.0, 0.0, 5.0, "1/s", "a gain"),
            "TEST_COUNT": ParamDef("TEST_COUNT", ParamType.INT32, 3, 1, 10, "", "a count"),
        }
    )
    seen = []
    store.subscribe(lambda name, value: seen.append((name, value)))
    refused = [
        (("TEST_GAIN", 5.5), "outside range"),
        (("TEST_GAIN", -0.1), "outside range"),
        (("TEST_GAIN", math.nan), "finite"),
        (("TEST_COUNT", 2.5), "integer"),
        (("TEST_COUNT", 0), "outside range"),
        (("TEST_GAIN", 2.0, ParamType.INT32), "is REAL32, not INT32"),
        (("NO_SUCH", 1.0), "unknown parameter NO_SUCH"),
    ]
    for args, why in refused:
        with pytest.raises(ParamError, match=why):
            store.set(*args)
    assert store.get("TEST_GAIN") == 1.0 and store.get("TEST_COUNT") == 3 and seen == []
    with pytest.raises(ParamError, match="unknown parameter NOPE"):
        store.get("NOPE")
    assert store.set("TEST_GAIN", 5.0) == 5.0 and store.set("TEST_COUNT", 7.0, ParamType.INT32) == 7
    assert seen == [("TEST_GAIN", 5.0), ("TEST_COUNT", 7.0)]
    assert store.names() == ["TEST_COUNT", "TEST_GAIN"] and store.name_at(1) == "TEST_GAIN"


def test_declared_parameters_use_px4_names_and_valid_defaults(params):
    for name in ("MC_ROLLRATE_P", "MPC_XY_P", "MIS_TAKEOFF_ALT", "RTL_RETURN_ALT", "COM_DISARM_LAND", "SYS_AUTOSTART"):
        assert name in params
    assert params.definition("SYS_AUTOSTART").ptype == ParamType.INT32 and params.get("SYS_AUTOSTART") != 0
    for name in params.names():
        d = params.definition(name)
        assert d.min <= params.get(name) <= d.max and len(name) <= 16


def test_a_bound_sent_as_float32_is_the_bound():
    """A REAL32 parameter whose minimum (or maximum) is not exact in float32 (0.01) must accept that bound as a
    ground station sends it (0.0099999998): QGroundControl's "reset to default" of a default at the bound."""
    store = ParameterStore([param("X_RISE", 0.01, 0.01, 0.5, "s", "a bound not exact in float32")])
    f32 = struct.unpack("<f", struct.pack("<f", 0.01))[0]
    assert f32 < 0.01
    assert store.set("X_RISE", f32) == 0.01
    with pytest.raises(ParamError, match="outside range"):
        store.set("X_RISE", 0.0099)
