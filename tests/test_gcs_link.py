"""Tests of autopilot.mavlink (GcsLink) against a real pymavlink client over loopback UDP.

The link runs on simulated time: every test pumps ``link.update(t_us)`` itself and
drains the client sockets after each call.  Its ten instances (tests/instances.py) keep
the ports clear of other tests.
"""

from __future__ import annotations

import math
import os
import socket
import struct
import time

import numpy as np
import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from autopilot.mavlink.link import GcsLink  # noqa: E402
from autopilot.parameters import ParamDef, ParameterStore, ParamType  # noqa: E402
from autopilot.topics import (  # noqa: E402
    BatteryState,
    GpsSample,
    HomePosition,
    LandedState,
    TelemetrySnapshot,
    VehicleEstimate,
)
from mavsim_core.geodesy import geodetic_to_ned, ned_to_geodetic  # noqa: E402
from mavsim_core.param_encoding import decode_param_bytes, encode_param_bytes  # noqa: E402
from mavsim_core.quaternion import to_euler  # noqa: E402
from mavsim_core.statustext import split_statustext  # noqa: E402

from instances import instance  # tests/instances.py: every test's instance numbers

# This file's ten instances: GcsLink binds UDP 14580+I and 18570+I, its clients 14540+I and 14550+I.
LINK = [instance("test_gcs_link", f"link{k}") for k in range(10)]
ORIGIN = (47.397742, 8.545594, 488.0)
CUSTOM_MODE_POSCTL = 3 << 16
BASE_MODE = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_SAFETY_ARMED
DT_US = 4000  # 250 Hz control loop
GCS_SYS, GCS_COMP = 255, 190


# --------------------------------------------------------------------------- fixtures


def make_snapshot(*, with_estimate: bool = True) -> TelemetrySnapshot:
    yaw = math.pi / 2
    q = np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])
    estimate = VehicleEstimate(
        timestamp_us=0,
        q_wxyz=q,
        rate_frd_rad_s=np.array([0.01, -0.02, 0.03]),
        accel_ned_m_s2=np.zeros(3),
        pos_ned_m=np.array([10.0, 20.0, -5.0]),
        vel_ned_m_s=np.array([1.0, 2.0, -0.5]),
        attitude_valid=True,
        position_valid=True,
        origin_lat_deg=ORIGIN[0],
        origin_lon_deg=ORIGIN[1],
        origin_alt_amsl_m=ORIGIN[2],
    )
    gps = GpsSample(
        timestamp_us=0, fix_type=3, lat_deg=47.3978, lon_deg=8.5458, alt_amsl_m=493.0,
        vel_ned_m_s=np.array([1.0, 0.0, 0.0]), eph_m=0.8, epv_m=1.2, satellites=12,
    )  # fmt: skip
    home = HomePosition(lat_deg=ORIGIN[0], lon_deg=ORIGIN[1], alt_amsl_m=ORIGIN[2], pos_ned_m=np.zeros(3), yaw_rad=0.0)
    return TelemetrySnapshot(
        timestamp_us=0,
        mav_type=mavlink.MAV_TYPE_QUADROTOR,
        armed=True,
        base_mode=BASE_MODE,
        custom_mode=CUSTOM_MODE_POSCTL,
        system_status=mavlink.MAV_STATE_ACTIVE,
        landed_state=LandedState.IN_AIR,
        estimate=estimate if with_estimate else None,
        gps=gps if with_estimate else None,
        home=home if with_estimate else None,
        battery=BatteryState(voltage_v=16.0, current_a=5.0, remaining_frac=0.75, cell_count=4),
        throttle_frac=0.42,
        sensors_present=0x2F,
        sensors_enabled=0x2F,
        sensors_health=0x2F,
        prearm_ok=True,
    )


