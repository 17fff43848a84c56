"""The flight recorder's ULog (autopilot/ulog_topics.py): PX4's topics at their rates, read back with pyulog.

A flight controller pretends to fly (as in tests/test_flight_logs.py) while the recorder is fed
steps, link traffic and parameter changes; no process, no socket.  A real flight's ULog, fetched
over MAVLink, is checked in tests/test_e2e_logs.py.
"""

from __future__ import annotations

import os
from dataclasses import replace
from types import SimpleNamespace

import numpy as np
import pytest

pyulog = pytest.importorskip("pyulog", reason="pyulog is a dependency: pip install .")

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from autopilot import flight_recorder  # noqa: E402
from autopilot.control.position_control import PositionSetpoint  # noqa: E402
from autopilot.flight_controller import FlightController  # noqa: E402
from autopilot.mavlink.identity import running_commit  # noqa: E402
from autopilot.navigation.precland_types import PrecLandPhase  # noqa: E402
from autopilot.param_catalogue import default_store  # noqa: E402
from autopilot.topics import BatteryState, GpsSample, ImuSample, LandingTargetEstimate, VehicleEstimate  # noqa: E402
from mavsim_core.px4_modes import Mode  # noqa: E402
from mavsim_core.statustext import StatustextChunker  # noqa: E402
from params.vehicle import load_vehicle  # noqa: E402

from flight_log_helpers import EPOCH0_US, make_mav  # tests/flight_log_helpers.py

T0_US = 2_000_000
STEP_US = 4000


def _estimate(t_us: int, down_m: float) -> VehicleEstimate:
    return VehicleEstimate(
        timestamp_us=t_us, q_wxyz=np.array([1.0, 0.0, 0.0, 0.0]), rate_frd_rad_s=np.zeros(3),
        accel_ned_m_s2=np.zeros(3), pos_ned_m=np.array([1.0, 2.0, down_m]), vel_ned_m_s=np.array([0.0, 0.0, -1.0]),
        attitude_valid=True, position_valid=True, origin_lat_deg=47.397742, origin_lon_deg=8.545594,
        origin_alt_amsl_m=488.0, yaw_rad=0.5,
    )  # fmt: skip


def _imu(t_us: int) -> ImuSample:
    return ImuSample(t_us, np.array([0.1, -0.2, -9.8]), np.array([0.01, 0.02, 0.03]), np.zeros(3), 1000.0, 20.0, 0x1FFF)


def _fly(rec, fc: FlightController, seconds: float, mode: Mode = Mode.AUTO_TAKEOFF) -> None:
    """Steps of a pretended flight: armed, climbing, a position setpoint, motors spinning, a GPS fix each 200 ms."""
    status = fc.commander.status
    battery = BatteryState(voltage_v=16.0, current_a=5.0, remaining_frac=0.8, consumed_mah=12.0)
    fc.commander.status = replace(status, armed=True, mode=mode, in_air=True, battery=battery)
    fc.setpoint = PositionSetpoint(np.array([1.0, 2.0, -5.0]), np.zeros(3), 0.5)
    fc.q_sp = np.array([1.0, 0.0, 0.0, 0.0])
    fc.thrust_vec = np.array([0.0, 0.0, -0.5 * fc.max_thrust_n])
    start = fc.last_us or T0_US
    for k in range(int(seconds * 1e6 / STEP_US)):
        t = start + k * STEP_US
        fc.last_us = t
        gps = fc.commander.status.gps
        if k % 50 == 0:
            gps = GpsSample(t, 3, 47.3977, 8.5456, 490.0, np.array([1.0, 1.0, 0.0]), 0.8, 1.2, 12)
        fc.commander.status = replace(fc.commander.status, estimate=_estimate(t, -0.001 * k), gps=gps)
        fc.actuators = replace(fc.actuators, motor_outputs=(0.5, 0.55, 0.6, 0.65))
        rec.on_step(_imu(t))


