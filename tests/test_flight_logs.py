"""Flight logs and plots: the setpoint streams, the .tlog, the control-rate log, ``gcs plot``.

Unit tests write files in pytest's tmp_path; one GcsLink test uses UDP on its own instance;
the end-to-end test (marked ``e2e``) flies the real processes (``Stack``) on another and reads
the logs they leave.  Both instances are this file's in tests/instances.py.  The simulator's
UDP truth is off (``--truth-port 0``): the test reads the truth from the simulator's log.
"""

from __future__ import annotations

import math
import os
import signal
import struct
import subprocess
import sys
import textwrap
import time
from collections import Counter
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from autopilot import flight_log, flight_recorder  # noqa: E402
from autopilot.control.position_control import PositionSetpoint  # noqa: E402
from autopilot.flight_controller import FlightController  # noqa: E402
from autopilot.mavlink.link import GcsLink  # noqa: E402
from autopilot.param_catalogue import default_store
from autopilot.topics import (  # noqa: E402
    BatteryState,
    ControlSetpoints,
    LandedState,
    TelemetrySnapshot,
)
from gcs import plot  # noqa: E402
from gcs.__main__ import main as gcs_main  # noqa: E402
from mavsim_core import tlog  # noqa: E402
from mavsim_core.npy_log import NpyLogWriter, read_npy_log  # noqa: E402
from mavsim_core.quaternion import from_euler  # noqa: E402
from params.vehicle import load_vehicle  # noqa: E402
from sitl.truth_log import truth_log_fields  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
PNG_MAGIC = b"\x89PNG\r\n\x1a\n"

from instances import instance  # tests/instances.py: every test's instance numbers

LINK_INSTANCE = instance("test_flight_logs", "link")  # GcsLink binds UDP 14580+I, 18570+I; the client 14550+I
E2E_INSTANCE = instance("test_flight_logs", "e2e")  # TCP 4560+I; the flight controller binds UDP 14580+I, 18570+I
EPOCH0_US = 1_750_000_000_000_000  # 2025-06-15, a plausible wall-clock anchor


def _mav():
    return mavlink.MAVLink(None, 1, 1)


def _read_tlog(path: Path) -> list:
    conn = mavutil.mavlink_connection(str(path), dialect="common")
    out = []
    try:
        while (m := conn.recv_match()) is not None:
            if m.get_type() != "BAD_DATA":
                out.append(m)
    finally:
        conn.close()
    return out


# --------------------------------------------------------------------------- tlog


def test_tlog_writer_round_trip_through_pymavlink(tmp_path):
    """pymavlink reads back the exact messages, in order, with the exact timestamps."""
    mav = _mav()
    msgs = [
        mavlink.MAVLink_heartbeat_message(2, 12, 129, 4 << 16 | 3 << 24, 4, 3),
        mavlink.MAVLink_attitude_target_message(1234, 0, [0.9, 0.1, -0.2, 0.3], 0.1, -0.2, 0.3, 0.55),
        mavlink.MAVLink_position_target_local_ned_message(
            1240, mavlink.MAV_FRAME_LOCAL_NED, 2048, 1.0, 2.0, -5.0, 0.1, 0.2, -0.3, 0.0, 0.0, 0.0, 1.5, 0.0
        ),
    ]
    stamps = [EPOCH0_US, EPOCH0_US + 4_000, EPOCH0_US + 1_000_007]
    w = tlog.TlogWriter(tmp_path / "a.tlog")
    for t, m in zip(stamps, msgs):
        w.write(t, m.pack(mav))
    w.close()
    raw = (tmp_path / "a.tlog").read_bytes()
    assert struct.unpack(">Q", raw[:8])[0] == stamps[0]  # big-endian µs before each packet
    back = _read_tlog(tmp_path / "a.tlog")
    assert [m.get_type() for m in back] == ["HEARTBEAT", "ATTITUDE_TARGET", "POSITION_TARGET_LOCAL_NED"]
    for m, orig, t in zip(back, msgs, stamps):
        assert m.get_msgbuf() == orig.get_msgbuf()
        assert m._timestamp == pytest.approx(t / 1e6, abs=1e-6)
    assert back[1].q == pytest.approx([0.9, 0.1, -0.2, 0.3]) and back[1].thrust == pytest.approx(0.55)
    assert back[2].z == -5.0 and back[2].type_mask == 2048