def make_params(extra: int = 0) -> ParameterStore:
    defs = [
        ParamDef("MPC_XY_P", ParamType.REAL32, 0.95, 0.0, 2.0, "", "position P gain"),
        ParamDef("SYS_AUTOSTART", ParamType.INT32, 4001, 0, 9_999_999, "", "airframe"),
        ParamDef("TST_INT", ParamType.INT32, -1, -10_000_000, 10_000_000, "", "test integer"),
    ]
    defs += [ParamDef(f"TST_P{i:03d}", ParamType.REAL32, i * 0.5, 0.0, 1000.0, "", "filler") for i in range(extra)]
    return ParameterStore({d.name: d for d in defs})


class StubVehicle:
    """VehicleInterface for tests: fixed snapshot, records commands, chosen results."""

    def __init__(self, params: ParameterStore | None = None, snapshot: TelemetrySnapshot | None = None) -> None:
        self.params = params if params is not None else make_params()
        self.snap = snapshot if snapshot is not None else make_snapshot()
        self.commands: list[tuple[int, tuple[float, ...], int]] = []
        self.set_modes: list[tuple[int, int]] = []
        self.results: dict[int, int] = {}  # command -> MAV_RESULT; unknown ones UNSUPPORTED
        self.events: list[tuple[int, str]] = []
        self.snapshot_calls = 0

    def snapshot(self) -> TelemetrySnapshot:
        self.snapshot_calls += 1
        return self.snap

    def handle_command(self, command: int, params: tuple[float, ...], frame: int) -> int:
        self.commands.append((command, params, frame))
        return self.results.get(command, mavlink.MAV_RESULT_UNSUPPORTED)

    def handle_set_mode(self, base_mode: int, custom_mode: int) -> int:
        self.set_modes.append((base_mode, custom_mode))
        return mavlink.MAV_RESULT_ACCEPTED

    def pop_events(self) -> list[tuple[int, str]]:
        events, self.events = self.events, []
        return events


class Harness:
    """A GcsLink, its stub vehicle, simulated time and ground-station clients."""

    def __init__(self, instance: int, vehicle: StubVehicle | None = None) -> None:
        self.instance = instance
        self.vehicle = vehicle if vehicle is not None else StubVehicle()
        self.link = GcsLink(self.vehicle, instance=instance)
        self.t_us = 0
        self.updates = 0
        self.clients: dict[str, mavutil.mavfile] = {}

    def client(self, endpoint: str = "gcs") -> mavutil.mavfile:
        if endpoint not in self.clients:
            port = (14550 if endpoint == "gcs" else 14540) + self.instance
            self.clients[endpoint] = mavutil.mavlink_connection(
                f"udpin:127.0.0.1:{port}", source_system=GCS_SYS, source_component=GCS_COMP, dialect="common"
            )
        return self.clients[endpoint]

    def pump(self, sim_s: float, until=None, wall_timeout_s: float = 5.0) -> dict[str, list]:
        """Run update() for ``sim_s`` simulated seconds (or until ``until(msg)``); return received messages."""
        got: dict[str, list] = {name: [] for name in self.clients}
        end_us = self.t_us + int(sim_s * 1e6)
        wall_end = time.monotonic() + wall_timeout_s
        while self.t_us < end_us and time.monotonic() < wall_end:
            self.t_us += DT_US
            self.link.update(self.t_us)
            self.updates += 1
            done = False
            for name, c in self.clients.items():
                while (m := c.recv_match(blocking=False)) is not None:
                    got[name].append(m)
                    done = done or (until is not None and until(m))
            if done:
                break
        return got

    def connect(self, endpoint: str = "gcs") -> mavutil.mavfile:
        """Client that has heard from the link, so it knows where to send."""
        c = self.client(endpoint)
        got = self.pump(2.0, until=lambda m: m.get_type() == "HEARTBEAT")
        assert any(m.get_type() == "HEARTBEAT" for m in got[endpoint])
        return c

    def close(self) -> None:
        for c in self.clients.values():
            c.close()
        self.link.close()


@pytest.fixture
def make_harness():
    made: list[Harness] = []

    def make(instance: int, vehicle: StubVehicle | None = None) -> Harness:
        h = Harness(instance, vehicle)
        made.append(h)
        return h

    yield make
    for h in made:
        h.close()


