"""GcsLink's parameter protocol (autopilot.mavlink), against a real pymavlink client over loopback UDP.

The full list, PX4's byte-wise INT32 encoding both ways, refused sets (the old value echoed,
a STATUSTEXT says why), changes made elsewhere broadcast to every endpoint.  Telemetry is in
tests/test_gcs_link_telemetry.py, commands and robustness in tests/test_gcs_link_commands.py.

The link runs on simulated time: every test pumps ``link.update(t_us)`` itself and
drains the client sockets after each call (tests/gcs_link_harness.py).  Each test leases a free
instance (``free_instance``, tests/conftest.py), so its ports are clear of every other test's.
"""

from __future__ import annotations

import os
import struct

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from mavsim_core.param_encoding import decode_param_bytes, encode_param_bytes  # noqa: E402

from gcs_link_harness import StubVehicle, make_params, of_type  # tests/gcs_link_harness.py

# --------------------------------------------------------------------------- pure functions


def test_param_value_encoding():
    for v in (0, 1, -1, 4001, -5_000_000, 2**31 - 1, -(2**31)):
        raw = encode_param_bytes(v, mavlink.MAV_PARAM_TYPE_INT32)
        assert raw == struct.pack("<i", v)
        assert decode_param_bytes(raw, mavlink.MAV_PARAM_TYPE_INT32) == v
    raw = encode_param_bytes(0.25, mavlink.MAV_PARAM_TYPE_REAL32)
    assert decode_param_bytes(raw, mavlink.MAV_PARAM_TYPE_REAL32) == 0.25


# --------------------------------------------------------------------------- parameters


def test_full_parameter_list(make_harness, free_instance):
    h = make_harness(free_instance(), StubVehicle(params=make_params(extra=400)))
    c = h.connect("gcs")
    store = h.vehicle.params
    start_us = h.t_us
    c.mav.param_request_list_send(1, 1)
    got = h.pump(5.0, until=lambda m: m.get_type() == "PARAM_VALUE" and m.param_index == len(store) - 1)["gcs"]
    elapsed = (h.t_us - start_us) * 1e-6  # simulated: the link's own clock, not this machine's load
    values = of_type(got, "PARAM_VALUE")
    assert sorted(m.param_index for m in values) == list(range(len(store)))  # every index exactly once
    assert {m.param_count for m in values} == {len(store)}
    assert all(m.param_id == store.name_at(m.param_index) for m in values)
    assert elapsed < 1.0, f"parameter list took {elapsed:.2f} simulated s"
    real = next(m for m in values if m.param_id == "MPC_XY_P")
    assert real.param_type == mavlink.MAV_PARAM_TYPE_REAL32 and real.param_value == pytest.approx(0.95)


def param_value_raw(m) -> bytes:
    """The 4 wire bytes of a received PARAM_VALUE's param_value."""
    return bytes(m.get_msgbuf()[mavlink.HEADER_LEN_V2 : mavlink.HEADER_LEN_V2 + 4])


class RawParamSet(mavlink.MAVLink_param_set_message):
    """PARAM_SET with exact value bytes (a Python float would corrupt sNaN-looking int32s)."""

    def __init__(self, name: str, raw4: bytes, param_type: int) -> None:
        super().__init__(1, 1, name.encode(), 0.0, param_type)
        self.raw4 = raw4

    def pack(self, mav, force_mavlink1=False):
        payload = self.unpacker.pack(
            0.0, self.target_system, self.target_component, self._param_id_raw, self.param_type
        )
        return self._pack(mav, self.crc_extra, self.raw4 + payload[4:], force_mavlink1=force_mavlink1)