def test_sim_epoch_clock_keeps_simulated_intervals():
    clock = tlog.SimEpochClock(sim_us=3_000_000, epoch_us=EPOCH0_US)
    assert clock(3_000_000) == EPOCH0_US
    assert clock(13_000_000) - clock(3_000_000) == 10_000_000  # ten simulated seconds, whatever the speed
    assert clock(2_000_000) == EPOCH0_US - 1_000_000


def _flight_controller() -> FlightController:
    return FlightController(load_vehicle("quad_x"), default_store())


def _fly(fc: FlightController, t_us: int) -> None:
    """Pretend the cascade is flying at t_us (setpoints in place, armed)."""
    fc.last_us = t_us
    fc.commander.status = replace(fc.commander.status, armed=True)
    fc.setpoint = PositionSetpoint(np.array([1.0, 2.0, -5.0]), np.zeros(3), 0.5)
    fc.position_control.vel_sp = np.array([0.1, 0.2, -0.3])
    fc.position_control.acc_sp = np.array([0.0, 0.1, -0.2])
    fc.q_sp = from_euler(0.05, -0.02, 0.5)
    fc.rate_sp = np.array([0.3, -0.1, 0.05])
    fc.thrust_vec = np.array([0.0, 0.0, -13.7])
    fc.actuators = replace(fc.actuators, motor_outputs=(0.5, 0.55, 0.6, 0.65))


def test_recorder_one_tlog_per_arming_with_prearm_traffic_and_no_duplicates(tmp_path):
    fc = _flight_controller()
    rec = flight_recorder.FlightRecorder(
        tmp_path, fc, instance=3, say=lambda text: None, epoch_s=lambda: EPOCH0_US / 1e6
    )
    mav_gcs, mav_api = _mav(), _mav()
    hb = mavlink.MAVLink_heartbeat_message(2, 12, 0, 0, 3, 3)
    arm = mavlink.MAVLink_command_long_message(1, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0)
    other = mavlink.MAVLink(None, 255, 190)

    fc.last_us = 1_000_000
    rec.on_step()  # disarmed: nothing written yet
    rec.tap(1_000_000, "gcs", True, hb.pack(mav_gcs))
    rec.tap(1_000_000, "api", True, hb.pack(mav_api))  # the same heartbeat on the API endpoint: skipped
    rec.tap(1_500_000, "api", False, arm.pack(other))  # received: kept
    assert not list(tmp_path.iterdir())

    _fly(fc, 2_000_000)
    rec.on_step()  # armed: the flight's files open with the buffered traffic
    stems = rec.flights
    assert len(stems) == 1 and stems[0].endswith("_i3")
    ack = mavlink.MAVLink_command_ack_message(400, 0, 0, 0, 255, 190)
    rec.tap(2_000_000, "api", True, ack.pack(mav_api))  # only on the API endpoint: kept
    att = mavlink.MAVLink_attitude_message(2500, 0.1, 0.2, 0.3, 0, 0, 0)
    rec.tap(2_500_000, "gcs", True, att.pack(mav_gcs))
    rec.tap(2_500_000, "api", True, att.pack(mav_api))  # duplicate: skipped
    for k in range(1, 400):
        fc.last_us = 2_000_000 + 4000 * k
        if k == 100:
            # disarm at 2.4 s; the files close 1 s later
            fc.commander.status = replace(fc.commander.status, armed=False)
        rec.on_step()
    assert not rec.active
    fc.commander.status = replace(fc.commander.status, armed=True)
    fc.last_us = 4_000_000
    rec.on_step()  # a second arming: a second pair of files
    rec.close()
    assert len(rec.flights) == 2 and rec.flights[0] != rec.flights[1]

    path = tmp_path / (stems[0] + ".tlog")
    msgs = _read_tlog(path)
    assert [m.get_type() for m in msgs] == ["HEARTBEAT", "COMMAND_LONG", "COMMAND_ACK", "ATTITUDE"]
    assert [round(m._timestamp * 1e6) for m in msgs] == [
        EPOCH0_US - 1_000_000,
        EPOCH0_US - 500_000,
        EPOCH0_US,
        EPOCH0_US + 500_000,
    ]
    log = np.load(tmp_path / (stems[0] + ".fc.npy"))
    assert log["time_us"][0] == 2_000_000
    assert log["armed"][0] == 1 and log["armed"][-1] == 0
    assert log["time_us"][-1] == 3_400_000  # 1 s after the disarm