def of_type(msgs: list, mtype: str) -> list:
    return [m for m in msgs if m.get_type() == mtype]


def acks(msgs: list, command: int) -> list:
    return [m for m in of_type(msgs, "COMMAND_ACK") if m.command == command]


def command_long(client, command: int, *params: float, target_system: int = 1, target_component: int = 1) -> None:
    p = list(params) + [0.0] * (7 - len(params))
    client.mav.command_long_send(target_system, target_component, command, 0, *p)


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


def test_param_value_encoding():
    for v in (0, 1, -1, 4001, -5_000_000, 2**31 - 1, -(2**31)):
        raw = encode_param_bytes(v, mavlink.MAV_PARAM_TYPE_INT32)
        assert raw == struct.pack("<i", v)
        assert decode_param_bytes(raw, mavlink.MAV_PARAM_TYPE_INT32) == v
    raw = encode_param_bytes(0.25, mavlink.MAV_PARAM_TYPE_REAL32)
    assert decode_param_bytes(raw, mavlink.MAV_PARAM_TYPE_REAL32) == 0.25


# --------------------------------------------------------------------------- telemetry


def test_heartbeat_identifies_as_px4(make_harness):
    h = make_harness(LINK[0])
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


def test_streams_rates_in_simulated_time_and_content(make_harness):
    h = make_harness(LINK[1])
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


def test_no_estimate_no_attitude_or_position(make_harness):
    h = make_harness(LINK[2], StubVehicle(snapshot=make_snapshot(with_estimate=False)))
    c = h.connect("gcs")
    got = h.pump(3.0)["gcs"]
    types = {m.get_type() for m in got}
    assert "HEARTBEAT" in types and "SYS_STATUS" in types
    assert not types & {"ATTITUDE", "ATTITUDE_QUATERNION", "GLOBAL_POSITION_INT", "GPS_RAW_INT", "HOME_POSITION"}
    command_long(c, mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_HOME_POSITION)
    got = h.pump(0.5)["gcs"]
    assert [a.result for a in acks(got, mavlink.MAV_CMD_REQUEST_MESSAGE)] == [mavlink.MAV_RESULT_TEMPORARILY_REJECTED]


def test_set_message_interval(make_harness):
    h = make_harness(LINK[3])
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
    command_long(c, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_HIGHRES_IMU, 10_000)  # not sent
    command_long(c, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_ATTITUDE, -5)  # invalid
    got = h.pump(0.02)["gcs"]
    results = [a.result for a in acks(got, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL)]
    assert results == [mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_UNSUPPORTED, mavlink.MAV_RESULT_DENIED]
    got = h.pump(4.0)["gcs"]
    assert abs(len(of_type(got, "GLOBAL_POSITION_INT")) - 20) <= 1
    assert h.vehicle.commands == []  # handled by the link itself


def test_interval_applies_to_its_endpoint_only(make_harness):
    h = make_harness(LINK[4])
    gcs = h.connect("gcs")
    h.connect("api")
    command_long(gcs, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_ATTITUDE, -1)
    h.pump(0.1)
    got = h.pump(2.0)
    assert of_type(got["gcs"], "ATTITUDE") == []
    assert abs(len(of_type(got["api"], "ATTITUDE")) - 40) <= 1