def test_int32_bytewise_round_trip(make_harness, free_instance):
    h = make_harness(free_instance())
    c = h.connect("gcs")
    c.mav.param_request_read_send(1, 1, b"SYS_AUTOSTART", -1)
    got = of_type(h.pump(0.02)["gcs"], "PARAM_VALUE")
    assert len(got) == 1 and got[0].param_type == mavlink.MAV_PARAM_TYPE_INT32
    assert param_value_raw(got[0]) == struct.pack("<i", 4001)
    assert struct.unpack("<i", struct.pack("<f", got[0].param_value))[0] == 4001

    byte_wise = struct.unpack("<f", struct.pack("<i", 4010))[0]
    c.mav.param_set_send(1, 1, b"SYS_AUTOSTART", byte_wise, mavlink.MAV_PARAM_TYPE_INT32)
    got = of_type(h.pump(0.02)["gcs"], "PARAM_VALUE")
    assert len(got) == 1 and param_value_raw(got[0]) == struct.pack("<i", 4010)
    assert h.vehicle.params.get("SYS_AUTOSTART") == 4010

    # a value whose bytes form a signalling NaN survives exactly, both ways
    c.mav.send(RawParamSet("TST_INT", struct.pack("<i", -5_000_000), mavlink.MAV_PARAM_TYPE_INT32))
    got = of_type(h.pump(0.02)["gcs"], "PARAM_VALUE")
    assert h.vehicle.params.get("TST_INT") == -5_000_000
    assert len(got) == 1 and param_value_raw(got[0]) == struct.pack("<i", -5_000_000)
    assert got[0].param_index == h.vehicle.params.index("TST_INT")

    c.mav.param_request_read_send(1, 1, b"", h.vehicle.params.index("MPC_XY_P"))  # by index
    got = of_type(h.pump(0.02)["gcs"], "PARAM_VALUE")
    assert [m.param_id for m in got] == ["MPC_XY_P"]


def test_param_set_refused_echoes_old_value(make_harness, free_instance):
    h = make_harness(free_instance())
    c = h.connect("gcs")
    c.mav.param_set_send(1, 1, b"MPC_XY_P", 5.0, mavlink.MAV_PARAM_TYPE_REAL32)  # out of range
    got = h.pump(0.02)["gcs"]
    (pv,) = of_type(got, "PARAM_VALUE")
    assert pv.param_id == "MPC_XY_P" and pv.param_value == pytest.approx(0.95)
    (st,) = of_type(got, "STATUSTEXT")
    assert st.severity == mavlink.MAV_SEVERITY_ERROR and "MPC_XY_P" in st.text and "range" in st.text
    assert h.vehicle.params.get("MPC_XY_P") == 0.95

    c.mav.param_set_send(1, 1, b"SYS_AUTOSTART", 4010.0, mavlink.MAV_PARAM_TYPE_REAL32)  # wrong type
    got = h.pump(0.02)["gcs"]
    (pv,) = of_type(got, "PARAM_VALUE")
    assert param_value_raw(pv) == struct.pack("<i", 4001) and pv.param_type == mavlink.MAV_PARAM_TYPE_INT32
    (st,) = of_type(got, "STATUSTEXT")
    assert st.severity == mavlink.MAV_SEVERITY_ERROR and "INT32" in st.text
    assert h.vehicle.params.get("SYS_AUTOSTART") == 4001

    c.mav.param_set_send(1, 1, b"NO_SUCH_PARAM", 1.0, mavlink.MAV_PARAM_TYPE_REAL32)
    c.mav.param_request_read_send(1, 1, b"NO_SUCH_PARAM2", -1)
    got = h.pump(0.02)["gcs"]
    assert of_type(got, "PARAM_VALUE") == []
    texts = [m.text for m in of_type(got, "STATUSTEXT")]
    # the second within UNKNOWN_TEXT_PERIOD_S is held back (tests/test_gcs_link_px4_leftovers.py), then counted
    assert texts == ["unknown parameter NO_SUCH_PARAM"]
    assert len(of_type(got, "PARAM_ERROR")) == 2  # each still answered


def test_param_change_from_elsewhere_is_broadcast(make_harness, free_instance):
    h = make_harness(free_instance())
    h.connect("gcs")
    h.connect("api")
    h.vehicle.params.set("MPC_XY_P", 1.25)
    got = h.pump(0.02)
    for name in ("gcs", "api"):
        (pv,) = of_type(got[name], "PARAM_VALUE")
        assert pv.param_value == pytest.approx(1.25)