def test_control_log_round_trip(tmp_path):
    fc = _flight_controller()
    w = flight_log.FlightLogWriter(tmp_path / "x.fc.npy", fc, chunk_rows=7)
    fc.last_us = 0
    w.record()  # disarmed, no estimate yet: NaN setpoints and positions
    _fly(fc, 4000)
    w.record()
    w.close()
    log = np.load(tmp_path / "x.fc.npy")
    assert log.dtype.names == tuple(name for name, _ in flight_log.flight_log_fields(4))
    assert len(log) == 2
    idle, fly = log
    assert idle["armed"] == 0 and math.isnan(idle["pos_sp_d_m"]) and math.isnan(idle["q_sp_w"])
    assert fly["time_us"] == 4000 and fly["armed"] == 1
    assert (fly["main_mode"], fly["sub_mode"]) == fc.commander.mode.value
    assert [fly["pos_sp_n_m"], fly["pos_sp_e_m"], fly["pos_sp_d_m"]] == [1.0, 2.0, -5.0]
    assert fly["vel_sp_d_m_s"] == pytest.approx(-0.3) and fly["acc_sp_e_m_s2"] == pytest.approx(0.1)
    assert fly["yaw_sp_rad"] == pytest.approx(0.5)
    assert [fly[f"q_sp_{c}"] for c in "wxyz"] == pytest.approx(list(fc.q_sp), abs=1e-6)
    assert [fly[f"rate_sp_{c}_rad_s"] for c in "pqr"] == pytest.approx([0.3, -0.1, 0.05], abs=1e-6)
    max_thrust = 4 * fc.spec.max_thrust_per_rotor_n
    assert fly["thrust_sp"] == pytest.approx(13.7 / max_thrust, rel=1e-5)
    assert [fly[f"motor_{i}"] for i in range(4)] == pytest.approx([0.5, 0.55, 0.6, 0.65])
    assert fly["q_w"] == pytest.approx(1.0)  # the estimator has not moved


def test_npy_log_survives_an_abrupt_kill(tmp_path):
    """SIGKILL after 35 rows with 10-row chunks: the 30 rows of complete chunks are a valid .npy."""
    path = tmp_path / "killed.npy"
    code = textwrap.dedent(f"""
        import os, signal, sys
        sys.path.insert(0, {str(ROOT)!r})
        from mavsim_core.npy_log import NpyLogWriter
        w = NpyLogWriter({str(path)!r}, [("time_us", "q"), ("x", "f")], chunk_rows=10)
        for i in range(35):
            w.append(i * 4000, i * 0.5)
        os.kill(os.getpid(), signal.SIGKILL)
    """)
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True)
    assert proc.returncode == -signal.SIGKILL
    log = np.load(path)
    assert len(log) == 30
    assert list(log["time_us"]) == [i * 4000 for i in range(30)] and log["x"][-1] == pytest.approx(14.5)


def test_npy_log_header_counts_only_complete_rows(tmp_path):
    """Rows written after the last header update (a kill between the two) are ignored, never misread."""
    path = tmp_path / "torn.npy"
    w = NpyLogWriter(path, [("time_us", "q"), ("x", "f")], chunk_rows=4)
    for i in range(8):
        w.append(i, float(i))
    w._f.write(struct.pack("<qf", 8, 8.0) + b"\x01\x02")  # a chunk's data, and a torn row, before the header
    w._f.flush()
    assert len(np.load(path)) == 8 and len(read_npy_log(path)) == 8
    w.close()  # the next header update counts the complete row, not the torn bytes
    assert list(read_npy_log(path)["time_us"]) == list(range(9))


