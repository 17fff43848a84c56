"""The extra telemetry, message intervals and identity of GcsLink, against a pymavlink client over loopback UDP.

Every new message (SYSTEM_TIME, ALTITUDE, ODOMETRY, HIGHRES_IMU, GPS_GLOBAL_ORIGIN, FLIGHT_INFORMATION,
PROTOCOL_VERSION, UTM_GLOBAL_POSITION) is requested from a link whose stub vehicle holds a known snapshot
and its fields are checked against that snapshot in MAVLink's units; REQUEST_MESSAGE is answered for
every message the link can send; SET_MESSAGE_INTERVAL / GET_MESSAGE_INTERVAL round trips (default,
set, capped at the link's 50 Hz, off, back to the default) are checked in what arrives, per endpoint;
AUTOPILOT_VERSION carries the checkout's commit and stable non-zero ids; the git reader handles the
forms a checkout takes.  The link runs on simulated time (tests/gcs_link_harness.py).
"""

from __future__ import annotations

import dataclasses
import math
import os
import subprocess
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from autopilot.manual_input import ManualInput  # noqa: E402
from autopilot.mavlink import identity, protocol_version  # noqa: E402
from autopilot.mavlink.endpoint import MIN_STREAM_INTERVAL_US  # noqa: E402
from autopilot.mavlink.telemetry_more import BUILDERS, DEFAULT_STREAM_RATES_HZ  # noqa: E402
from autopilot.telemetry_extras import FlightTimes, TelemetryExtras  # noqa: E402
from autopilot.topics import (  # noqa: E402
    BatteryState,
    BatteryWarning,
    CommanderStatus,
    ControlSetpoints,
    EstimatorStatus,
    ImuSample,
    LandedState,
)
from mavsim_core.geodesy import ned_to_geodetic  # noqa: E402
from mavsim_core.px4_modes import Mode  # noqa: E402

from gcs_link_harness import ORIGIN, StubVehicle, acks, command_long, make_snapshot, of_type

protocol_version.register(mavlink)  # so the client decodes PROTOCOL_VERSION (pymavlink leaves it out)
UTC0_US = 1_700_000_000_000_000  # the snapshot's wall clock at simulated time 0
ARMED_US, TAKEOFF_US, FLIGHT = 10_000_000, 12_500_000, 3
IMU = ImuSample(
    timestamp_us=30_000_000, accel_frd_m_s2=np.array([0.1, -0.2, -9.7]), gyro_frd_rad_s=np.array([0.01, 0.02, -0.03]),
    mag_frd_gauss=np.array([0.21, 0.01, 0.43]), pressure_hpa=955.5, temperature_c=21.5, fields_updated=0x1FFF,
)  # fmt: skip
EKF = EstimatorStatus(
    timestamp_us=0, flags=0x1F, vel_ratio=0.1, pos_horiz_ratio=0.2, pos_vert_ratio=0.3, mag_ratio=0.4,
    pos_horiz_accuracy_m=0.8, pos_vert_accuracy_m=1.2, tilt_std_rad=0.01, yaw_std_rad=0.05, mag_fault=False,
    gps_glitch=False, position_ok=True,
)  # fmt: skip
CONTROL = ControlSetpoints(
    timestamp_us=0, pos_ned_m=np.array([10.0, 20.0, -5.0]), vel_ned_m_s=np.zeros(3), acc_ned_m_s2=np.zeros(3),
    yaw_rad=0.5, q_sp_wxyz=np.array([1.0, 0.0, 0.0, 0.0]), rate_sp_frd_rad_s=np.zeros(3), thrust_frac=0.5,
)  # fmt: skip
SET, GET, REQUEST = (
    mavlink.MAV_CMD_SET_MESSAGE_INTERVAL,
    mavlink.MAV_CMD_GET_MESSAGE_INTERVAL,
    mavlink.MAV_CMD_REQUEST_MESSAGE,
)
ACCEPTED, UNSUPPORTED = mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_UNSUPPORTED


