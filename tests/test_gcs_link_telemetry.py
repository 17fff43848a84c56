"""GcsLink's telemetry (autopilot.mavlink) against a real pymavlink client over loopback UDP.

The heartbeat, the streams (rates in simulated time, their content, SET_MESSAGE_INTERVAL per
endpoint), REQUEST_MESSAGE and the capabilities; and the pure conversions the streams use
(geodesy, quaternion to Euler angles, STATUSTEXT chunks).  Commands and robustness are in
tests/test_gcs_link_commands.py, parameters in tests/test_gcs_link_params.py.

The link runs on simulated time: every test pumps ``link.update(t_us)`` itself and
drains the client sockets after each call (tests/gcs_link_harness.py).  Each test leases a free
instance (``free_instance``, tests/conftest.py), so its ports are clear of every other test's.
"""

from __future__ import annotations

import math
import os

import numpy as np
import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from mavsim_core.geodesy import geodetic_to_ned, ned_to_geodetic  # noqa: E402
from mavsim_core.quaternion import to_euler  # noqa: E402
from mavsim_core.statustext import split_statustext  # noqa: E402

from gcs_link_harness import (  # tests/gcs_link_harness.py
    BASE_MODE,
    CUSTOM_MODE_POSCTL,
    ORIGIN,
    StubVehicle,
    acks,
    command_long,
    make_snapshot,
    of_type,
)

# --------------------------------------------------------------------------- pure functions


def test_global_ned_round_trip():
    for origin in [ORIGIN, (-33.9, 151.2, 10.0), (0.0, 179.9999, 0.0), (64.1, -21.9, 50.0)]:
        for ned in ([0.0, 0.0, 0.0], [100.0, -250.0, -30.0], [-1234.5, 987.6, 12.0]):
            lat, lon, alt = ned_to_geodetic(ned, *origin)
            back = geodetic_to_ned(lat, lon, alt, *origin)
            np.testing.assert_allclose(back, ned, atol=1e-6)
    # 1 km north is 1000 / R rad of latitude; east shrinks with cos(lat)
    lat, lon, alt = ned_to_geodetic([1000.0, 1000.0, -20.0], 45.0, 0.0, 100.0)
    assert lat == pytest.approx(45.0 + math.degrees(1000.0 / 6378137.0))
    assert lon == pytest.approx(math.degrees(1000.0 / (6378137.0 * math.cos(math.radians(45.0)))))
    assert alt == pytest.approx(120.0)
    # across the antimeridian
    lat, lon, _ = ned_to_geodetic([0.0, 100.0, 0.0], 0.0, 179.9999, 0.0)
    assert -180.0 <= lon < -179.99


def test_to_euler():
    roll, pitch, yaw = 0.1, -0.2, 2.5
    cr, sr = math.cos(roll / 2), math.sin(roll / 2)
    cp, sp = math.cos(pitch / 2), math.sin(pitch / 2)
    cy, sy = math.cos(yaw / 2), math.sin(yaw / 2)
    q = [
        cr * cp * cy + sr * sp * sy,
        sr * cp * cy - cr * sp * sy,
        cr * sp * cy + sr * cp * sy,
        cr * cp * sy - sr * sp * cy,
    ]
    assert to_euler(q) == pytest.approx((roll, pitch, yaw))


def test_split_statustext():
    assert split_statustext("short") == [b"short"]
    assert [len(c) for c in split_statustext("x" * 120)] == [50, 50, 20]
    assert [len(c) for c in split_statustext("x" * 100)] == [50, 50, 0]  # terminating empty chunk
    assert split_statustext("x" * 50) == [b"x" * 50]
    chunks = split_statustext("é" * 30)  # 2 bytes each: never cut inside a character
    assert all(len(c) <= 50 for c in chunks) and b"".join(chunks).decode() == "é" * 30


# --------------------------------------------------------------------------- telemetry


def test_heartbeat_identifies_as_px4(make_harness, free_instance):
    h = make_harness(free_instance())
    c = h.client("gcs")
    got = h.pump(0.1)["gcs"]
    hb = of_type(got, "HEARTBEAT")
    assert hb, "no heartbeat"
    m = hb[0]
    assert m.autopilot == mavlink.MAV_AUTOPILOT_PX4
    assert m.type == mavlink.MAV_TYPE_QUADROTOR
    assert m.custom_mode == CUSTOM_MODE_POSCTL
    assert m.base_mode == BASE_MODE
    assert m.system_status == mavlink.MAV_STATE_ACTIVE
    assert m.mavlink_version == 3
    assert (m.get_srcSystem(), m.get_srcComponent()) == (1, 1)
    assert m.get_msgbuf()[0] == mavlink.PROTOCOL_MARKER_V2
    assert c is not None