# --------------------------------------------------------------------------- ground-station streams


def _snapshot(control: ControlSetpoints | None) -> TelemetrySnapshot:
    return TelemetrySnapshot(
        timestamp_us=0, mav_type=mavlink.MAV_TYPE_QUADROTOR, armed=True,
        base_mode=mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_SAFETY_ARMED,
        custom_mode=4 << 16 | 3 << 24, system_status=mavlink.MAV_STATE_ACTIVE, landed_state=LandedState.IN_AIR,
        estimate=None, gps=None, home=None, battery=BatteryState(16.0, 5.0, 0.8), throttle_frac=0.5,
        sensors_present=0, sensors_enabled=0, sensors_health=0, prearm_ok=True,
        motor_outputs=(0.5, 0.6, 0.0, 1.0), control=control,
    )  # fmt: skip


class _Vehicle:
    def __init__(self, snap: TelemetrySnapshot) -> None:
        self.params = default_store()
        self.snap = snap

    def snapshot(self) -> TelemetrySnapshot:
        return self.snap

    def handle_command(self, command, params, frame) -> int:
        return mavlink.MAV_RESULT_UNSUPPORTED

    def handle_set_mode(self, base_mode, custom_mode) -> int:
        return mavlink.MAV_RESULT_DENIED

    def pop_events(self) -> list:
        return []


def test_link_streams_attitude_and_position_targets():
    """ATTITUDE_TARGET, POSITION_TARGET_LOCAL_NED and SERVO_OUTPUT_RAW: fields, default rates, SET_MESSAGE_INTERVAL."""
    instance = LINK_INSTANCE
    q_sp = from_euler(0.1, -0.05, 1.0)
    control = ControlSetpoints(
        timestamp_us=0,
        pos_ned_m=np.array([1.0, 2.0, math.nan]),
        vel_ned_m_s=np.array([0.1, 0.2, -0.5]),
        acc_ned_m_s2=np.array([0.0, 0.3, -0.1]),
        yaw_rad=1.0,
        q_sp_wxyz=q_sp,
        rate_sp_frd_rad_s=np.array([0.2, -0.1, 0.05]),
        thrust_frac=0.57,
    )
    vehicle = _Vehicle(_snapshot(control))
    link = GcsLink(vehicle, instance=instance)
    client = mavutil.mavlink_connection(
        f"udpin:127.0.0.1:{14550 + instance}", source_system=255, source_component=190, dialect="common"
    )
    got: list = []
    t = [0]

    def run(seconds: float) -> list:
        out = []
        for _ in range(int(seconds * 50)):
            t[0] += 20_000
            link.update(t[0])
            time.sleep(0.0005)
            while (m := client.recv_match(blocking=False)) is not None:
                out.append(m)
        time.sleep(0.05)
        while (m := client.recv_match(blocking=False)) is not None:
            out.append(m)
        return out

    try:
        got = run(2.0)
        counts = Counter(m.get_type() for m in got)
        assert 35 <= counts["ATTITUDE_TARGET"] <= 41  # 20 Hz of simulated time
        assert 18 <= counts["POSITION_TARGET_LOCAL_NED"] <= 21  # 10 Hz
        assert 8 <= counts["SERVO_OUTPUT_RAW"] <= 11  # 5 Hz
        at = next(m for m in got if m.get_type() == "ATTITUDE_TARGET")
        assert at.type_mask == 0 and at.q == pytest.approx(list(q_sp), abs=1e-6)
        assert (at.body_roll_rate, at.body_pitch_rate, at.body_yaw_rate) == pytest.approx((0.2, -0.1, 0.05))
        assert at.thrust == pytest.approx(0.57)
        pt = next(m for m in got if m.get_type() == "POSITION_TARGET_LOCAL_NED")
        assert pt.coordinate_frame == mavlink.MAV_FRAME_LOCAL_NED
        assert pt.type_mask == (
            mavlink.POSITION_TARGET_TYPEMASK_Z_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE
        )
        assert (pt.x, pt.y) == (1.0, 2.0) and math.isnan(pt.z)
        assert (pt.vx, pt.vy, pt.vz) == pytest.approx((0.1, 0.2, -0.5))
        assert (pt.afx, pt.afy, pt.afz) == pytest.approx((0.0, 0.3, -0.1)) and pt.yaw == pytest.approx(1.0)
        so = next(m for m in got if m.get_type() == "SERVO_OUTPUT_RAW")
        servos = (so.servo1_raw, so.servo2_raw, so.servo3_raw, so.servo4_raw, so.servo5_raw)
        assert servos == (1500, 1600, 1000, 2000, 0)

        # SET_MESSAGE_INTERVAL works for them as for every stream: 50 Hz, then off.
        client.mav.command_long_send(
            1,
            1,
            mavlink.MAV_CMD_SET_MESSAGE_INTERVAL,
            0,
            mavlink.MAVLINK_MSG_ID_POSITION_TARGET_LOCAL_NED,
            20_000,
            0,
            0,
            0,
            0,
            0,
        )
        client.mav.command_long_send(
            1, 1, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0, mavlink.MAVLINK_MSG_ID_ATTITUDE_TARGET, -1, 0, 0, 0, 0, 0
        )
        time.sleep(0.05)
        got = run(0.1)
        acks = [m for m in got if m.get_type() == "COMMAND_ACK"]
        assert [a.result for a in acks] == [mavlink.MAV_RESULT_ACCEPTED] * 2
        got = run(2.0)
        counts = Counter(m.get_type() for m in got)
        assert counts["ATTITUDE_TARGET"] == 0 and 95 <= counts["POSITION_TARGET_LOCAL_NED"] <= 101

        vehicle.snap = _snapshot(None)  # controllers idle (disarmed): no targets at all
        counts = Counter(m.get_type() for m in run(1.0))
        assert counts["POSITION_TARGET_LOCAL_NED"] == 0 and counts["HEARTBEAT"] >= 1
    finally:
        client.close()
        link.close()


