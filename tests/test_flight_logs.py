"""Flight logs: the .tlog writer, the flight recorder, what the ULog holds of the control loops, the .npy format.

Unit tests writing files in pytest's tmp_path; no process, no socket.  The setpoint streams
the logs record are tested in tests/test_setpoint_streams.py, ``gcs plot`` and a real flight's
logs in tests/test_flight_log_plots.py.
"""

from __future__ import annotations

import math
import os
import signal
import struct
import subprocess
import sys
import textwrap
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402
from pyulog import ULog  # noqa: E402

from autopilot import flight_recorder, ulog_topics  # noqa: E402
from autopilot.control.position_control import PositionSetpoint  # noqa: E402
from autopilot.flight_controller import FlightController  # noqa: E402
from autopilot.param_catalogue import default_store
from autopilot.topics import AttitudeSetpoint  # noqa: E402
from mavsim_core import tlog  # noqa: E402
from mavsim_core.npy_log import NpyLogWriter, read_npy_log  # noqa: E402
from mavsim_core.quaternion import from_euler  # noqa: E402
from params.vehicle import load_vehicle  # noqa: E402

from flight_log_helpers import EPOCH0_US, make_mav, read_tlog  # tests/flight_log_helpers.py

ROOT = Path(__file__).resolve().parent.parent


# --------------------------------------------------------------------------- tlog


def test_tlog_writer_round_trip_through_pymavlink(tmp_path):
    """pymavlink reads back the exact messages, in order, with the exact timestamps."""
    mav = make_mav()
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
    back = read_tlog(tmp_path / "a.tlog")
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
    mav_gcs, mav_api = make_mav(), make_mav()
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
    msgs = read_tlog(path)
    assert [m.get_type() for m in msgs] == ["HEARTBEAT", "COMMAND_LONG", "COMMAND_ACK", "ATTITUDE"]
    assert [round(m._timestamp * 1e6) for m in msgs] == [
        EPOCH0_US - 1_000_000,
        EPOCH0_US - 500_000,
        EPOCH0_US,
        EPOCH0_US + 500_000,
    ]
    status = _topics(tmp_path / (stems[0] + ".ulg"))["vehicle_status"]
    assert status["timestamp"][0] == 2_000_000
    assert status["arming_state"][0] == ulog_topics.ARMING_STATE_ARMED
    assert status["arming_state"][-1] == ulog_topics.ARMING_STATE_DISARMED
    assert status["timestamp"][-1] == 3_400_000  # 1 s after the disarm


def _topics(path: Path) -> dict[str, dict[str, np.ndarray]]:
    """Every topic of a ULog (instance 0) as pyulog reads it: {topic: {field: array}}."""
    return {d.name: d.data for d in ULog(str(path)).data_list if d.multi_id == 0}


def _ulog(path: Path, fc: FlightController) -> ulog_topics.FlightULog:
    return ulog_topics.FlightULog(path, fc, 0, EPOCH0_US, sysid=1)