def test_streams_rates_in_simulated_time_and_content(make_harness, free_instance):
    h = make_harness(free_instance())
    h.client("gcs")
    got = h.pump(10.0)["gcs"]
    expected_hz = {
        "HEARTBEAT": 1, "SYS_STATUS": 1, "EXTENDED_SYS_STATE": 1, "ATTITUDE": 20, "ATTITUDE_QUATERNION": 10,
        "GLOBAL_POSITION_INT": 5, "LOCAL_POSITION_NED": 5, "GPS_RAW_INT": 2, "VFR_HUD": 4,
        "HOME_POSITION": 0.5, "BATTERY_STATUS": 0.5,
    }  # fmt: skip
    for mtype, hz in expected_hz.items():
        n = len(of_type(got, mtype))
        assert abs(n - hz * 10) <= 1, f"{mtype}: {n} in 10 s, expected {hz * 10}"
    # the snapshot is fetched only when something is due, at most once per update
    assert h.vehicle.snapshot_calls <= 0.15 * h.updates

    gpi = of_type(got, "GLOBAL_POSITION_INT")[-1]
    lat, lon, alt = ned_to_geodetic([10.0, 20.0, -5.0], *ORIGIN)
    assert gpi.lat == round(lat * 1e7) and gpi.lon == round(lon * 1e7)
    assert gpi.alt == round(alt * 1000) and gpi.relative_alt == 5000
    assert (gpi.vx, gpi.vy, gpi.vz) == (100, 200, -50)
    assert gpi.hdg == 9000
    att = of_type(got, "ATTITUDE")[-1]
    assert att.yaw == pytest.approx(math.pi / 2, abs=1e-6) and att.roll == pytest.approx(0.0, abs=1e-6)
    assert att.yawspeed == pytest.approx(0.03)
    assert att.time_boot_ms <= h.t_us // 1000
    aq = of_type(got, "ATTITUDE_QUATERNION")[-1]
    assert (aq.q1, aq.q4) == pytest.approx((math.cos(math.pi / 4), math.sin(math.pi / 4)))
    lpn = of_type(got, "LOCAL_POSITION_NED")[-1]
    assert (lpn.x, lpn.y, lpn.z, lpn.vz) == pytest.approx((10.0, 20.0, -5.0, -0.5))
    hud = of_type(got, "VFR_HUD")[-1]
    assert hud.heading == 90 and hud.throttle == 42
    assert hud.groundspeed == pytest.approx(math.hypot(1.0, 2.0)) and hud.climb == pytest.approx(0.5)
    assert hud.alt == pytest.approx(493.0)
    gps = of_type(got, "GPS_RAW_INT")[-1]
    assert (gps.fix_type, gps.satellites_visible, gps.eph, gps.epv, gps.vel, gps.cog) == (3, 12, 80, 120, 100, 0)
    assert gps.lat == 473978000 and gps.alt == 493000
    sys_status = of_type(got, "SYS_STATUS")[-1]
    assert (sys_status.voltage_battery, sys_status.current_battery, sys_status.battery_remaining) == (16000, 500, 75)
    assert sys_status.onboard_control_sensors_health == 0x2F and 0 <= sys_status.load <= 1000
    assert of_type(got, "EXTENDED_SYS_STATE")[-1].landed_state == mavlink.MAV_LANDED_STATE_IN_AIR
    bat = of_type(got, "BATTERY_STATUS")[-1]
    assert list(bat.voltages) == [4000] * 4 + [65535] * 6
    assert (bat.current_battery, bat.battery_remaining, bat.type) == (500, 75, mavlink.MAV_BATTERY_TYPE_LIPO)
    home = of_type(got, "HOME_POSITION")[-1]
    assert (home.latitude, home.longitude, home.altitude) == (473977420, 85455940, 488000)
    assert list(home.q) == pytest.approx([1.0, 0.0, 0.0, 0.0])