# --------------------------------------------------------------------------- plots


def _synthetic_flight(tmp_path: Path, stem: str = "2026-01-02_03-04-05") -> tuple[Path, Path]:
    """A 20 s control log (take-off to 3 m and a roll wobble) and its truth log."""
    t_us = np.arange(0, 20_000_000, 4000)
    alt = np.clip((t_us / 1e6 - 2.0) * 1.0, 0.0, 3.0)
    roll = 0.05 * np.sin(t_us / 1e6 * 3.0)
    fc_path, truth_path = tmp_path / (stem + ".fc.npy"), tmp_path / (stem + ".truth.npy")
    w = NpyLogWriter(fc_path, flight_log.flight_log_fields(4), chunk_rows=500)
    for k, t in enumerate(t_us):
        q = from_euler(float(roll[k]), 0.0, 0.2)
        q_sp = from_euler(float(roll[k]) * 1.2, 0.0, 0.2)
        sp = (
            [1.0, 0.0, -3.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.2, *q_sp, 0.0, 0.0, 0.0, 0.5]
            if t > 2e6
            else [math.nan] * 18
        )
        w.append(
            int(t),
            1,
            4,
            2 if t < 8e6 else 3,
            *sp,
            0.5,
            0.9,
            0.0,
            -alt[k],
            0.0,
            0.0,
            0.0,
            *q,
            0.0,
            0.0,
            0.0,
            0.5,
            0.52,
            0.48,
            0.5,
        )
    w.close()
    w = NpyLogWriter(truth_path, truth_log_fields(4), chunk_rows=500)
    for k, t in enumerate(t_us):
        w.append(
            int(t),
            1,
            1.0,
            0.02,
            -alt[k] - 0.2,
            0.0,
            0.0,
            0.0,
            float(roll[k]) + 0.01,
            0.0,
            0.2,
            0.0,
            0.0,
            0.0,
            0.5,
            0.5,
            0.5,
            0.5,
        )
    w.close()
    return fc_path, truth_path