def test_a_flight_becomes_a_px4_ulog(tmp_path):
    fc = FlightController(load_vehicle("quad_x"), default_store())
    rec = flight_recorder.FlightRecorder(tmp_path, fc, instance=3, say=lambda t: None, epoch_s=lambda: EPOCH0_US / 1e6)
    fc.last_us = T0_US
    _fly(rec, fc, 2.0)
    assert rec.writing is not None and rec.writing.suffix == ".ulg"
    mav = make_mav()
    for msg in StatustextChunker().messages(mavlink.MAV_SEVERITY_WARNING, "Takeoff: " + "climbing " * 10):
        rec.tap(2_500_000, "gcs", True, msg.pack(mav))
        rec.tap(2_500_000, "api", True, msg.pack(make_mav()))  # the same text on the API endpoint: once in the log
    rec.tap(2_600_000, "gcs", True, mavlink.MAVLink_statustext_message(6, b"Landing detected").pack(mav))
    fc.params.set("MPC_XY_P", 1.2)
    fc.commander.status = replace(fc.commander.status, armed=False, mode=Mode.AUTO_LAND, in_air=False)
    for k in range(300):  # disarmed: the files close a second later
        fc.last_us += STEP_US
        rec.on_step(_imu(fc.last_us))
    assert rec.writing is None
    path = tmp_path / (rec.flights[0] + ".ulg")
    log = pyulog.ULog(str(path))

    assert not log.file_corruption
    assert log.start_timestamp == T0_US
    assert log.msg_info_dict["sys_name"] == "PX4" and log.msg_info_dict["sys_uuid"] == f"4d415653{3:08x}{4:08x}"
    assert log.msg_info_dict.get("ver_sw") == running_commit()  # the checkout's commit (none when installed)
    assert log.initial_parameters["MPC_XY_P"] == pytest.approx(fc.params.default("MPC_XY_P"))
    assert len(log.initial_parameters) == len(fc.params)
    assert [(name, round(v, 4)) for _, name, v in log.changed_parameters] == [("MPC_XY_P", 1.2)]
    texts = [(m.log_level_str(), m.message) for m in log.logged_messages]
    assert texts == [("WARNING", "Takeoff: " + "climbing " * 10), ("INFO", "Landing detected")]

    def topic(name):
        return log.get_dataset(name).data

    n_att = len(topic("vehicle_attitude")["timestamp"])
    assert abs(n_att - 3.0 / 0.012) <= 2  # every third 4 ms step for the 2 s flight and the 1 s tail
    assert np.all(np.diff(topic("vehicle_attitude")["timestamp"]) == 12_000)
    lp = topic("vehicle_local_position")
    assert np.all(np.diff(lp["timestamp"]) == 20_000) and abs(len(lp["timestamp"]) - 150) <= 1
    assert lp["z"][-1] == pytest.approx(-0.001 * 499, abs=0.01) and lp["heading"][0] == pytest.approx(0.5)
    assert lp["xy_valid"][0] == 1 and lp["ref_lat"][0] == pytest.approx(47.397742, abs=1e-9)
    sp = topic("vehicle_local_position_setpoint")
    assert len(sp["timestamp"]) == 100 and sp["z"][0] == -5.0  # written only while flying (armed)
    assert topic("vehicle_attitude_setpoint")["thrust_body[2]"][0] == pytest.approx(-0.5)
    outputs = topic("actuator_outputs")
    assert outputs["output[3]"][0] == pytest.approx(0.65) and outputs["noutputs"][0] == 4
    assert topic("sensor_combined")["accelerometer_m_s2[2]"][0] == pytest.approx(-9.8)
    assert topic("vehicle_air_data")["baro_pressure_pa"][0] == pytest.approx(100_000.0)
    gps = topic("vehicle_gps_position")
    assert len(gps["timestamp"]) == 10 and gps["latitude_deg"][0] == pytest.approx(47.3977, abs=1e-9)
    assert gps["time_utc_usec"][0] == EPOCH0_US  # the fix at arming: the wall-clock time of arming
    battery = topic("battery_status")
    assert battery["voltage_v"][0] == 16.0 and battery["remaining"][0] == pytest.approx(0.8)
    assert battery["discharged_mah"][0] == 12.0 and len(battery["timestamp"]) == 31  # 10 Hz from 2 s to 5 s
    status = topic("vehicle_status")
    assert list(status["arming_state"][[0, -1]]) == [2, 1]  # armed, then disarmed
    assert list(status["nav_state"][[0, -1]]) == [17, 18]  # AUTO_TAKEOFF, AUTO_LAND
    assert status["system_id"][0] == 4 and status["armed_time"][0] == T0_US
    changes = status["timestamp"][np.flatnonzero(np.diff(status["arming_state"])) + 1]
    assert list(changes) == [T0_US + 2_000_000]  # written at once on the change, not at the next 5 Hz tick