def test_request_message_and_capabilities(make_harness):
    h = make_harness(LINK[5])
    c = h.connect("gcs")
    command_long(c, mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
    got = h.pump(0.1)["gcs"]
    versions = of_type(got, "AUTOPILOT_VERSION")
    assert len(versions) == 1
    v = versions[0]
    for cap in (
        mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2,
        mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE,
        mavlink.MAV_PROTOCOL_CAPABILITY_COMMAND_INT,
        mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_INT,
        mavlink.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED,
        mavlink.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT,
    ):
        assert v.capabilities & cap
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


# --------------------------------------------------------------------------- commands and modes


def test_unknown_command_goes_to_vehicle_and_is_unsupported(make_harness):
    h = make_harness(LINK[6])
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


def test_command_int_global_frame_converted_to_degrees(make_harness):
    h = make_harness(LINK[7])
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


def test_set_mode_message_acked_with_id_11(make_harness):
    h = make_harness(LINK[8])
    c = h.connect("gcs")
    c.mav.set_mode_send(1, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 4 << 16 | 3 << 24)
    c.mav.set_mode_send(7, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 2 << 16)  # not us
    got = h.pump(0.1)["gcs"]
    assert h.vehicle.set_modes == [(mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 4 << 16 | 3 << 24)]
    assert [(a.command, a.result) for a in of_type(got, "COMMAND_ACK")] == [(11, mavlink.MAV_RESULT_ACCEPTED)]


def test_timesync_and_empty_mission(make_harness):
    h = make_harness(LINK[9])
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
    assert [a.type for a in of_type(got, "MISSION_ACK")] == [
        mavlink.MAV_MISSION_ACCEPTED,
        mavlink.MAV_MISSION_UNSUPPORTED,
    ]


# --------------------------------------------------------------------------- parameters


def test_full_parameter_list(make_harness):
    h = make_harness(LINK[0], StubVehicle(params=make_params(extra=400)))
    c = h.connect("gcs")
    store = h.vehicle.params
    start = time.monotonic()
    c.mav.param_request_list_send(1, 1)
    got = h.pump(5.0, until=lambda m: m.get_type() == "PARAM_VALUE" and m.param_index == len(store) - 1)["gcs"]
    elapsed = time.monotonic() - start
    values = of_type(got, "PARAM_VALUE")
    assert sorted(m.param_index for m in values) == list(range(len(store)))  # every index exactly once
    assert {m.param_count for m in values} == {len(store)}
    assert all(m.param_id == store.name_at(m.param_index) for m in values)
    assert elapsed < 1.0, f"parameter list took {elapsed:.2f} s"
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


def test_int32_bytewise_round_trip(make_harness):
    h = make_harness(LINK[1])
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


def test_param_set_refused_echoes_old_value(make_harness):
    h = make_harness(LINK[2])
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
    assert texts == ["unknown parameter NO_SUCH_PARAM", "unknown parameter NO_SUCH_PARAM2"]


def test_param_change_from_elsewhere_is_broadcast(make_harness):
    h = make_harness(LINK[3])
    h.connect("gcs")
    h.connect("api")
    h.vehicle.params.set("MPC_XY_P", 1.25)
    got = h.pump(0.02)
    for name in ("gcs", "api"):
        (pv,) = of_type(got[name], "PARAM_VALUE")
        assert pv.param_value == pytest.approx(1.25)


# --------------------------------------------------------------------------- robustness and endpoints


def test_garbage_does_not_break_the_link(make_harness):
    h = make_harness(LINK[4])
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
            s.sendto(j, ("127.0.0.1", 18570 + h.instance))
        s.sendto(b"junk" + good, ("127.0.0.1", 18570 + h.instance))  # junk then a good packet
    h.pump(0.2)
    assert h.link.rx_errors >= 4
    command_long(c, mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
    got = h.pump(0.1)["gcs"]
    assert [a.result for a in acks(got, mavlink.MAV_CMD_REQUEST_MESSAGE)] == [mavlink.MAV_RESULT_ACCEPTED]


def test_both_endpoints_and_peers_get_telemetry(make_harness):
    h = make_harness(LINK[5])
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
        s.sendto(hb.pack(mav), ("127.0.0.1", 14580 + h.instance))
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


def test_long_statustext_arrives_in_chunks(make_harness):
    h = make_harness(LINK[6])
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


def test_nan_snapshot_and_clock_restart_do_not_break_streams(make_harness):
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
        LINK[7], StubVehicle(snapshot=replace(snap, estimate=estimate, battery=battery, throttle_frac=math.nan))
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


def test_stream_rates_option_is_checked():
    with pytest.raises(ValueError, match="cannot stream"):
        GcsLink(StubVehicle(), instance=LINK[8], stream_rates_hz={mavlink.MAVLINK_MSG_ID_HIGHRES_IMU: 50.0})