def full_snapshot():
    """The harness's flying snapshot (yaw 90 deg, 10/20/-5 m NED, 1/2/-0.5 m/s, home at the origin) with the
    IMU, clock, flight times, EKF status, setpoints and motors: every builder has something to say."""
    sticks = ManualInput(0, 0.0, pitch=0.5, roll=0.0, throttle=0.5, yaw=0.0)  # (MANUAL_CONTROL's echo)
    extras = TelemetryExtras(IMU, UTC0_US, ARMED_US, TAKEOFF_US, 0, FLIGHT, sticks)
    return dataclasses.replace(
        make_snapshot(), extras=extras, estimator_status=EKF, control=CONTROL, motor_outputs=(0.5,) * 4
    )


def request(h, msg_id: int, endpoint: str = "gcs", *params: float) -> tuple[int, list]:
    """REQUEST_MESSAGE ``msg_id`` (param2.. ``params``): its ACK result and the messages that came with it."""
    command_long(h.clients[endpoint], REQUEST, msg_id, *params)
    got = h.pump(0.1, until=lambda m: m.get_type() == "COMMAND_ACK" and m.command == REQUEST)[endpoint]
    results = [a.result for a in acks(got, REQUEST)]
    assert len(results) == 1, f"one COMMAND_ACK for REQUEST_MESSAGE {msg_id}, got {results}"
    return results[0], got


def requested(h, msg_id: int, mtype: str):
    result, got = request(h, msg_id)
    assert result == ACCEPTED and of_type(got, mtype), f"{mtype}: {result}"
    return of_type(got, mtype)[-1]


def interval(h, msg_id: int, endpoint: str = "gcs") -> tuple[int, int]:
    """GET_MESSAGE_INTERVAL: (ACK result, MESSAGE_INTERVAL.interval_us)."""
    command_long(h.clients[endpoint], GET, msg_id)
    got = h.pump(0.1, until=lambda m: m.get_type() == "COMMAND_ACK" and m.command == GET)[endpoint]
    replies = [m for m in of_type(got, "MESSAGE_INTERVAL") if m.message_id == msg_id]
    assert len(replies) == 1 and len(acks(got, GET)) == 1
    return acks(got, GET)[0].result, replies[0].interval_us


def set_interval(h, msg_id: int, interval_us: float, endpoint: str = "gcs") -> int:
    command_long(h.clients[endpoint], SET, msg_id, interval_us)
    got = h.pump(0.1, until=lambda m: m.get_type() == "COMMAND_ACK" and m.command == SET)[endpoint]
    return acks(got, SET)[0].result


@pytest.fixture
def link(make_harness, inst):
    h = make_harness(inst, StubVehicle(snapshot=full_snapshot()))
    h.connect("gcs")
    return h


# --------------------------------------------------------------------------- the new messages' fields


def test_system_time_altitude_and_origin(link):
    st = requested(link, mavlink.MAVLINK_MSG_ID_SYSTEM_TIME, "SYSTEM_TIME")
    assert st.time_boot_ms > 0 and st.time_unix_usec == UTC0_US + st.time_boot_ms * 1000  # simulated time from UTC0
    alt = requested(link, mavlink.MAVLINK_MSG_ID_ALTITUDE, "ALTITUDE")
    baro_m = (1.0 - (IMU.pressure_hpa / 1013.25) ** (1 / 5.25588)) / 2.25577e-5  # standard atmosphere
    assert alt.altitude_monotonic == pytest.approx(baro_m, abs=0.01)
    assert (alt.altitude_amsl, alt.altitude_local, alt.altitude_relative) == pytest.approx((ORIGIN[2] + 5, 5, 5))
    assert math.isnan(alt.altitude_terrain) and math.isnan(alt.bottom_clearance)
    origin = requested(link, mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN, "GPS_GLOBAL_ORIGIN")
    assert (origin.latitude, origin.longitude, origin.altitude) == (473977420, 85455940, 488000)


