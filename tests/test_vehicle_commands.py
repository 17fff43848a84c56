"""The remaining commands QGroundControl and MAVSDK send, on the commander with nothing running: the bench of
tests/test_commander.py gets each through the command table as a COMMAND_LONG; the tests read what a ground
station sees (MAV_RESULT, STATUSTEXTs, published status, the setpoint flown)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink

from autopilot.commander.vehicle_commands import MOTOR_TEST_TIMEOUT_MAX_S
from autopilot.flight_controller import FlightController
from autopilot.navigation.orbit import OrbitTask
from autopilot.param_catalogue import default_store
from autopilot.param_storage import ParamSaver
from autopilot.topics import ImuSample
from mavsim_core import mission_items as mi
from mavsim_core.geodesy import ned_to_geodetic
from mavsim_core.mission_items import MissionItem
from mavsim_core.px4_modes import Mode
from params.vehicle import load_vehicle

from test_commander import ACCEPTED, DENIED, NAN7, ORIGIN, UNSUPPORTED, Bench

C = mavlink


def flying() -> Bench:
    b = Bench()
    b.fly_up()
    return b


def setpoint_speed(b: Bench) -> float:
    return float(np.linalg.norm(b.cmd.setpoint.vel_ned_m_s[:2]))


# --------------------------------------------------------------------------- DO_REPOSITION


def test_reposition_yaw_is_radians_nan_keeps_and_infinities_are_refused():
    b = flying()
    lat, lon, _ = ned_to_geodetic([20.0, 0.0, 0.0], *ORIGIN)
    assert b.command(C.MAV_CMD_DO_REPOSITION, 4.0, 0, 0, math.pi / 2, lat, lon, math.nan) == ACCEPTED
    assert b.cmd.task.yaw_rad == pytest.approx(math.pi / 2)  # east, not 90 radians
    assert b.cmd.task.cruise_m_s == 4.0  # param1: ground speed
    b.run(3.0)  # (the heading turns at MPC_YAWRAUTO_MAX, speeding up and slowing down at MPC_YAWRAUTO_ACC: 2.75 s)
    assert b.cmd.setpoint.yaw_rad == pytest.approx(math.pi / 2)
    b.run(10.0)
    np.testing.assert_allclose(b.pos[:2], [20.0, 0.0], atol=1e-6)
    # NaN yaw keeps the heading; speed <= 0 or NaN: MPC_XY_CRUISE
    assert b.command(C.MAV_CMD_DO_REPOSITION, math.nan, 0, 0, math.nan, *ORIGIN[:2], math.nan) == ACCEPTED
    assert b.cmd.task.cruise_m_s == b.params.get("MPC_XY_CRUISE")
    for bad in ((-1, 0, 0, math.inf, lat, lon, math.nan), (-1, 0, 0, math.nan, math.inf, lon, math.nan),
                (-1, 0, 0, math.nan, lat, lon, -math.inf)):  # fmt: skip
        assert b.command(C.MAV_CMD_DO_REPOSITION, *bad) == DENIED
        assert b.texts()[-1].startswith("Reposition denied: param") and b.texts()[-1].endswith("inf")


# --------------------------------------------------------------------------- DO_CHANGE_SPEED


def test_change_speed_applies_to_the_current_goto_and_to_later_ones():
    b = flying()
    lat, lon, _ = ned_to_geodetic([150.0, 0.0, 0.0], *ORIGIN)
    assert b.command(C.MAV_CMD_DO_REPOSITION, -1, 0, 0, math.nan, lat, lon, math.nan) == ACCEPTED
    b.run(5.0)
    assert setpoint_speed(b) == pytest.approx(b.params.get("MPC_XY_CRUISE"))
    north_before = b.pos[0]
    assert b.command(C.MAV_CMD_DO_CHANGE_SPEED, 1, 4.5, -1) == ACCEPTED
    assert b.texts()[-1] == "Speed set to 4.5 m/s"
    b.run(0.02)
    assert b.pos[0] > north_before  # goes on from where it was, without stopping first
    assert setpoint_speed(b) == pytest.approx(b.params.get("MPC_XY_CRUISE"), abs=0.1)
    b.run(5.0)
    assert setpoint_speed(b) == pytest.approx(4.5)
    assert b.command(C.MAV_CMD_DO_CHANGE_SPEED, 1, -1, -1) == ACCEPTED  # -1: no change
    assert b.command(C.MAV_CMD_DO_CHANGE_SPEED, 1, math.nan, -1) == ACCEPTED
    b.run(1.0)
    assert setpoint_speed(b) == pytest.approx(4.5)
    b.run(40.0)
    np.testing.assert_allclose(b.pos[:2], [150.0, 0.0], atol=1e-6)
    # a later reposition without a speed flies at it; -2: back to MPC_XY_CRUISE
    assert b.command(C.MAV_CMD_DO_REPOSITION, -1, 0, 0, math.nan, *ORIGIN[:2], math.nan) == ACCEPTED
    assert b.cmd.task.cruise_m_s == 4.5
    assert b.command(C.MAV_CMD_DO_CHANGE_SPEED, 1, -2, -1) == ACCEPTED
    assert b.command(C.MAV_CMD_DO_REPOSITION, -1, 0, 0, math.nan, *ORIGIN[:2], math.nan) == ACCEPTED
    assert b.cmd.task.cruise_m_s == b.params.get("MPC_XY_CRUISE")
    assert b.command(C.MAV_CMD_DO_CHANGE_SPEED, 1, 12.0, -1) == ACCEPTED
    assert b.texts()[-2:] == ["Speed 12 m/s limited to MPC_XY_VEL_MAX", "Speed set to 5.0 m/s"]
    assert b.command(C.MAV_CMD_DO_CHANGE_SPEED, 2, 1.0, -1) == DENIED
    assert b.texts()[-1] == "Change speed denied: speed type 2 not supported (0, 1)"
    assert b.command(C.MAV_CMD_DO_CHANGE_SPEED, 1, 0.0, -1) == DENIED
    assert b.texts()[-1] == "Change speed denied: 0 m/s is not a speed"


def test_change_speed_in_a_mission():
    (b := flying()).params.set("MPC_XY_CRUISE", 3.0)  # below the 4.5 m/s set later: a change up
    items = [MissionItem(0, mi.FRAME_GLOBAL_RELATIVE_ALT, mi.NAV_WAYPOINT, x=int(ORIGIN[0] * 1e7 + 9000),
                         y=int(ORIGIN[1] * 1e7), z=5.0)]  # fmt: skip
    b.cmd.plans.replace(mi.MISSION, items, mission_active=False)
    assert b.set_mode(Mode.AUTO_MISSION) == ACCEPTED
    b.run(5.0)
    assert setpoint_speed(b) == pytest.approx(b.params.get("MPC_XY_CRUISE"))
    north_before = b.pos[0]
    assert b.command(C.MAV_CMD_DO_CHANGE_SPEED, 1, 4.5, -1) == ACCEPTED
    assert b.cmd.task.cruise == 4.5  # the later legs
    b.run(0.02)
    assert b.pos[0] > north_before and setpoint_speed(b) == pytest.approx(b.params.get("MPC_XY_CRUISE"), abs=0.1)
    b.run(3.0)
    assert setpoint_speed(b) == pytest.approx(4.5)  # the current leg, without stopping
    b.run(30.0)
    assert b.cmd.task.complete and b.pos[0] == pytest.approx(100.19, abs=0.01)  # still ends at the waypoint
    assert "Mission: item 0 reached" in b.texts()


# ------------------------------------------------------------- DO_SET_HOME (GET_HOME_POSITION: test_px4_leftovers.py)


def test_set_home_here_or_at_a_point():
    b = Bench()
    assert b.command(C.MAV_CMD_DO_SET_HOME, 1) == DENIED
    assert b.texts()[-1] == "Set home denied: no position estimate"
    b.run(0.5)
    b.pos = np.array([3.0, -2.0, 0.0])
    b.run(0.04)
    assert b.command(C.MAV_CMD_DO_SET_HOME, 1, *NAN7[:6]) == ACCEPTED
    np.testing.assert_allclose(b.cmd.status.home.pos_ned_m, [3.0, -2.0, 0.0])
    assert b.texts()[-1].startswith("Home set: ")
    lat, lon, _ = ned_to_geodetic([-10.0, 4.0, 0.0], *ORIGIN)
    assert b.command(C.MAV_CMD_DO_SET_HOME, 0, 0, 0, math.nan, lat, lon, ORIGIN[2] + 2.0) == ACCEPTED
    np.testing.assert_allclose(b.cmd.status.home.pos_ned_m, [-10.0, 4.0, -2.0], atol=1e-6)
    assert b.cmd.status.home.alt_amsl_m == pytest.approx(ORIGIN[2] + 2.0)
    assert b.command(C.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, lat, lon, math.nan) == DENIED
    assert b.texts()[-1] == "Set home denied: latitude, longitude and altitude required"
    assert b.command(C.MAV_CMD_DO_SET_HOME, 0, 0, 0, 0, 91.0, lon, 500.0) == DENIED
    assert b.texts()[-1] == "Set home denied: latitude/longitude 91, 8.54565 out of range"


# --------------------------------------------------------------------------- CONDITION_YAW


def test_condition_yaw_turns_in_place_at_the_rate():
    b = Bench()
    b.run(0.5)
    assert b.command(C.MAV_CMD_CONDITION_YAW, 90, 30, 1, 0) == DENIED
    assert b.texts()[-1] == "Yaw denied: vehicle not flying"
    b.fly_up()
    held = b.pos.copy()
    assert b.command(C.MAV_CMD_CONDITION_YAW, 90, 30, 0, 0) == ACCEPTED  # absolute 90 deg at 30 deg/s
    b.run(1.5)  # at 30 deg/s after speeding up at MPC_YAWRAUTO_ACC (60 deg/s^2) for 0.5 s: 45 - 7.5 deg
    assert math.degrees(b.cmd.setpoint.yaw_rad) == pytest.approx(37.5, abs=1.0)
    b.run(2.5)  # (slowing down to stop on it: 3.5 s in all)
    assert math.degrees(b.cmd.setpoint.yaw_rad) == pytest.approx(90.0)
    np.testing.assert_allclose(b.pos, held, atol=1e-9)  # in place
    # relative, counter-clockwise: 90 -> 30 deg; speed 0: MPC_YAWRAUTO_MAX
    assert b.command(C.MAV_CMD_CONDITION_YAW, 60, 0, -1, 1) == ACCEPTED
    b.run(5.0)
    assert math.degrees(b.cmd.setpoint.yaw_rad) == pytest.approx(30.0)
    # clockwise the long way: 30 -> 0 deg through 180
    assert b.command(C.MAV_CMD_CONDITION_YAW, 0, 90, 1, 0) == ACCEPTED
    b.run(2.0)  # 1.5 s speeding up to 90 deg/s (67.5 deg), 0.5 s at it: 30 + 112.5 deg, clockwise
    assert math.degrees(b.cmd.setpoint.yaw_rad) == pytest.approx(142.5, abs=1.0)
    b.run(3.5)  # (330 deg: 5.2 s in all)
    assert b.cmd.setpoint.yaw_rad == pytest.approx(0.0, abs=1e-9)
    assert b.command(C.MAV_CMD_CONDITION_YAW, math.nan, 0, 0, 0) == DENIED
    assert b.texts()[-1] == "Yaw denied: param1 (angle) not given"
    b.set_mode(Mode.AUTO_RTL)
    assert b.command(C.MAV_CMD_CONDITION_YAW, 90, 30, 0, 0) == DENIED
    assert b.texts()[-1] == "Yaw denied: only while holding or going to a point (AUTO.LOITER)"


def test_a_speed_change_during_a_turn_keeps_the_turn_and_speeds_the_goto():
    """CONDITION_YAW while going to a point, then DO_CHANGE_SPEED mid-turn: the heading goes on turning to its
    target at its rate (it was dropped: the new go-to took the turn's place) and the go-to flies at the new speed."""
    b = flying()
    lat, lon, _ = ned_to_geodetic([150.0, 0.0, 0.0], *ORIGIN)
    assert b.command(C.MAV_CMD_DO_REPOSITION, -1, 0, 0, math.nan, lat, lon, math.nan) == ACCEPTED
    b.run(3.0)
    assert b.command(C.MAV_CMD_CONDITION_YAW, 90, 30, 0, 0) == ACCEPTED  # absolute 90 deg at 30 deg/s: 3.5 s
    b.run(1.0)
    turning = math.degrees(b.cmd.setpoint.yaw_rad)
    assert 5.0 < turning < 30.0
    assert b.command(C.MAV_CMD_DO_CHANGE_SPEED, 1, 4.5, -1) == ACCEPTED
    b.run(0.5)
    assert math.degrees(b.cmd.setpoint.yaw_rad) == pytest.approx(turning + 15.0, abs=1.0)  # on at 30 deg/s
    b.run(2.5)
    assert math.degrees(b.cmd.setpoint.yaw_rad) == pytest.approx(90.0)
    assert setpoint_speed(b) == pytest.approx(4.5)
    b.run(40.0)
    np.testing.assert_allclose(b.pos[:2], [150.0, 0.0], atol=1e-6)
    assert math.degrees(b.cmd.setpoint.yaw_rad) == pytest.approx(90.0)  # the turn's heading held at the goal


# --------------------------------------------------------------------------- DO_PAUSE_CONTINUE


def test_pause_holds_and_continue_resumes_the_mission():
    b = flying()
    assert b.command(C.MAV_CMD_DO_PAUSE_CONTINUE, 1) == DENIED
    assert b.texts()[-1] == "Continue denied: no mission uploaded"
    items = [MissionItem(0, mi.FRAME_GLOBAL_RELATIVE_ALT, mi.NAV_WAYPOINT, x=int(ORIGIN[0] * 1e7 + 9000),
                         y=int(ORIGIN[1] * 1e7), z=5.0)]  # fmt: skip
    b.cmd.plans.replace(mi.MISSION, items, mission_active=False)
    assert b.set_mode(Mode.AUTO_MISSION) == ACCEPTED
    b.run(3.0)
    assert b.command(C.MAV_CMD_DO_PAUSE_CONTINUE, 0) == ACCEPTED
    assert b.cmd.status.mode is Mode.AUTO_LOITER and "Paused: holding position" in b.texts()
    b.run(2.0)
    held = b.pos.copy()
    b.run(3.0)
    np.testing.assert_allclose(b.pos, held, atol=1e-9)
    assert b.command(C.MAV_CMD_DO_PAUSE_CONTINUE, 1) == ACCEPTED
    assert b.cmd.status.mode is Mode.AUTO_MISSION
    b.run(60.0)
    assert b.pos[0] == pytest.approx(100.0, abs=1.0)  # the waypoint, 9000e-7 deg north
    assert b.command(C.MAV_CMD_DO_PAUSE_CONTINUE, 2) == DENIED
    assert b.texts()[-1] == "Pause/continue denied: param1 (continue) 2 is not one of 0, 1"


# --------------------------------------------------------------------------- DO_FLIGHTTERMINATION


def test_flight_termination_stops_the_motors_until_reboot():
    b = flying()
    assert b.command(C.MAV_CMD_DO_FLIGHTTERMINATION, 0.2) == ACCEPTED  # below 0.5: nothing
    assert b.cmd.status.armed
    assert b.command(C.MAV_CMD_DO_FLIGHTTERMINATION, 1) == ACCEPTED
    b.run(0.02)
    assert not b.cmd.status.armed and b.cmd.setpoint is None
    assert "Flight terminated: motors off until reboot" in b.texts()
    b.run(2.0)
    assert b.arm(force=True) == DENIED
    assert b.texts()[-1] == "Arming denied: flight terminated (reboot to clear)"
    assert b.command(C.MAV_CMD_DO_MOTOR_TEST, 1, 0, 10, 1) == DENIED
    assert b.command(C.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 1) == ACCEPTED
    b.run(1.0)
    assert b.arm() == ACCEPTED


# --------------------------------------------------------------------------- PREFLIGHT_REBOOT_SHUTDOWN


def test_reboot_restarts_the_state_disarmed_only_and_keeps_parameters():
    b = flying()
    assert b.command(C.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 1) == DENIED
    assert b.texts()[-1] == "Reboot denied: vehicle armed (disarm first)"
    b.command(C.MAV_CMD_NAV_LAND)
    b.run(15.0)
    assert not b.cmd.status.armed
    b.params.set("MPC_XY_CRUISE", 4.0)
    plans, inputs = b.cmd.plans, b.cmd.inputs
    assert b.command(C.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 0) == ACCEPTED  # no action
    assert b.command(C.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 1, 1, 1, 1) == ACCEPTED  # as MAVSDK sends it
    st = b.cmd.status
    assert st.home is None and st.estimate is None and st.mode is Mode.POSCTL and not st.armed
    assert b.texts()[-1] == "Rebooted: flight controller restarted, parameters kept"
    assert b.cmd.reboot_pending  # the flight controller restarts the estimator and controllers next
    assert b.params.get("MPC_XY_CRUISE") == 4.0 and b.cmd.plans is plans and b.cmd.inputs is inputs
    b.run(0.5)
    assert b.cmd.status.home is not None and b.texts()[-1].startswith("Home set: ")
    assert b.command(C.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 2) == UNSUPPORTED
    assert b.texts()[-1] == "Reboot/shutdown: shutdown not supported in simulation"
    assert b.command(C.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 7) == DENIED
    assert b.texts()[-1] == "Reboot/shutdown denied: param1 (autopilot action) 7 is not a whole number in 0..3"


def test_reboot_restarts_the_flight_controllers_estimator_in_place():
    fc = FlightController(load_vehicle("quad_x"), default_store())
    listeners = len(fc.params._listeners)

    def imu(t_us: int) -> ImuSample:
        return ImuSample(t_us, np.array([0.0, 0.0, -9.81]), np.zeros(3), np.array([0.2, 0.0, 0.4]), 1013.25, 20.0, 0)

    for k in range(1, 30):
        fc.step(imu(k * 4000), None)
        fc.after_step()
    est = fc.estimator
    fc.params.set("EKF2_GPS_DELAY", 50.0)
    fc.estimator.events.append(("INFO", "before the reboot"))
    assert fc.commander.reboot() == ACCEPTED
    fc.step(imu(400_000), None)
    assert fc.estimator is est and not fc.commander.reboot_pending
    assert est.last_imu_us == 400_000 and est.events == []  # as at power-on: one sample since
    assert est.gps.delay_us == 50_000 and est.defer_filters  # the parameters read as before
    assert len(fc.params._listeners) == listeners  # no second subscription
    assert fc.setpoint is None and not fc.commander.status.armed


# --------------------------------------------------------------------------- PREFLIGHT_STORAGE


def test_parameter_storage_read_write_reset(tmp_path):
    b = Bench()
    b.run(0.5)
    b.params.set("MPC_XY_CRUISE", 4.0)
    assert b.command(C.MAV_CMD_PREFLIGHT_STORAGE, 1) == DENIED
    assert b.texts()[-1] == "Parameter storage denied: parameters are not saved (no --state-dir)"
    assert b.command(C.MAV_CMD_PREFLIGHT_STORAGE, 2) == ACCEPTED  # reset works without storage
    assert b.params.get("MPC_XY_CRUISE") == b.params.default("MPC_XY_CRUISE")
    assert b.texts()[-1] == "Parameters reset to defaults (1 changed)"
    saver = ParamSaver(b.params, tmp_path / "quad-0.params")
    try:
        b.cmd.param_saver = saver
        b.params.set("MPC_XY_CRUISE", 4.0)
        assert b.command(C.MAV_CMD_PREFLIGHT_STORAGE, 1) == ACCEPTED
        assert b.texts()[-1] == "Parameters saved"
        saved = (tmp_path / "quad-0.params").read_text()
        assert "MPC_XY_CRUISE" in saved
    finally:
        saver.close()
    # read: the stored set replaces what is in memory (values not stored go back to their defaults)
    stored = tmp_path / "stored.params"
    stored.write_text(saved)
    b.cmd.param_saver = type("Storage", (), {"path": stored, "save": lambda self: True})()
    b.params.set("MPC_XY_CRUISE", 4.5)
    b.params.set("MPC_ACC_HOR", 4.0)
    assert b.command(C.MAV_CMD_PREFLIGHT_STORAGE, 0) == ACCEPTED
    assert b.params.get("MPC_XY_CRUISE") == 4.0 and b.params.get("MPC_ACC_HOR") == b.params.default("MPC_ACC_HOR")
    assert b.texts()[-1].startswith("Parameters read from storage")
    assert b.command(C.MAV_CMD_PREFLIGHT_STORAGE, 9) == DENIED
    assert b.texts()[-1].endswith("param1 (parameter storage action) 9 is not a whole number in 0..4")
    assert b.arm() == ACCEPTED
    assert b.command(C.MAV_CMD_PREFLIGHT_STORAGE, 1) == ACCEPTED  # saving is allowed armed ...
    for action in (0, 2):  # ... reading and resetting are not
        assert b.command(C.MAV_CMD_PREFLIGHT_STORAGE, action) == DENIED
        assert b.texts()[-1] == "Parameter storage denied: vehicle armed"


# --------------------------------------------------------------------------- DO_MOTOR_TEST


def test_motor_test_on_the_ground_for_the_timeout():
    b = Bench()
    b.run(0.5)
    assert b.command(C.MAV_CMD_DO_MOTOR_TEST, 2, C.MOTOR_TEST_THROTTLE_PERCENT, 20, 1.0, 0, 0) == ACCEPTED
    assert b.texts()[-1] == "Motor test: motor 2 at 20% for 1 s"
    out = b.cmd.motor_test_output(b.t_us + 1000, 4)
    np.testing.assert_allclose(out, [0.0, 0.2, 0.0, 0.0])
    b.run(0.5)
    assert b.cmd.motor_test_output(b.t_us, 4) is not None
    b.run(0.6)
    assert b.cmd.motor_test_output(b.t_us, 4) is None  # the timeout ended it
    assert b.command(C.MAV_CMD_DO_MOTOR_TEST, 1, C.MOTOR_TEST_THROTTLE_PWM, 1300, 60.0) == ACCEPTED
    assert b.cmd.motor_test_run.frac == pytest.approx(0.3)
    assert b.cmd.motor_test_run.until_us == b.t_us + int(MOTOR_TEST_TIMEOUT_MAX_S * 1e6)
    assert b.command(C.MAV_CMD_DO_MOTOR_TEST, 1, C.MOTOR_TEST_THROTTLE_PERCENT, 0, 1.0) == ACCEPTED  # stop
    assert b.cmd.motor_test_output(b.t_us, 4) is None
    assert b.command(C.MAV_CMD_DO_MOTOR_TEST, 5, 0, 10, 1) == DENIED
    assert b.texts()[-1] == "Motor test denied: motor 5 not in 1..4"
    assert b.command(C.MAV_CMD_DO_MOTOR_TEST, 0, 0, 10, 1) == DENIED
    assert b.command(C.MAV_CMD_DO_MOTOR_TEST, 1, C.MOTOR_TEST_THROTTLE_PILOT, 10, 1) == UNSUPPORTED
    assert b.texts()[-1] == "Motor test denied: throttle type 2 not supported (0, 1)"
    assert b.command(C.MAV_CMD_DO_MOTOR_TEST, 1, 0, 10, 1, 4) == DENIED
    assert b.command(C.MAV_CMD_DO_MOTOR_TEST, 1, 0, math.nan, 1) == DENIED
    assert b.arm() == ACCEPTED
    assert b.command(C.MAV_CMD_DO_MOTOR_TEST, 1, 0, 10, 1) == DENIED
    assert b.texts()[-1] == "Motor test denied: vehicle armed"


# --------------------------------------------------------------------------- DO_ORBIT


def test_orbit_circles_the_centre_facing_it():
    b = Bench()
    b.run(0.5)
    assert b.command(C.MAV_CMD_DO_ORBIT, 5, 2, math.nan, 0, math.nan, math.nan, math.nan) == DENIED
    assert b.texts()[-1] == "Orbit denied: vehicle not flying"
    b.fly_up()
    centre_ned = np.array([10.0, 0.0, -5.0])
    lat, lon, _ = ned_to_geodetic(centre_ned, *ORIGIN)
    assert b.command(C.MAV_CMD_DO_ORBIT, 5, 2, math.nan, 0, lat, lon, ORIGIN[2] + 7.0) == ACCEPTED
    assert b.cmd.status.mode is Mode.POSCTL_ORBIT and isinstance(b.cmd.task, OrbitTask)
    assert Mode.POSCTL_ORBIT.custom_mode == 3 << 16 | 1 << 24  # PX4: POSCTL main mode, ORBIT sub-mode
    b.run(15.0)
    angles = []
    for _ in range(40):
        b.run(0.25)
        d = b.pos[:2] - centre_ned[:2]
        assert np.hypot(*d) == pytest.approx(5.0, abs=0.01)
        assert b.pos[2] == pytest.approx(-(2.0 + 5.0), abs=0.01)  # 7 m above the origin
        assert setpoint_speed(b) == pytest.approx(2.0, abs=0.01)
        to_centre = math.atan2(-d[1], -d[0])
        assert math.cos(b.cmd.setpoint.yaw_rad - to_centre) == pytest.approx(1.0)
        angles.append(math.atan2(d[1], d[0]))
    assert np.all(np.diff(np.unwrap(angles)) > 0)  # radius > 0: clockwise seen from above
    # negative radius: counter-clockwise, about the same centre (NaN), speed kept (NaN)
    assert b.command(C.MAV_CMD_DO_ORBIT, -5, math.nan, 3, 0, math.nan, math.nan, math.nan) == ACCEPTED
    b.run(5.0)
    angles = []
    for _ in range(8):
        b.run(0.25)
        angles.append(math.atan2(*(b.pos[:2] - centre_ned[:2])[::-1]))
    assert np.all(np.diff(np.unwrap(angles)) < 0)
    assert b.command(C.MAV_CMD_DO_ORBIT, 0.5, 1, 0, 0, *NAN7[:3]) == DENIED
    assert b.texts()[-1] == "Orbit denied: radius 0.5 m outside 1..1000 m"
    assert b.command(C.MAV_CMD_DO_ORBIT, 5, 50, 0, 0, *NAN7[:3]) == ACCEPTED
    assert b.texts()[-2] == f"Orbit speed limited to {math.sqrt(b.params.get('MPC_ACC_HOR') * 5):.1f} m/s (radius 5 m)"
    # a reposition leaves the orbit
    assert b.command(C.MAV_CMD_DO_REPOSITION, -1, 0, 0, math.nan, *NAN7[:3]) == ACCEPTED
    assert b.cmd.status.mode is Mode.AUTO_LOITER