def _check_pngs(out: Path) -> None:
    for name in plot.FIGURES:
        png = out / f"{name}.png"
        assert png.exists(), png
        data = png.read_bytes()
        assert data.startswith(PNG_MAGIC) and len(data) > 10_000, png


def test_gcs_plot_control_log_finds_truth_and_writes_pngs(tmp_path, capsys):
    fc_path, _ = _synthetic_flight(tmp_path)
    assert gcs_main(["plot", str(tmp_path), "--out", str(tmp_path / "png")]) == 0  # a directory: newest log
    out = capsys.readouterr().out
    assert "ground truth from 2026-01-02_03-04-05.truth.npy" in out
    _check_pngs(tmp_path / "png")
    data = plot.load(fc_path)
    assert data.truth is not None and data.truth.cols["alt_m"][0] == 0.0  # truth altitude from its start
    assert np.nanmax(data.setpoint.cols["alt_m"]) == pytest.approx(3.0)
    assert [name for _, name in data.modes] == ["TAKEOFF", "LOITER"]
    assert gcs_main(["plot", str(fc_path), "--no-truth"]) == 0  # default --out: beside the log
    _check_pngs(tmp_path / "2026-01-02_03-04-05_plots")


def test_gcs_plot_tlog(tmp_path):
    """From a tlog: ATTITUDE vs ATTITUDE_TARGET, LOCAL_POSITION_NED vs POSITION_TARGET_LOCAL_NED, SERVO_OUTPUT_RAW."""
    mav = _mav()
    w = tlog.TlogWriter(tmp_path / "2026-01-02_03-04-05.tlog")
    for k in range(200):  # 10 s at 20 Hz, every message twice (two endpoints)
        ms = k * 50
        q = list(from_euler(0.1, 0.0, 0.0))
        msgs = [
            mavlink.MAVLink_attitude_message(ms, 0.09, 0.01, 0.0, 0, 0, 0),
            mavlink.MAVLink_attitude_target_message(ms, 0, q, 0, 0, 0, 0.5),
            mavlink.MAVLink_local_position_ned_message(ms + 10, 0.0, 0.0, -min(ms / 1000.0, 3.0), 0, 0, 0),
            mavlink.MAVLink_position_target_local_ned_message(ms + 10, 1, 0, 0.0, 0.0, -3.0, 0, 0, 0, 0, 0, 0, 0, 0),
            mavlink.MAVLink_servo_output_raw_message(ms * 1000, 0, 1500, 1500, 1500, 1500, 0, 0, 0, 0),
        ]
        if k % 20 == 0:
            msgs.append(mavlink.MAVLink_heartbeat_message(2, 12, 129, 4 << 16 | 3 << 24, 4, 3))
        for m in msgs * 2:
            w.write(EPOCH0_US + ms * 1000, m.pack(mav))
    w.close()
    out = tmp_path / "png"
    assert gcs_main(["plot", str(tmp_path / "2026-01-02_03-04-05.tlog"), "--out", str(out)]) == 0
    _check_pngs(out)
    data = plot.load(tmp_path / "2026-01-02_03-04-05.tlog")
    assert data.truth is None and data.motors is not None and len(data.motors.cols) == 4
    assert np.nanmax(data.setpoint.cols["roll_deg"]) == pytest.approx(math.degrees(0.1), abs=1e-3)
    assert np.isfinite(data.estimate.cols["alt_m"]).sum() == 200  # duplicates dropped
    assert data.motors.cols["motor_0"][0] == pytest.approx(0.5)


def test_gcs_plot_reports_a_bad_log(tmp_path, capsys):
    assert gcs_main(["plot", str(tmp_path / "missing.fc.npy")]) == 1
    assert "no such file" in capsys.readouterr().err
    assert gcs_main(["plot", str(tmp_path)]) == 1  # an empty directory
    assert "no *.fc.npy or *.tlog" in capsys.readouterr().err


# --------------------------------------------------------------------------- end to end