def test_odometry(link):
    od = requested(link, mavlink.MAVLINK_MSG_ID_ODOMETRY, "ODOMETRY")
    assert (od.frame_id, od.child_frame_id) == (mavlink.MAV_FRAME_LOCAL_NED, mavlink.MAV_FRAME_BODY_FRD)
    assert (od.x, od.y, od.z) == pytest.approx((10.0, 20.0, -5.0))
    assert list(od.q) == pytest.approx([math.cos(math.pi / 4), 0, 0, math.sin(math.pi / 4)], abs=1e-6)
    # facing east: forward is east (2 m/s), right is south (-1 m/s), down is down
    assert (od.vx, od.vy, od.vz) == pytest.approx((2.0, -1.0, -0.5), abs=1e-5)
    assert (od.rollspeed, od.pitchspeed, od.yawspeed) == pytest.approx((0.01, -0.02, 0.03))
    diagonal = [od.pose_covariance[i] for i in (0, 6, 11, 15, 18, 20)]
    assert diagonal == pytest.approx([0.64, 0.64, 1.44, 1e-4, 1e-4, 0.0025])
    assert math.isnan(od.pose_covariance[1]) and math.isnan(od.velocity_covariance[0])  # unknown
    assert od.estimator_type == mavlink.MAV_ESTIMATOR_TYPE_AUTOPILOT and od.quality == 0


def test_highres_imu(link):
    imu = requested(link, mavlink.MAVLINK_MSG_ID_HIGHRES_IMU, "HIGHRES_IMU")
    assert imu.time_usec == IMU.timestamp_us
    assert (imu.xacc, imu.yacc, imu.zacc) == pytest.approx(tuple(IMU.accel_frd_m_s2))
    assert (imu.xgyro, imu.ygyro, imu.zgyro) == pytest.approx(tuple(IMU.gyro_frd_rad_s))
    assert (imu.xmag, imu.ymag, imu.zmag) == pytest.approx(tuple(IMU.mag_frd_gauss))
    assert (imu.abs_pressure, imu.temperature) == pytest.approx((955.5, 21.5))
    alt = requested(link, mavlink.MAVLINK_MSG_ID_ALTITUDE, "ALTITUDE")
    assert imu.pressure_alt == pytest.approx(alt.altitude_monotonic)
    # the simulator's HIL_SENSOR bits (all 13 set), but no airspeed sensor: no differential pressure
    assert imu.fields_updated == 0x1FFF & ~mavlink.HIGHRES_IMU_UPDATED_DIFF_PRESSURE


def test_flight_information_protocol_version_and_utm(link):
    fi = requested(link, mavlink.MAVLINK_MSG_ID_FLIGHT_INFORMATION, "FLIGHT_INFORMATION")
    assert (fi.arming_time_utc, fi.takeoff_time_utc) == (ARMED_US, TAKEOFF_US)  # since boot, despite the names
    assert fi.flight_uuid == FLIGHT and fi.landing_time == 0 and fi.time_boot_ms > 0  # the flight's number
    pv = requested(link, protocol_version.MAVLINK_MSG_ID_PROTOCOL_VERSION, "PROTOCOL_VERSION")
    assert (pv.version, pv.min_version, pv.max_version) == (200, 100, 200)
    assert list(pv.spec_version_hash) == [0] * 8 and list(pv.library_version_hash) == [0] * 8
    # the older one-message requests PX4 answers too
    c = link.clients["gcs"]
    command_long(c, mavlink.MAV_CMD_REQUEST_PROTOCOL_VERSION, 1)
    command_long(c, mavlink.MAV_CMD_REQUEST_FLIGHT_INFORMATION, 1)
    got = link.pump(0.1)["gcs"]
    assert [a.result for a in acks(got, mavlink.MAV_CMD_REQUEST_PROTOCOL_VERSION)] == [ACCEPTED]
    assert [a.result for a in acks(got, mavlink.MAV_CMD_REQUEST_FLIGHT_INFORMATION)] == [ACCEPTED]
    assert of_type(got, "PROTOCOL_VERSION") and of_type(got, "FLIGHT_INFORMATION")
    utm = requested(link, mavlink.MAVLINK_MSG_ID_UTM_GLOBAL_POSITION, "UTM_GLOBAL_POSITION")
    lat, lon, alt = ned_to_geodetic([10.0, 20.0, -5.0], *ORIGIN)
    assert (utm.lat, utm.lon, utm.alt, utm.relative_alt) == (round(lat * 1e7), round(lon * 1e7), 493000, 5000)
    assert (utm.vx, utm.vy, utm.vz, utm.h_acc, utm.v_acc) == (100, 200, -50, 800, 1200)
    assert utm.time > UTC0_US and utm.flight_state == mavlink.UTM_FLIGHT_STATE_AIRBORNE
    assert utm.update_rate == 0  # unknown: the stream's rate is the client's choice
    assert bytes(utm.uas_id) == identity.instance_uid2(link.instance, 1)
    assert utm.flags == 0x7F  # time, id, position, altitude, relative altitude, both velocities; no next waypoint


