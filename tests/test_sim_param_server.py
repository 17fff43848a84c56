"""The simulator's MAVLink parameter service: :class:`sitl.param_server.SimParamServer`.

It runs in this process on a real UDP socket; a pymavlink client (``udpin``) is its default
peer.  The test drives ``poll()`` itself with a fake wall clock, so nothing depends on timing
(deadlines only stop a broken test from hanging).  The heartbeat, the list, reads, C-cast
sets and refusals, commands, MAVFTP, malformed datagrams, peers.  The same service in the real
``sitl`` process is tested in tests/test_sitl_cli.py.
"""

from __future__ import annotations

import math
import os
import socket
import struct
import time

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from mavsim_core.param_encoding import INT32, REAL32, raw_param_value  # noqa: E402
from sitl.param_server import SIM_COMPID, SIM_SYSID, SimParamServer  # noqa: E402

from sim_params_helpers import GCS_COMP, GCS_SYS, make_params, value_of  # tests/sim_params_helpers.py

# --------------------------------------------------------------------------- the MAVLink service


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Harness:
    """A SimParamServer on a real socket and a pymavlink client as its default peer."""

    def __init__(self) -> None:
        self.params, self.wind, self.sensors, self.motors = make_params()
        port = free_udp_port()
        self.client = mavutil.mavlink_connection(
            f"udpin:127.0.0.1:{port}", source_system=GCS_SYS, source_component=GCS_COMP
        )
        self.changes: list[tuple[str, float, tuple]] = []
        self.server = SimParamServer(
            self.params,
            bind=("127.0.0.1", 0),
            default_peer=("127.0.0.1", port),
            on_param_set=lambda *a: self.changes.append(a),
        )
        self.now_s = 0.0  # the fake wall clock handed to poll()

    def pump(self, rounds: int = 20) -> list:
        """Poll the server and drain the client until a few rounds bring nothing new."""
        got, quiet, deadline = [], 0, time.monotonic() + 5.0
        while quiet < rounds and time.monotonic() < deadline:
            self.server.poll(self.now_s)
            m = self.client.recv_match(blocking=True, timeout=0.005)
            if m is None:
                quiet += 1
                continue
            quiet = 0
            if m.get_type() != "BAD_DATA":
                got.append(m)
        return got

    def hello(self) -> None:
        """First contact: the heartbeat tells the client where the server is."""
        got = self.pump()
        assert [m.get_type() for m in got] == ["HEARTBEAT"]

    def close(self) -> None:
        self.server.close()
        self.client.close()


@pytest.fixture
def h():
    harness = Harness()
    yield harness
    harness.close()


def of_type(msgs: list, kind: str) -> list:
    return [m for m in msgs if m.get_type() == kind]


def test_heartbeat_identity_and_pacing(h):
    got = h.pump()
    (hb,) = of_type(got, "HEARTBEAT")
    assert (hb.get_srcSystem(), hb.get_srcComponent()) == (SIM_SYSID, SIM_COMPID) == (1, 51)
    assert (hb.type, hb.autopilot) == (mavlink.MAV_TYPE_GENERIC, mavlink.MAV_AUTOPILOT_GENERIC)
    assert h.client.probably_vehicle_heartbeat(hb) and h.client.target_system == 1  # pymavlink locks on
    h.now_s = 0.9
    assert of_type(h.pump(), "HEARTBEAT") == []
    h.now_s = 1.0
    assert len(of_type(h.pump(), "HEARTBEAT")) == 1
    h.now_s = 10.0  # a stalled loop gets one heartbeat, not a burst
    assert len(of_type(h.pump(), "HEARTBEAT")) == 1


def test_full_list_download(h):
    h.hello()
    h.client.mav.param_request_list_send(SIM_SYSID, SIM_COMPID)
    got = of_type(h.pump(), "PARAM_VALUE")
    n = len(h.params)
    assert len(got) == n
    assert {m.param_count for m in got} == {n}
    assert sorted(m.param_index for m in got) == list(range(n))
    assert [m.param_id for m in sorted(got, key=lambda m: m.param_index)] == h.params.names()
    for m in got:
        p = h.params.at(m.param_index)
        assert m.param_type == (INT32 if p.type == "INT32" else REAL32)
        assert value_of(m) == pytest.approx(h.params.get(p.name), rel=1e-7)
    lag = next(m for m in got if m.param_id == "SIM_GPS_LAG_MS")
    assert raw_param_value(lag) == struct.pack("<f", 120.0)  # C-cast (the simulator is not PX4), not byte-wise


