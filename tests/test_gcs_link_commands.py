"""GcsLink's commands, modes and robustness (autopilot.mavlink), against a real pymavlink client over loopback UDP.

COMMAND_LONG / COMMAND_INT handed to the vehicle, SET_MODE, TIMESYNC and the empty mission
protocol; garbage on the socket, both endpoints and extra peers, long STATUSTEXT in chunks,
NaN in the snapshot and a simulator restart.  Telemetry is in tests/test_gcs_link_telemetry.py,
parameters in tests/test_gcs_link_params.py.

The link runs on simulated time: every test pumps ``link.update(t_us)`` itself and
drains the client sockets after each call (tests/gcs_link_harness.py).  Each test leases a free
instance (``free_instance``, tests/conftest.py), so its ports are clear of every other test's.
"""

from __future__ import annotations

import math
import os
import socket

import numpy as np
import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from autopilot.mavlink.link import GcsLink  # noqa: E402
from autopilot.topics import BatteryState, VehicleEstimate  # noqa: E402
from mavsim_core import ports

from gcs_link_harness import (  # tests/gcs_link_harness.py
    GCS_COMP,
    GCS_SYS,
    ORIGIN,
    StubVehicle,
    acks,
    command_long,
    make_snapshot,
    of_type,
)

# --------------------------------------------------------------------------- commands and modes


def test_unknown_command_goes_to_vehicle_and_is_unsupported(make_harness, free_instance):
    h = make_harness(free_instance())
    c = h.connect("gcs")
    command_long(c, 31010, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0)
    command_long(c, 31011, target_system=2)  # another vehicle: ignored
    command_long(c, 31012, target_component=mavlink.MAV_COMP_ID_CAMERA)  # another component: ignored
    got = h.pump(0.1)["gcs"]
    all_acks = of_type(got, "COMMAND_ACK")
    assert len(all_acks) == 1
    ack = all_acks[0]
    assert (ack.command, ack.result) == (31010, mavlink.MAV_RESULT_UNSUPPORTED)
    assert (ack.target_system, ack.target_component) == (GCS_SYS, GCS_COMP)
    assert h.vehicle.commands == [(31010, (1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0), mavlink.MAV_FRAME_GLOBAL)]


def test_command_int_global_frame_converted_to_degrees(make_harness, free_instance):
    h = make_harness(free_instance())
    h.vehicle.results[mavlink.MAV_CMD_DO_REPOSITION] = mavlink.MAV_RESULT_ACCEPTED
    c = h.connect("gcs")
    c.mav.command_int_send(
        1, 1, mavlink.MAV_FRAME_GLOBAL_INT, mavlink.MAV_CMD_DO_REPOSITION, 0, 0,
        -1.0, 1.0, 0.0, math.nan, 473977420, 85455940, 510.5,
    )  # fmt: skip
    got = h.pump(0.1)["gcs"]
    assert [a.result for a in acks(got, mavlink.MAV_CMD_DO_REPOSITION)] == [mavlink.MAV_RESULT_ACCEPTED]
    ((command, params, frame),) = h.vehicle.commands
    assert command == mavlink.MAV_CMD_DO_REPOSITION and frame == mavlink.MAV_FRAME_GLOBAL_INT
    assert params[4] == pytest.approx(47.397742) and params[5] == pytest.approx(8.545594)
    assert params[6] == pytest.approx(510.5) and math.isnan(params[3])


def test_set_mode_message_acked_as_do_set_mode(make_harness, free_instance):
    h = make_harness(free_instance())
    c = h.connect("gcs")
    c.mav.set_mode_send(1, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 4 << 16 | 3 << 24)
    c.mav.set_mode_send(7, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 2 << 16)  # not us
    got = h.pump(0.1)["gcs"]
    assert h.vehicle.set_modes == [(mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 4 << 16 | 3 << 24)]
    acks = [(a.command, a.result) for a in of_type(got, "COMMAND_ACK")]
    assert acks == [(mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_RESULT_ACCEPTED)]  # PX4's: SET_MODE runs as DO_SET_MODE


def test_timesync_and_empty_plans(make_harness, free_instance):
    h = make_harness(free_instance())
    c = h.connect("gcs")
    c.mav.timesync_send(0, 123456789)
    c.mav.mission_request_list_send(1, 1, mavlink.MAV_MISSION_TYPE_FENCE)
    c.mav.mission_clear_all_send(1, 1, mavlink.MAV_MISSION_TYPE_MISSION)
    c.mav.mission_count_send(1, 1, 3, mavlink.MAV_MISSION_TYPE_MISSION)
    got = h.pump(0.02)["gcs"]
    (ts,) = of_type(got, "TIMESYNC")
    assert ts.ts1 == 123456789 and 0 < ts.tc1 <= h.t_us * 1000
    (count,) = of_type(got, "MISSION_COUNT")
    assert (count.count, count.mission_type, count.target_system) == (0, mavlink.MAV_MISSION_TYPE_FENCE, GCS_SYS)
    assert [a.type for a in of_type(got, "MISSION_ACK")] == [mavlink.MAV_MISSION_ACCEPTED]
    # the upload of 3 items has begun: the vehicle asks for the first one
    (request,) = of_type(got, "MISSION_REQUEST_INT")
    assert (request.seq, request.mission_type, request.target_system) == (0, mavlink.MAV_MISSION_TYPE_MISSION, GCS_SYS)


# --------------------------------------------------------------------------- robustness and endpoints