def test_request_message_for_every_message_the_link_streams(link):
    streams = link.link._streams.builders
    assert set(BUILDERS) < set(streams) and mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION in streams
    for msg_id in streams:
        result, got = request(link, msg_id)
        assert result == ACCEPTED, msg_id
        assert any(m.get_msgId() == msg_id for m in got), msg_id
    assert request(link, mavlink.MAVLINK_MSG_ID_ADSB_VEHICLE)[0] == UNSUPPORTED
    assert request(link, 9999)[0] == UNSUPPORTED


def test_nothing_to_report_is_temporarily_rejected(make_harness, inst):
    h = make_harness(inst, StubVehicle(snapshot=make_snapshot(with_estimate=False)))
    h.connect("gcs")
    for msg_id in (
        mavlink.MAVLINK_MSG_ID_HIGHRES_IMU,
        mavlink.MAVLINK_MSG_ID_ODOMETRY,
        mavlink.MAVLINK_MSG_ID_ALTITUDE,
    ):
        assert request(h, msg_id)[0] == mavlink.MAV_RESULT_TEMPORARILY_REJECTED
    st = requested(h, mavlink.MAVLINK_MSG_ID_SYSTEM_TIME, "SYSTEM_TIME")
    assert st.time_unix_usec == 0  # no clock: unknown, not a made-up date


# --------------------------------------------------------------------------- message intervals


def count(h, mtype: str, sim_s: float, endpoint: str = "gcs") -> int:
    return len(of_type(h.pump(sim_s)[endpoint], mtype))


@pytest.mark.parametrize(
    "msg_id, mtype",
    [
        (mavlink.MAVLINK_MSG_ID_ODOMETRY, "ODOMETRY"),
        (mavlink.MAVLINK_MSG_ID_HIGHRES_IMU, "HIGHRES_IMU"),
        (mavlink.MAVLINK_MSG_ID_ALTITUDE, "ALTITUDE"),
        (mavlink.MAVLINK_MSG_ID_ATTITUDE, "ATTITUDE"),
    ],
)
def test_set_and_get_message_interval_round_trip(link, msg_id, mtype):
    default_hz = DEFAULT_STREAM_RATES_HZ.get(msg_id)
    default_us = round(1e6 / default_hz) if default_hz else -1
    assert interval(link, msg_id) == (ACCEPTED, default_us)
    assert set_interval(link, msg_id, 100_000) == ACCEPTED  # 10 Hz
    assert interval(link, msg_id) == (ACCEPTED, 100_000)
    link.pump(0.1)
    assert abs(count(link, mtype, 2.0) - 20) <= 1
    assert set_interval(link, msg_id, 1000) == ACCEPTED  # 1 kHz asked: the link's 50 Hz
    assert interval(link, msg_id) == (ACCEPTED, MIN_STREAM_INTERVAL_US)
    link.pump(0.1)
    assert abs(count(link, mtype, 2.0) - 100) <= 2
    assert set_interval(link, msg_id, -1) == ACCEPTED
    assert interval(link, msg_id) == (ACCEPTED, -1)
    link.pump(0.1)
    assert count(link, mtype, 2.0) == 0
    assert set_interval(link, msg_id, 0) == ACCEPTED  # back to the default
    assert interval(link, msg_id) == (ACCEPTED, default_us)
    assert set_interval(link, msg_id, -7) == mavlink.MAV_RESULT_DENIED


def test_heartbeat_interval_is_not_a_clients_to_change(link):
    """SET_MESSAGE_INTERVAL for HEARTBEAT is refused whatever the interval (PX4 refuses it too): every
    ground station on the endpoint relies on its 1 Hz to see the vehicle (issue 18, finding 6)."""
    hb = mavlink.MAVLINK_MSG_ID_HEARTBEAT
    for interval_us in (-1, 0, 100_000, 5_000_000):
        assert set_interval(link, hb, interval_us) == mavlink.MAV_RESULT_DENIED
    assert interval(link, hb) == (ACCEPTED, 1_000_000)
    link.pump(0.1)
    assert abs(count(link, "HEARTBEAT", 3.0) - 3) <= 1