def test_read_by_name_and_index(h):
    h.hello()
    h.client.mav.param_request_read_send(SIM_SYSID, SIM_COMPID, b"SIM_GUST_DUR", -1)
    (pv,) = of_type(h.pump(), "PARAM_VALUE")
    assert (pv.param_id, pv.param_value, pv.param_index) == ("SIM_GUST_DUR", 2.0, h.params.param("SIM_GUST_DUR").index)
    idx = h.params.param("SIM_ENGINE_FAIL").index
    h.client.mav.param_request_read_send(SIM_SYSID, SIM_COMPID, b"IGNORED", idx)
    (pv,) = of_type(h.pump(), "PARAM_VALUE")
    assert pv.param_id == "SIM_ENGINE_FAIL" and pv.param_type == INT32 and value_of(pv) == 0
    h.client.mav.param_request_read_send(0, 0, b"SIM_WIND_DIR", -1)  # broadcast target
    assert [m.param_id for m in of_type(h.pump(), "PARAM_VALUE")] == ["SIM_WIND_DIR"]
    h.client.mav.param_request_read_send(SIM_SYSID, 1, b"SIM_WIND_DIR", -1)  # the flight controller's: not us
    assert of_type(h.pump(), "PARAM_VALUE") == []
    h.client.mav.param_request_read_send(SIM_SYSID, SIM_COMPID, b"SIM_NOPE", -1)
    h.client.mav.param_request_read_send(SIM_SYSID, SIM_COMPID, b"", len(h.params))
    got = h.pump()
    assert of_type(got, "PARAM_VALUE") == []
    n = len(h.params)
    assert [m.text for m in of_type(got, "STATUSTEXT")] == [
        "SIM_NOPE: unknown parameter",
        f"#{n}: no parameter at index {n} (0..{n - 1})",
    ]


def test_set_real32_and_int32_c_cast(h):
    h.hello()
    h.client.mav.param_set_send(SIM_SYSID, SIM_COMPID, b"SIM_WIND_SPD", 4.5, REAL32)
    got = h.pump()
    (pv,) = of_type(got, "PARAM_VALUE")
    assert (pv.param_id, pv.param_value, pv.param_type) == ("SIM_WIND_SPD", 4.5, REAL32)
    assert of_type(got, "STATUSTEXT") == []
    assert h.wind.speed_m_s == 4.5  # the models read this object on their next step

    h.client.mav.param_set_send(SIM_SYSID, SIM_COMPID, b"SIM_ENGINE_FAIL", 3.0, INT32)
    (pv,) = of_type(h.pump(), "PARAM_VALUE")
    assert pv.param_type == INT32 and raw_param_value(pv) == struct.pack("<f", 3.0)
    assert h.motors.fail_motor == 3 and isinstance(h.motors.fail_motor, int)

    # read back
    h.client.mav.param_request_read_send(SIM_SYSID, SIM_COMPID, b"SIM_ENGINE_FAIL", -1)
    h.client.mav.param_request_read_send(SIM_SYSID, SIM_COMPID, b"SIM_WIND_SPD", -1)
    assert [(m.param_id, value_of(m)) for m in of_type(h.pump(), "PARAM_VALUE")] == [
        ("SIM_ENGINE_FAIL", 3),
        ("SIM_WIND_SPD", 4.5),
    ]

    # a client that sends an integer parameter typed REAL32: the value is what counts
    h.client.mav.param_set_send(SIM_SYSID, SIM_COMPID, b"SIM_GPS_LAG_MS", 250.0, REAL32)
    (pv,) = of_type(h.pump(), "PARAM_VALUE")
    assert pv.param_type == INT32 and value_of(pv) == 250 and h.sensors.gps_lag_ms == 250
    assert [c[:2] for c in h.changes] == [("SIM_WIND_SPD", 4.5), ("SIM_ENGINE_FAIL", 3), ("SIM_GPS_LAG_MS", 250)]
    assert h.server.params_set == 3


def test_refused_set_echoes_old_value_and_says_why(h):
    h.hello()
    h.client.mav.param_set_send(SIM_SYSID, SIM_COMPID, b"SIM_WIND_SPD", 40.0, REAL32)
    got = h.pump()
    (pv,) = of_type(got, "PARAM_VALUE")
    assert (pv.param_id, pv.param_value) == ("SIM_WIND_SPD", 0.0)
    (st,) = of_type(got, "STATUSTEXT")
    assert st.severity == mavlink.MAV_SEVERITY_ERROR and st.text == "SIM_WIND_SPD: 40 outside range [0, 30] m/s"
    assert h.wind.speed_m_s == 0.0

    h.client.mav.param_set_send(SIM_SYSID, SIM_COMPID, b"SIM_ENGINE_FAIL", 2.5, REAL32)
    got = h.pump()
    (pv,) = of_type(got, "PARAM_VALUE")
    assert pv.param_type == INT32 and value_of(pv) == 0
    assert "not an integer" in of_type(got, "STATUSTEXT")[0].text

    h.client.mav.param_set_send(SIM_SYSID, SIM_COMPID, b"SIM_ENGINE_FAIL", math.nan, REAL32)
    h.client.mav.param_set_send(SIM_SYSID, SIM_COMPID, b"SIM_ENGINE_FAIL", 2.8e-45, INT32)  # a byte-wise 2: refused
    got = h.pump()
    assert [value_of(m) for m in of_type(got, "PARAM_VALUE")] == [0, 0]
    texts = [m.text for m in of_type(got, "STATUSTEXT")]
    assert texts[0] == "SIM_ENGINE_FAIL: value must be finite, not nan"
    assert texts[1].startswith("SIM_ENGINE_FAIL: 2.8026e-45 is not an integer")

    h.client.mav.param_set_send(SIM_SYSID, SIM_COMPID, b"SIM_NOPE", 1.0, REAL32)
    got = h.pump()
    assert of_type(got, "PARAM_VALUE") == []
    assert [m.text for m in of_type(got, "STATUSTEXT")] == ["SIM_NOPE: unknown parameter"]
    assert h.motors.fail_motor == 0 and h.changes == [] and h.server.params_set == 0