@pytest.mark.e2e
def test_e2e_flight_leaves_tlog_control_log_truth_and_plots(tmp_path):
    """Real sitl + autopilot (max speed): take off to 3 m, hover 3 s, land; read the logs; plot them."""
    from gcs.client import VehicleClient
    from gcs.launcher import Stack

    wait_s, alt_m = 90.0, 3.0
    logs = tmp_path / "logs"
    with Stack(instance=E2E_INSTANCE, speed="max", log_dir=logs, extra_sitl_args=["--truth-port", "0"]) as stack:
        with VehicleClient(stack.api_url, timeout_s=wait_s, idle=stack.check_alive) as c:
            c.wait_until(c.prearm_ok, wait_s, "ready to arm")
            home = c.wait_home(wait_s)
            c.arm().check()
            c.wait_armed(True, wait_s)
            c.takeoff(home.alt_amsl_m + alt_m).check()
            c.wait_until(lambda: c.takeoff_done(alt_m), wait_s, f"takeoff to {alt_m} m")
            c.wait_sim_time(3.0, wait_s, "3 s of hover")
            c.land().check()
            c.wait_until(c.landed_and_disarmed, wait_s, "landed and disarmed")
        codes = stack.stop()
    assert codes == {"autopilot": 143, "sitl": 143}  # SIGTERM: both closed their logs and exited

    tlogs, fcs, truths = (sorted(logs.glob("*" + sfx)) for sfx in (".tlog", ".fc.npy", ".truth.npy"))
    assert len(tlogs) == len(fcs) == len(truths) == 1, sorted(p.name for p in logs.iterdir())
    assert tlogs[0].name.endswith(f"_i{E2E_INSTANCE}.tlog") and fcs[0].name == tlogs[0].name.replace(".tlog", ".fc.npy")

    msgs = _read_tlog(tlogs[0])
    types = Counter(m.get_type() for m in msgs)
    for needed in (
        "HEARTBEAT",
        "ATTITUDE",
        "ATTITUDE_TARGET",
        "POSITION_TARGET_LOCAL_NED",
        "COMMAND_LONG",
        "COMMAND_ACK",
        "SERVO_OUTPUT_RAW",
    ):
        assert types[needed] > 0, types
    stamps = [m._timestamp for m in msgs]
    assert all(b >= a for a, b in zip(stamps, stamps[1:]))
    assert abs(stamps[0] - time.time()) < 24 * 3600  # wall-clock epoch seconds
    hover_z = [m.z for m in msgs if m.get_type() == "POSITION_TARGET_LOCAL_NED" and math.isfinite(m.z)]
    assert -min(hover_z) == pytest.approx(alt_m, abs=0.3)  # the commanded altitude (home ~ origin)
    targets = [m for m in msgs if m.get_type() == "ATTITUDE_TARGET"]
    assert all(abs(np.linalg.norm(m.q) - 1.0) < 1e-3 for m in targets)
    thrust = np.median([m.thrust for m in targets])
    assert 0.4 < thrust < 0.75  # hover: 57 % of full thrust for quad_x
    assert max(abs(m.roll) for m in msgs if m.get_type() == "ATTITUDE") < math.radians(15)

    log = np.load(fcs[0])
    assert log["armed"][0] == 1 and log["armed"][-1] == 0
    steps = np.diff(log["time_us"])
    assert (steps == 4000).all()  # every 250 Hz step, none lost
    assert -np.nanmin(log["pos_sp_d_m"]) == pytest.approx(alt_m, abs=0.3)
    assert -np.nanmin(log["pos_d_m"]) == pytest.approx(alt_m, abs=0.5)
    truth = np.load(truths[0])
    climb = -(truth["pos_d_m"] - truth["pos_d_m"][0])
    assert climb.max() == pytest.approx(alt_m, abs=0.5)
    assert abs(len(truth) - len(log)) < 50  # the same flight, both at 250 Hz

    out = tmp_path / "png"
    proc = subprocess.run(
        [sys.executable, "-m", "gcs", "plot", str(tlogs[0]), "--out", str(out)],
        capture_output=True,
        text=True,
        cwd=ROOT,
    )
    assert proc.returncode == 0, proc.stderr
    assert "ground truth from" in proc.stdout
    _check_pngs(out)