def test_unknown_messages_and_request_message_244(link):
    for msg_id in (mavlink.MAVLINK_MSG_ID_ADSB_VEHICLE, mavlink.MAVLINK_MSG_ID_PARAM_VALUE, 9999):
        assert interval(link, msg_id) == (UNSUPPORTED, 0)  # 0: not available
        assert set_interval(link, msg_id, 100_000) == UNSUPPORTED
    # REQUEST_MESSAGE 244 with param2 the message id: the same answer as GET_MESSAGE_INTERVAL
    result, got = request(link, mavlink.MAVLINK_MSG_ID_MESSAGE_INTERVAL, "gcs", mavlink.MAVLINK_MSG_ID_ATTITUDE)
    assert result == ACCEPTED
    reply = of_type(got, "MESSAGE_INTERVAL")[-1]
    assert (reply.message_id, reply.interval_us) == (mavlink.MAVLINK_MSG_ID_ATTITUDE, 50_000)
    assert request(link, mavlink.MAVLINK_MSG_ID_MESSAGE_INTERVAL, "gcs", math.nan)[0] == mavlink.MAV_RESULT_DENIED


def test_intervals_are_per_endpoint(link):
    link.connect("api")
    assert set_interval(link, mavlink.MAVLINK_MSG_ID_ODOMETRY, 40_000, "api") == ACCEPTED
    assert interval(link, mavlink.MAVLINK_MSG_ID_ODOMETRY, "api") == (ACCEPTED, 40_000)
    assert interval(link, mavlink.MAVLINK_MSG_ID_ODOMETRY, "gcs") == (ACCEPTED, -1)
    link.pump(0.1)
    got = link.pump(2.0)
    assert abs(len(of_type(got["api"], "ODOMETRY")) - 50) <= 1 and of_type(got["gcs"], "ODOMETRY") == []


def test_default_streams_include_the_new_defaults(link):
    got = link.pump(10.0)["gcs"]
    assert abs(len(of_type(got, "ALTITUDE")) - 10) <= 1 and abs(len(of_type(got, "SYSTEM_TIME")) - 10) <= 1
    assert 1 <= len(of_type(got, "GPS_GLOBAL_ORIGIN")) <= 2  # 0.1 Hz
    assert of_type(got, "ODOMETRY") == [] and of_type(got, "HIGHRES_IMU") == []  # off until asked for


# --------------------------------------------------------------------------- identity


def test_autopilot_version_tells_the_truth(link, make_harness, inst):
    v = requested(link, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION, "AUTOPILOT_VERSION")
    root = Path(__file__).resolve().parents[1]
    head = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True, check=True)
    commit = head.stdout.strip()
    packed = int.from_bytes(bytes(v.flight_custom_version), "little")
    assert f"{packed:016x}"[:10] == commit[:10]  # the top 5 bytes: the commit, as PX4 sends it
    assert [(packed >> s) & 0xFF for s in (16, 8, 0)] == list(identity.vendor_version())  # major, minor, patch
    assert v.capabilities & mavlink.MAV_PROTOCOL_CAPABILITY_FTP
    assert v.capabilities & mavlink.MAV_PROTOCOL_CAPABILITY_FLIGHT_TERMINATION  # DO_FLIGHTTERMINATION works
    no = mavlink.MAV_PROTOCOL_CAPABILITY_TERRAIN | mavlink.MAV_PROTOCOL_CAPABILITY_COMPASS_CALIBRATION
    assert not v.capabilities & (no | mavlink.MAV_PROTOCOL_CAPABILITY_COMPONENT_IMPLEMENTS_GIMBAL_MANAGER)
    assert v.uid != 0 and any(v.uid2)
    uid, uid2 = v.uid, bytes(v.uid2)
    link.close()  # a restart of the same instance: the same ids
    again = make_harness(inst, StubVehicle(snapshot=full_snapshot()))
    again.connect("gcs")
    w = requested(again, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION, "AUTOPILOT_VERSION")
    assert (w.uid, bytes(w.uid2)) == (uid, uid2)
    assert identity.instance_uid2(inst, 2) != uid2 and identity.instance_uid(inst + 1, 1) != uid  # another vehicle


def _git(tmp_path: Path, head: str, **files: str) -> Path:
    git = tmp_path / ".git"
    git.mkdir(parents=True)
    (git / "HEAD").write_text(head)
    for name, text in files.items():
        path = git / name.replace("__", "/")
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(text)
    return tmp_path