def test_sdlog_mode_minus_one_writes_no_ulog(tmp_path):
    fc = FlightController(load_vehicle("quad_x"), default_store())
    fc.params.set("SDLOG_MODE", -1)
    rec = flight_recorder.FlightRecorder(tmp_path, fc, say=lambda t: None)
    fc.last_us = T0_US
    _fly(rec, fc, 0.2)
    rec.close()
    assert sorted(p.suffix for p in tmp_path.iterdir()) == [".tlog"]


def test_logging_goes_on_when_the_simulated_clock_restarts(tmp_path):
    """The simulator reconnected mid-flight and its clock starts again from 0: the topics keep coming."""
    fc = FlightController(load_vehicle("quad_x"), default_store())
    rec = flight_recorder.FlightRecorder(tmp_path, fc, say=lambda t: None)
    fc.last_us = T0_US
    _fly(rec, fc, 0.5)
    fc.last_us = STEP_US
    _fly(rec, fc, 0.5)
    rec.close()
    log = pyulog.ULog(str(tmp_path / (rec.flights[0] + ".ulg")))
    times = log.get_dataset("vehicle_attitude").data["timestamp"]
    assert (times < T0_US).sum() == pytest.approx(0.5 / 0.012, abs=1)


def test_a_precision_landing_is_in_the_ulog_and_gcs_reads_it_back(tmp_path):
    """landing_target_pose (PX4's) and precision_landing (the phase, the measurements, the target's velocity over
    the ground) while a precision landing runs; ``gcs plot``'s reader pairs them (gcs/flight_logs.py)."""
    from gcs.flight_logs import load_ulog

    fc = FlightController(load_vehicle("quad_x"), default_store())
    rec = flight_recorder.FlightRecorder(tmp_path, fc, say=lambda t: None)
    fc.last_us = T0_US
    _fly(rec, fc, 0.2)  # no precision landing: neither topic
    fc.commander.task = SimpleNamespace(phase=PrecLandPhase.TRACKING)
    fc.landing_target.accepted = 7
    fc.landing_target.estimate = LandingTargetEstimate(
        T0_US, np.array([0.3, -0.4, 5.0]), np.array([0.5, 0.0, 0.0]), True, False, np.array([1.5, 0.25, 0.0])
    )
    _fly(rec, fc, 0.2)
    rec.close()
    path = tmp_path / (rec.flights[0] + ".ulg")
    log = pyulog.ULog(str(path))
    pose, pl = (log.get_dataset(name).data for name in ("landing_target_pose", "precision_landing"))
    assert len(pl["timestamp"]) == pytest.approx(0.2 / 0.02, abs=1) and (pl["timestamp"] >= T0_US + 200_000).all()
    assert list(pose["timestamp"]) == list(pl["timestamp"])  # written together, at 50 Hz
    assert pose["x_rel"][0] == pytest.approx(0.3) and pose["vx_rel"][0] == pytest.approx(0.5)
    assert (pose["x_abs"][0], pose["y_abs"][0]) == pytest.approx((1.3, 1.6))  # the vehicle at 1, 2 plus the target
    assert set(pl["phase"]) == {2} and set(pl["measurements"]) == {7}  # 2: tracking
    landing = load_ulog(path).landing
    assert landing is not None and set(landing.cols["precland_phase"]) == {2.0}
    assert landing.cols["tgt_n_m"][0] == pytest.approx(0.3) and landing.cols["tgt_e_m"][0] == pytest.approx(-0.4)
    assert landing.cols["tgt_vn_m_s"][0] == pytest.approx(1.5) and landing.cols["tgt_ve_m_s"][0] == pytest.approx(0.25)