def test_garbage_does_not_break_the_link(make_harness, free_instance):
    h = make_harness(free_instance())
    c = h.connect("gcs")
    good = (
        mavlink.MAVLink(None, GCS_SYS, GCS_COMP)
        .command_long_encode(
            1, 1, mavlink.MAV_CMD_REQUEST_MESSAGE, 0, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION, 0, 0, 0, 0, 0, 0
        )
        .pack(mavlink.MAVLink(None, GCS_SYS, GCS_COMP))
    )
    bad_crc = bytearray(good)
    bad_crc[-1] ^= 0xFF
    rng = np.random.default_rng(1)
    junk = [
        bytes(rng.integers(0, 256, 300, dtype=np.uint8)),
        b"\xfd\xff" + b"\x00" * 20,  # header announcing more bytes than the datagram holds
        good[:15],  # truncated
        bytes(bad_crc),
        b"\xfe\x09",
        b"",
    ]
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        for j in junk:
            s.sendto(j, ("127.0.0.1", ports.gcs_local_port(h.instance)))
        s.sendto(b"junk" + good, ("127.0.0.1", ports.gcs_local_port(h.instance)))  # junk then a good packet
    h.pump(0.2)
    assert h.link.rx_errors >= 4
    command_long(c, mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
    got = h.pump(0.1)["gcs"]
    assert [a.result for a in acks(got, mavlink.MAV_CMD_REQUEST_MESSAGE)] == [mavlink.MAV_RESULT_ACCEPTED]


def test_both_endpoints_and_peers_get_telemetry(make_harness, free_instance):
    h = make_harness(free_instance())
    h.client("gcs")
    h.client("api")
    got = h.pump(1.5)
    assert of_type(got["gcs"], "HEARTBEAT") and of_type(got["api"], "HEARTBEAT")
    # a client on some other port is heard once it talks to the api endpoint
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        s.setblocking(False)
        mav = mavlink.MAVLink(None, 254, 191)
        hb = mav.heartbeat_encode(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        s.sendto(hb.pack(mav), ("127.0.0.1", ports.api_local_port(h.instance)))
        h.pump(1.5)
        parser = mavlink.MAVLink(None)
        types = set()
        while True:
            try:
                data = s.recv(65536)
            except BlockingIOError:
                break
            types |= {m.get_type() for m in parser.parse_buffer(data) or []}
        assert "HEARTBEAT" in types and "ATTITUDE" in types
    # and the default destination still gets telemetry
    got = h.pump(1.5)
    assert of_type(got["api"], "HEARTBEAT")


def test_long_statustext_arrives_in_chunks(make_harness, free_instance):
    h = make_harness(free_instance())
    h.connect("gcs")
    h.connect("api")
    text = "".join(chr(ord("a") + i % 26) for i in range(120))
    h.vehicle.events.append((mavlink.MAV_SEVERITY_WARNING, text))
    h.vehicle.events.append((mavlink.MAV_SEVERITY_INFO, "short one"))
    got = h.pump(0.02)
    for name in ("gcs", "api"):
        texts = of_type(got[name], "STATUSTEXT")
        chunks = [m for m in texts if m.severity == mavlink.MAV_SEVERITY_WARNING]
        assert [m.chunk_seq for m in chunks] == [0, 1, 2]
        assert len({m.id for m in chunks}) == 1 and chunks[0].id != 0
        assert "".join(m.text for m in chunks) == text
        short = [m for m in texts if m.severity == mavlink.MAV_SEVERITY_INFO]
        assert [(m.text, m.id) for m in short] == [("short one", 0)]


def test_nan_snapshot_and_clock_restart_do_not_break_streams(make_harness, free_instance):
    snap = make_snapshot()
    nan3 = np.full(3, math.nan)
    estimate = VehicleEstimate(
        timestamp_us=0, q_wxyz=np.array([math.nan] * 4), rate_frd_rad_s=nan3, accel_ned_m_s2=nan3,
        pos_ned_m=nan3, vel_ned_m_s=nan3, attitude_valid=False, position_valid=True,
        origin_lat_deg=ORIGIN[0], origin_lon_deg=ORIGIN[1], origin_alt_amsl_m=ORIGIN[2],
    )  # fmt: skip
    battery = BatteryState(voltage_v=math.nan, current_a=math.nan, remaining_frac=math.nan)
    from dataclasses import replace

    h = make_harness(
        free_instance(), StubVehicle(snapshot=replace(snap, estimate=estimate, battery=battery, throttle_frac=math.nan))
    )
    h.client("gcs")
    got = h.pump(2.0)["gcs"]
    assert h.link.tx_build_errors == 0
    types = {m.get_type() for m in got}
    assert {"HEARTBEAT", "GLOBAL_POSITION_INT", "VFR_HUD", "BATTERY_STATUS", "SYS_STATUS"} <= types
    gpi = of_type(got, "GLOBAL_POSITION_INT")[-1]
    assert (gpi.lat, gpi.vx, gpi.hdg) == (0, 0, 65535)
    assert of_type(got, "SYS_STATUS")[-1].voltage_battery == 65535
    # the simulator restarted: simulated time jumps back, streams keep going
    h.t_us = 0
    got = h.pump(2.0)["gcs"]
    assert abs(len(of_type(got, "HEARTBEAT")) - 2) <= 1


def test_stream_rates_option_is_checked(free_instance):
    with pytest.raises(ValueError, match="cannot stream"):
        GcsLink(StubVehicle(), instance=free_instance(), stream_rates_hz={mavlink.MAVLINK_MSG_ID_ADSB_VEHICLE: 50.0})