def test_git_head_in_the_forms_a_checkout_takes(tmp_path):
    sha = "0123456789abcdef0123456789abcdef01234567"
    assert identity.git_head(_git(tmp_path / "branch", "ref: refs/heads/main\n", refs__heads__main=sha + "\n")) == sha
    packed = f"# pack-refs with: peeled\n{sha} refs/heads/dev\n"
    assert identity.git_head(_git(tmp_path / "packed", "ref: refs/heads/dev\n", **{"packed-refs": packed})) == sha
    assert identity.git_head(_git(tmp_path / "detached", sha.upper() + "\n")) == sha
    worktree = tmp_path / "worktree"
    worktree.mkdir()
    gitdir = _git(tmp_path / "main", "ref: refs/heads/main\n", refs__heads__main=sha) / ".git" / "worktrees" / "w"
    gitdir.mkdir(parents=True)
    (gitdir / "HEAD").write_text("ref: refs/heads/main\n")
    (gitdir / "commondir").write_text("../..\n")
    (worktree / ".git").write_text(f"gitdir: {gitdir}\n")
    assert identity.git_head(worktree) == sha
    assert identity.git_head(tmp_path / "nothing") is None  # an installed package: no checkout
    assert identity.git_head(_git(tmp_path / "broken", "ref: refs/heads/gone\n")) is None
    assert identity.custom_version(None) == bytes(8)  # zeros, vendor version included
    assert identity.custom_version(sha, (1, 2, 3)) == bytes([3, 2, 1, 0x89, 0x67, 0x45, 0x23, 0x01])


# --------------------------------------------------------------------------- flight times and NaN


def _status(t_s: float, armed: bool, in_air: bool) -> CommanderStatus:
    return CommanderStatus(
        timestamp_us=round(t_s * 1e6), mav_type=mavlink.MAV_TYPE_QUADROTOR, armed=armed, mode=Mode.POSCTL,
        landed_state=LandedState.IN_AIR if in_air else LandedState.ON_GROUND, in_air=in_air, ground_contact=not in_air,
        home=None, estimate=None, gps=None, gps_ok=True, battery=BatteryState(16.0, 1.0, 0.9),
        battery_warning=BatteryWarning.NONE, prearm_failures=(), position_setpoint_ned_m=None,
    )  # fmt: skip


def test_flight_times_follow_the_commander():
    times = FlightTimes()
    for t_s, armed, in_air in [
        (1, False, False),
        (5, True, False),
        (7, True, True),
        (30, True, False),
        (31, False, False),
    ]:
        times.update(_status(t_s, armed, in_air))
    x = times.extras(IMU, UTC0_US)
    assert (x.armed_us, x.takeoff_us, x.landed_us) == (5_000_000, 7_000_000, 30_000_000)  # the last flight's
    assert x.flight_number == 1
    assert (x.imu, x.utc_at_zero_us) == (IMU, UTC0_US)
    times.update(_status(40, True, False))  # armed again: a new flight
    assert (times.armed_us, times.takeoff_us, times.landed_us, times.flights) == (40_000_000, 0, 0, 2)
    times.update(_status(2, False, False))  # the simulated clock restarted
    assert (times.armed_us, times.takeoff_us, times.landed_us, times.flights) == (0, 0, 0, 0)


def test_builders_never_raise_on_nan():
    nan3 = np.full(3, math.nan)
    snap = full_snapshot()
    estimate = dataclasses.replace(snap.estimate, q_wxyz=np.full(4, math.nan), pos_ned_m=nan3, vel_ned_m_s=nan3)
    imu = dataclasses.replace(IMU, accel_frd_m_s2=nan3, pressure_hpa=math.nan, temperature_c=math.nan)
    ekf = dataclasses.replace(EKF, pos_horiz_accuracy_m=math.nan, tilt_std_rad=math.inf)
    snap = dataclasses.replace(
        snap, estimate=estimate, estimator_status=ekf, extras=dataclasses.replace(snap.extras, imu=imu)
    )
    enc = mavlink.MAVLink(None, 1, 1)
    for msg_id, builder in BUILDERS.items():
        msg = builder(snap, 1_000_000)
        if msg is not None:
            msg.pack(enc)