def test_commands(h):
    h.hello()
    h.client.mav.command_long_send(SIM_SYSID, SIM_COMPID, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    (ack,) = of_type(h.pump(), "COMMAND_ACK")
    assert (ack.command, ack.result) == (mavlink.MAV_CMD_COMPONENT_ARM_DISARM, mavlink.MAV_RESULT_UNSUPPORTED)
    assert (ack.target_system, ack.target_component) == (GCS_SYS, GCS_COMP)
    h.client.mav.command_long_send(
        SIM_SYSID,
        SIM_COMPID,
        mavlink.MAV_CMD_REQUEST_MESSAGE,
        0,
        mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION,
        0,
        0,
        0,
        0,
        0,
        0,
    )
    got = h.pump()
    (ver,) = of_type(got, "AUTOPILOT_VERSION")
    assert ver.capabilities & mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_C_CAST
    assert not ver.capabilities & mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE
    assert of_type(got, "COMMAND_ACK")[0].result == mavlink.MAV_RESULT_ACCEPTED
    h.client.mav.command_int_send(SIM_SYSID, SIM_COMPID, 0, mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 0, 0, 0)
    (ack,) = of_type(h.pump(), "COMMAND_ACK")
    assert ack.result == mavlink.MAV_RESULT_UNSUPPORTED


def test_mavftp_is_refused_at_once(h):
    h.hello()
    request = [7, 0, 3, 4, 1, 0, 0, 0, 0, 0, 0, 0] + [ord("/")] + [0] * 238  # seq 7, session 3, OpenFileRO "/"
    h.client.mav.file_transfer_protocol_send(0, SIM_SYSID, SIM_COMPID, request)
    (reply,) = of_type(h.pump(), "FILE_TRANSFER_PROTOCOL")
    p = reply.payload
    assert (p[0] | p[1] << 8, p[2], p[3], p[4], p[5], p[12]) == (8, 3, 129, 1, 4, 7)  # NAK, ERR_UnknownCommand


def test_malformed_datagrams_are_ignored(h):
    h.hello()
    server_addr = ("127.0.0.1", h.server.local_address[1])
    raw = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        good = mavlink.MAVLink_param_request_read_message(SIM_SYSID, SIM_COMPID, b"SIM_WIND_DIR", -1)
        packet = bytearray(good.pack(mavlink.MAVLink(None, GCS_SYS, GCS_COMP)))
        bad_crc = bytearray(packet)
        bad_crc[-1] ^= 0xFF
        for junk in (
            b"",
            b"\x00",
            b"hello world" * 50,
            bytes(range(256)),
            bytes(packet[:-3]),
            bytes(bad_crc),
            b"\xfd\xff" + b"\x00" * 300,
        ):
            raw.sendto(junk, server_addr)
        raw.sendto(bytes(packet) + b"\xfd\x09", server_addr)  # a good packet with trailing damage
        got = h.pump()
        assert [m.param_id for m in of_type(got, "PARAM_VALUE")] == ["SIM_WIND_DIR"]
        assert h.server.rx_errors >= 5
    finally:
        raw.close()


def test_peers_are_remembered_and_send_reaches_everyone(h):
    h.hello()
    other = mavutil.mavlink_connection(
        "udpout:127.0.0.1:%d" % h.server.local_address[1], source_system=GCS_SYS, source_component=191
    )
    try:
        other.mav.param_request_read_send(SIM_SYSID, SIM_COMPID, b"SIM_WIND_TURB", -1)
        got_default = h.pump()
        assert [m.param_id for m in of_type(got_default, "PARAM_VALUE")] == ["SIM_WIND_TURB"]  # default peer too
        m = other.recv_match(type="PARAM_VALUE", blocking=True, timeout=2)
        assert m is not None and m.param_id == "SIM_WIND_TURB"  # and the one who asked
        h.server.send(h.server.encode([mavlink.MAVLink_local_position_ned_message(1, 1.0, 2.0, 3.0, 0, 0, 0)]))
        m = other.recv_match(type="LOCAL_POSITION_NED", blocking=True, timeout=2)
        assert m is not None and (m.x, m.get_srcComponent()) == (1.0, SIM_COMPID)
        assert [x.x for x in of_type(h.pump(), "LOCAL_POSITION_NED")] == [1.0]
        assert len(h.server.destinations) == 2
    finally:
        other.close()