def test_no_estimate_no_attitude_or_position(make_harness, free_instance):
    h = make_harness(free_instance(), StubVehicle(snapshot=make_snapshot(with_estimate=False)))
    c = h.connect("gcs")
    got = h.pump(3.0)["gcs"]
    types = {m.get_type() for m in got}
    assert "HEARTBEAT" in types and "SYS_STATUS" in types
    assert not types & {"ATTITUDE", "ATTITUDE_QUATERNION", "GLOBAL_POSITION_INT", "GPS_RAW_INT", "HOME_POSITION"}
    command_long(c, mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_HOME_POSITION)
    got = h.pump(0.5)["gcs"]
    assert [a.result for a in acks(got, mavlink.MAV_CMD_REQUEST_MESSAGE)] == [mavlink.MAV_RESULT_TEMPORARILY_REJECTED]


def test_set_message_interval(make_harness, free_instance):
    h = make_harness(free_instance())
    c = h.connect("gcs")
    command_long(c, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_ATTITUDE, 20_000)  # 50 Hz
    command_long(c, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, -1)
    got = h.pump(0.1)["gcs"]
    assert [a.result for a in acks(got, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL)] == [mavlink.MAV_RESULT_ACCEPTED] * 2
    got = h.pump(4.0)["gcs"]
    assert abs(len(of_type(got, "ATTITUDE")) - 200) <= 2
    assert of_type(got, "GLOBAL_POSITION_INT") == []
    assert abs(len(of_type(got, "HEARTBEAT")) - 4) <= 1  # others untouched

    command_long(c, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, 0)  # default
    command_long(c, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_ADSB_VEHICLE, 10_000)  # not sent
    command_long(c, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_ATTITUDE, -5)  # invalid
    got = h.pump(0.02)["gcs"]
    results = [a.result for a in acks(got, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL)]
    assert results == [mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_UNSUPPORTED, mavlink.MAV_RESULT_DENIED]
    got = h.pump(4.0)["gcs"]
    assert abs(len(of_type(got, "GLOBAL_POSITION_INT")) - 20) <= 1
    assert h.vehicle.commands == []  # handled by the link itself


def test_interval_applies_to_its_endpoint_only(make_harness, free_instance):
    h = make_harness(free_instance())
    gcs = h.connect("gcs")
    h.connect("api")
    command_long(gcs, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_ATTITUDE, -1)
    h.pump(0.1)
    got = h.pump(2.0)
    assert of_type(got["gcs"], "ATTITUDE") == []
    assert abs(len(of_type(got["api"], "ATTITUDE")) - 40) <= 1


def test_request_message_and_capabilities(make_harness, free_instance):
    h = make_harness(free_instance())
    c = h.connect("gcs")
    command_long(c, mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
    got = h.pump(0.1)["gcs"]
    versions = of_type(got, "AUTOPILOT_VERSION")
    assert len(versions) == 1
    v = versions[0]
    # Exactly what is implemented: offboard (SET_POSITION_TARGET_*, SET_ATTITUDE_TARGET), FTP, termination, ...
    assert v.capabilities == (
        mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2
        | mavlink.MAV_PROTOCOL_CAPABILITY_FTP
        | mavlink.MAV_PROTOCOL_CAPABILITY_FLIGHT_TERMINATION
        | mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
        | mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE
        | mavlink.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
        | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_INT
        | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT
        | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE
        | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_RALLY
        | mavlink.MAV_PROTOCOL_CAPABILITY_SET_ATTITUDE_TARGET
        | mavlink.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
        | mavlink.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
    )
    assert v.flight_sw_version != 0 and v.uid != 0
    assert [a.result for a in acks(got, mavlink.MAV_CMD_REQUEST_MESSAGE)] == [mavlink.MAV_RESULT_ACCEPTED]

    command_long(c, mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, 1)
    command_long(c, mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_GPS_RAW_INT)
    command_long(c, mavlink.MAV_CMD_REQUEST_MESSAGE, 9999)
    got = h.pump(0.02)["gcs"]
    assert len(of_type(got, "AUTOPILOT_VERSION")) == 1
    capabilities = acks(got, mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES)
    assert [a.result for a in capabilities] == [mavlink.MAV_RESULT_ACCEPTED]
    assert [a.result for a in acks(got, mavlink.MAV_CMD_REQUEST_MESSAGE)] == [
        mavlink.MAV_RESULT_ACCEPTED,
        mavlink.MAV_RESULT_UNSUPPORTED,
    ]
    assert len(of_type(got, "GPS_RAW_INT")) >= 1
    assert h.vehicle.commands == []