def test_the_ulog_holds_what_the_control_loops_did(tmp_path):
    """Everything the control-rate log held (modes, the position, velocity, acceleration, yaw, attitude and rate
    setpoints, the thrust asked and delivered, the motors, the estimate) is in the ULog's topics."""
    fc = _flight_controller()
    w = _ulog(tmp_path / "x.ulg", fc)
    fc.last_us = 0
    w.record()  # disarmed, no estimate yet: no setpoint topics
    _fly(fc, 20_000)
    fc.actuators = replace(fc.actuators, throttle_frac=0.4)
    w.record()
    w.close()
    t = _topics(tmp_path / "x.ulg")
    mode = t["flight_mode"]
    assert (mode["main_mode"][-1], mode["sub_mode"][-1]) == fc.commander.mode.value
    assert list(t["vehicle_status"]["arming_state"]) == [1, 2]
    lps, traj = t["vehicle_local_position_setpoint"], t["trajectory_setpoint"]
    assert list(lps["timestamp"]) == [20_000]  # setpoints only while the cascade flies
    assert [lps["x"][0], lps["y"][0], lps["z"][0]] == [1.0, 2.0, -5.0]
    assert [traj[f"position[{i}]"][0] for i in range(3)] == [1.0, 2.0, -5.0]
    assert lps["vz"][0] == pytest.approx(-0.3) and lps["acceleration[1]"][0] == pytest.approx(0.1)
    assert lps["yaw"][0] == pytest.approx(0.5)
    att_sp, rates_sp = t["vehicle_attitude_setpoint"], t["vehicle_rates_setpoint"]
    assert [att_sp[f"q_d[{i}]"][0] for i in range(4)] == pytest.approx(list(fc.q_sp), abs=1e-6)
    assert [rates_sp[c][0] for c in ("roll", "pitch", "yaw")] == pytest.approx([0.3, -0.1, 0.05], abs=1e-6)
    thrust_sp = 13.7 / (4 * fc.spec.max_thrust_per_rotor_n)
    assert -rates_sp["thrust_body[2]"][0] == pytest.approx(thrust_sp, rel=1e-5)
    alloc = t["control_allocator_status"]  # the thrust delivered: the setpoint minus what was not allocated
    assert alloc["unallocated_thrust[2]"][0] == pytest.approx(0.4 - thrust_sp, rel=1e-5)
    assert not alloc["thrust_setpoint_achieved"][0]
    motors = t["actuator_motors"]
    assert [motors[f"control[{i}]"][-1] for i in range(4)] == pytest.approx([0.5, 0.55, 0.6, 0.65])
    assert np.isnan(motors["control[4]"][-1])  # a quad: four motors
    assert t["vehicle_attitude"]["q[0]"][-1] == pytest.approx(1.0)  # the estimator has not moved


def test_the_ulog_goes_on_while_an_attitude_is_flown(tmp_path):
    """Offboard attitude or body rates (an AttitudeSetpoint, no position): NaN position-loop setpoints, the
    attitude and rate setpoints logged, and the log goes on (the control-rate log once stopped on the first such
    row, losing the rest of the flight: "flight logging stopped: AttributeError")."""
    fc = _flight_controller()
    w = _ulog(tmp_path / "x.ulg", fc)
    _fly(fc, 0)
    fc.setpoint = AttitudeSetpoint(from_euler(0.1, 0.0, 0.0), None, 0.6)
    w.record()
    _fly(fc, 20_000)
    w.record()
    w.close()
    t = _topics(tmp_path / "x.ulg")
    lps = t["vehicle_local_position_setpoint"]
    assert list(lps["timestamp"]) == [0, 20_000]
    assert all(math.isnan(lps[f][0]) for f in ("x", "vy", "acceleration[2]", "yaw"))
    q_d = [t["vehicle_attitude_setpoint"][f"q_d[{i}]"][0] for i in range(4)]
    assert q_d == pytest.approx(list(fc.q_sp), abs=1e-6)
    assert lps["z"][1] == -5.0 and list(t["trajectory_setpoint"]["timestamp"]) == [20_000]


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


def test_npy_log_chunk_is_written_once_when_an_exit_interrupts_its_write(tmp_path):
    """The flight controller's SIGTERM handler raises SystemExit wherever the loop is; raised just after a
    chunk's write, the close() that follows wrote the chunk again (a fresh-clone run's control log went 1 s
    back in time at its end: 250 rows twice)."""
    path = tmp_path / "interrupted.npy"
    w = NpyLogWriter(path, [("time_us", "q"), ("x", "f")], chunk_rows=5)
    real = w._f

    class ExitAfterWrite:  # the file, with a SIGTERM arriving right after its first write
        def __init__(self) -> None:
            self.hit = False

        def write(self, data):
            n = real.write(data)
            if not self.hit:
                self.hit = True
                raise SystemExit(143)
            return n

        def __getattr__(self, name):
            return getattr(real, name)

    w._f = ExitAfterWrite()
    with pytest.raises(SystemExit):
        for i in range(5):
            w.append(i * 4000, float(i))
    w.close()
    assert list(read_npy_log(path)["time_us"]) == [i * 4000 for i in range(5)]


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
