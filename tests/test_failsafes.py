"""The failsafes with nothing running: data link, sticks (RC), battery, estimate and offboard loss.

A real :class:`Commander` with the real parameter catalogue is fed 50 Hz estimates of a point that
follows its setpoints (test_commander's Bench, which also flies velocity-only and attitude setpoints
here).  Ground-station heartbeats and MANUAL_CONTROL reach it as the link delivers them
(``commander.inputs``), stamped with simulated time and, where a test says so, a wall clock.  The test
reads what a ground station sees: the STATUSTEXTs, the mode, and the HEARTBEAT system_status and
SYS_STATUS bits of the telemetry snapshot.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink.vehicle_interface import telemetry_snapshot
from autopilot.navigation import offboard
from autopilot.navigation.descend import DescendTask
from autopilot.topics import (
    NO_ACTUATORS,
    AttitudeSetpoint,
    BatteryState,
    LandedState,
    ManualInput,
    OffboardKind,
    OffboardSetpoint,
    VehicleEstimate,
)
from mavsim_core.px4_modes import Mode
from mavsim_core.quaternion import from_euler
from sitl.battery import Battery
from sitl.sim_params import SimParameters
from sitl.sim_settings import MotorSettings, SensorSettings, WindSettings

from test_commander import ACCEPTED, DT_US, ORIGIN, Bench

CRITICAL, EMERGENCY = mavlink.MAV_STATE_CRITICAL, mavlink.MAV_STATE_EMERGENCY
RC_BIT = mavlink.MAV_SYS_STATUS_SENSOR_RC_RECEIVER


class FailBench(Bench):
    """Bench with a ground station, sticks, a wall clock and attitude setpoints (a sink of 0.5 m/s)."""

    def __init__(self) -> None:
        super().__init__()
        self.wall: float | None = None  # wall clock passed to the commander (None: simulated time only)
        self.height_valid = True
        self.gcs = False  # a ground station sends HEARTBEATs every update
        self.sticks: tuple[float, float, float, float] | None = None  # pitch, roll, throttle, yaw
        self.offboard_stream = False

    def run(self, seconds: float, wall_per_step_s: float | None = None) -> None:
        for _ in range(round(seconds * 1e6 / DT_US)):
            self.t_us += DT_US
            if self.wall is not None:
                self.wall += DT_US * 1e-6 if wall_per_step_s is None else wall_per_step_s
            self._inputs()
            est = VehicleEstimate(
                timestamp_us=self.t_us, q_wxyz=from_euler(self.roll, 0.0, 0.0), rate_frd_rad_s=np.zeros(3),
                accel_ned_m_s2=np.zeros(3), pos_ned_m=self.pos.copy(), vel_ned_m_s=self.vel.copy(),
                attitude_valid=self.attitude_valid, position_valid=self.position_valid,
                origin_lat_deg=ORIGIN[0], origin_lon_deg=ORIGIN[1], origin_alt_amsl_m=ORIGIN[2],
                roll_rad=self.roll, height_valid=self.height_valid,
            )  # fmt: skip
            sp = self.cmd.update(self.t_us, est, self.gps, self.gps is not None, self._thrust(), wall_s=self.wall)
            self.last_sp = sp
            self._follow(sp)
            self.drain()

    def _inputs(self) -> None:
        inputs, wall = self.cmd.inputs, self.wall if self.wall is not None else 0.0
        if self.gcs:
            inputs.on_gcs_heartbeat(self.t_us, wall)
        if self.sticks is not None:
            inputs.on_manual(ManualInput(self.t_us, wall, *self.sticks))
        if self.offboard_stream:
            nan3 = np.full(3, math.nan)
            hold = np.array([0.0, 0.0, -5.0])
            sp = OffboardSetpoint(
                self.t_us, wall, OffboardKind.POSITION, mavlink.MAV_FRAME_LOCAL_NED, hold, nan3, nan3, 0.0, math.nan
            )
            inputs.on_offboard(sp)

    def _follow(self, sp) -> None:
        if isinstance(sp, AttitudeSetpoint):
            old = self.pos.copy()
            self.pos[2] = min(self.pos[2] + 0.5 * DT_US * 1e-6, 0.0)
            self.vel = (self.pos - old) / (DT_US * 1e-6)
            return
        if sp is not None and not np.all(np.isfinite(sp.vel_ned_m_s)):
            sp = type(sp)(sp.pos_ned_m, np.nan_to_num(sp.vel_ned_m_s), sp.yaw_rad, sp.acc_ned_m_s2)
        super()._follow(sp)

    def telemetry(self):
        return telemetry_snapshot(self.cmd.status, NO_ACTUATORS, None, None, False)

    def count(self, fragment: str) -> int:
        return sum(fragment in t for t in self.texts())


def flying(**params: float) -> FailBench:
    b = FailBench()
    for name, value in params.items():
        b.params.set(name, value)
    b.fly_up()
    return b


# --------------------------------------------------------------------------- data link


def test_data_link_loss_returns_once_reports_regain_and_lets_the_pilot_take_over():
    b = flying(NAV_DLL_ACT=2)
    b.gcs = True
    b.run(2.0)
    b.gcs = False
    b.run(9.5)  # COM_DL_LOSS_T 10 s: not yet
    assert b.count("Data link lost") == 0 and b.cmd.status.mode is Mode.AUTO_LOITER
    b.run(1.0)
    assert "Data link lost: returning" in b.texts()
    assert b.texts().index("Data link lost: returning") < b.texts().index("Mode AUTO.RTL")  # said first
    assert b.cmd.status.mode is Mode.AUTO_RTL
    assert b.cmd.status.failsafe.gcs_lost and b.cmd.status.failsafe.action_in_force
    assert b.telemetry().system_status == CRITICAL
    assert b.set_mode(Mode.AUTO_LOITER) == ACCEPTED  # the pilot takes over: no second trigger
    b.run(3.0)
    assert b.cmd.status.mode is Mode.AUTO_LOITER and b.count("Data link lost") == 1
    assert b.telemetry().system_status == mavlink.MAV_STATE_ACTIVE
    b.gcs = True
    b.run(0.1)
    assert b.texts()[-1] == "Data link regained" and not b.cmd.status.failsafe.gcs_lost


def test_no_data_link_failsafe_before_a_ground_station_was_seen_and_default_only_reports():
    b = flying(NAV_DLL_ACT=3)
    b.run(15.0)
    assert b.count("Data link") == 0  # never saw a ground station
    b = flying()  # PX4's default NAV_DLL_ACT 0: disabled, the loss is only reported
    b.gcs = True
    b.run(1.0)
    b.gcs = False
    b.run(11.0)
    assert b.count("Data link lost") == 1 and "Data link lost" in b.texts()
    assert b.cmd.status.mode is Mode.AUTO_LOITER and not b.cmd.status.failsafe.action_in_force


def test_data_link_loss_return_refused_falls_back_to_land():
    b = flying(NAV_DLL_ACT=2)
    enter = b.cmd._enter

    def refuse_return(mode, *args):  # as mode_entry refuses it (no home, no position)
        if mode is Mode.AUTO_RTL:
            b.cmd.say(mavlink.MAV_SEVERITY_CRITICAL, "Return denied: no home position")
            return mavlink.MAV_RESULT_DENIED
        return enter(mode, *args)

    b.cmd._enter = refuse_return
    b.gcs = True
    b.run(0.5)
    b.gcs = False
    b.run(11.0)
    texts = b.texts()
    assert "Data link lost: landing" in texts and "Return denied: no home position" in texts
    assert b.cmd.status.mode is Mode.AUTO_LAND


# --------------------------------------------------------------------------- sticks (RC)


def test_rc_loss_returns_by_default_reports_regain_and_sets_the_rc_bit():
    b = flying()
    b.sticks = (0.0, 0.0, 0.5, 0.0)
    b.run(0.2)
    assert b.set_mode(Mode.POSCTL) == ACCEPTED
    b.run(1.0)
    t = b.telemetry()
    assert t.sensors_present & RC_BIT and t.sensors_health & RC_BIT
    b.sticks = None
    b.run(0.4)  # COM_RC_LOSS_T 0.5 s
    assert b.count("Manual control lost") == 0
    b.run(0.3)
    assert "Manual control lost: returning" in b.texts()  # NAV_RCL_ACT default 2: Return
    assert b.cmd.status.mode is Mode.AUTO_RTL and b.telemetry().system_status == CRITICAL
    assert not b.telemetry().sensors_health & RC_BIT
    b.run(2.0)
    assert b.count("Manual control lost") == 1
    b.sticks = (0.0, 0.0, 0.5, 0.0)
    b.run(0.1)
    assert b.texts()[-1] == "Manual control regained" and b.telemetry().sensors_health & RC_BIT


def test_rc_loss_exceptions_and_hold_action():
    b = flying(COM_RCL_EXCEPT=2)  # Hold excepted: the vehicle is in AUTO.LOITER
    b.sticks = (0.0, 0.0, 0.5, 0.0)
    b.run(0.5)
    b.sticks = None
    b.run(1.0)
    assert "Manual control lost" in b.texts() and b.cmd.status.mode is Mode.AUTO_LOITER
    b = flying(NAV_RCL_ACT=1)  # Hold from POSCTL
    b.sticks = (0.0, 0.0, 0.5, 0.0)
    b.run(0.2)
    assert b.set_mode(Mode.POSCTL) == ACCEPTED
    b.run(0.5)
    b.sticks = None
    b.run(1.0)
    assert "Manual control lost: holding" in b.texts() and b.cmd.status.mode is Mode.AUTO_LOITER


def test_rc_loss_on_the_ground_is_only_reported_and_termination_stops_the_motors():
    b = FailBench()
    b.run(1.0)
    b.sticks = (0.0, 0.0, 0.0, 0.0)
    assert b.arm() == ACCEPTED
    b.run(0.2)
    b.sticks = None
    b.run(1.0)
    assert "Manual control lost" in b.texts() and b.cmd.status.armed
    b = flying(NAV_RCL_ACT=5)
    b.sticks = (0.0, 0.0, 0.5, 0.0)
    b.run(0.2)
    b.sticks = None
    b.run(1.0)
    assert "Manual control lost: motors stopped" in b.texts() and not b.cmd.status.armed
    assert b.cmd.status.failsafe.emergency and b.telemetry().system_status == EMERGENCY


def test_rc_loss_needs_silence_on_both_clocks():
    b = FailBench()
    b.wall = 100.0
    b.params.set("NAV_RCL_ACT", 3)
    b.fly_up()
    b.sticks = (0.0, 0.0, 0.5, 0.0)
    b.run(0.2)
    assert b.set_mode(Mode.POSCTL) == ACCEPTED
    b.sticks = None
    b.run(3.0, wall_per_step_s=0.001)  # the simulation races ahead: 3 s simulated, 0.15 s of wall clock
    assert b.count("Manual control lost") == 0 and b.cmd.status.mode is Mode.POSCTL
    b.run(0.4)  # now the wall clock passes COM_RC_LOSS_T too
    assert "Manual control lost: landing" in b.texts() and b.cmd.status.mode is Mode.AUTO_LAND


# --------------------------------------------------------------------------- battery


def battery(b: FailBench, frac: float) -> None:
    b.cmd.set_battery(BatteryState(14.0, 10.0, frac))
    b.run(0.1)


def test_battery_warns_low_returns_at_critical_lands_at_emergency():
    b = flying(COM_LOW_BAT_ACT=3)
    battery(b, 0.14)
    assert b.texts()[-1] == "Low battery (14% left): return advised"
    assert b.cmd.status.mode is Mode.AUTO_LOITER
    battery(b, 0.13)
    assert b.count("Low battery") == 1  # once per level
    battery(b, 0.06)
    assert "Critical battery (6% left): returning" in b.texts() and b.cmd.status.mode is Mode.AUTO_RTL
    t = b.telemetry()
    assert t.system_status == CRITICAL and not t.sensors_health & mavlink.MAV_SYS_STATUS_SENSOR_BATTERY
    battery(b, 0.04)
    assert "Emergency battery (4% left): landing" in b.texts() and b.cmd.status.mode is Mode.AUTO_LAND
    assert b.telemetry().system_status == EMERGENCY
    assert b.set_mode(Mode.AUTO_LOITER) == ACCEPTED  # the pilot may still switch modes
    b.run(1.0)
    assert b.cmd.status.mode is Mode.AUTO_LOITER and b.count("Emergency battery") == 1


def test_battery_default_only_warns_and_land_action_lands_at_critical():
    b = flying()  # COM_LOW_BAT_ACT 0: warning
    battery(b, 0.06)
    assert b.texts()[-1] == "Critical battery (6% left): landing advised" and b.cmd.status.mode is Mode.AUTO_LOITER
    battery(b, 0.04)
    assert b.texts()[-1] == "Emergency battery (4% left): land now" and b.cmd.status.mode is Mode.AUTO_LOITER
    b = flying(COM_LOW_BAT_ACT=2)
    battery(b, 0.06)
    assert "Critical battery (6% left): landing" in b.texts() and b.cmd.status.mode is Mode.AUTO_LAND
    battery(b, 0.04)
    assert "Emergency battery (4% left): already landing" in b.texts()


# --------------------------------------------------------------------------- estimate


def test_position_lost_lands_without_sticks_once_and_reports_regain():
    b = flying()
    b.position_valid = False
    b.run(0.1)
    assert "Position estimate lost: landing" in b.texts() and b.cmd.status.mode is Mode.AUTO_LAND
    b.run(1.0)
    assert b.count("Position estimate lost") == 1
    b.position_valid = True
    b.run(0.1)
    assert b.texts()[-1] == "Position estimate regained"


def test_position_lost_with_sticks_is_altitude_control_unless_posctl_navl_says_land():
    b = flying()
    b.sticks = (0.0, 0.0, 0.5, 0.0)
    b.run(0.2)
    assert b.set_mode(Mode.POSCTL) == ACCEPTED
    b.position_valid = False
    b.run(0.5)
    assert "Position estimate lost: altitude control" in b.texts() and b.cmd.status.mode is Mode.ALTCTL
    b = flying(COM_POSCTL_NAVL=1)
    b.sticks = (0.0, 0.0, 0.5, 0.0)
    b.run(0.2)
    b.position_valid = False
    b.run(0.5)
    assert "Position estimate lost: landing" in b.texts() and b.cmd.status.mode is Mode.AUTO_LAND


def test_position_and_height_lost_descends():
    b = flying()
    b.position_valid, b.height_valid = False, False
    b.run(0.1)
    assert "Position estimate lost: descending" in b.texts()
    assert isinstance(b.cmd.task, DescendTask) and b.cmd.status.mode is Mode.AUTO_LAND


def test_attitude_lost_descends_level_just_below_hover_and_lands():
    b = flying()
    b.cmd.hover_thrust_frac = 0.4
    b.attitude_valid = False
    b.run(0.1)
    assert "Attitude estimate lost: descending" in b.texts() and b.count("Attitude estimate lost") == 1
    sp = b.last_sp
    assert isinstance(sp, AttitudeSetpoint)
    np.testing.assert_allclose(sp.q_wxyz, [1.0, 0.0, 0.0, 0.0], atol=1e-9)  # level, heading north
    assert 0.3 < sp.thrust_frac < 0.4
    assert b.cmd.status.mode is Mode.AUTO_LAND and b.cmd.status.landed_state is LandedState.LANDING
    assert b.telemetry().system_status == CRITICAL
    b.run(20.0)  # sinks at 0.5 m/s from 2.5 m, rests, idles: the land detector lands and disarms
    assert not b.cmd.status.armed and "Landing detected" in b.texts()


# --------------------------------------------------------------------------- offboard (tested last)


def test_offboard_loss_switches_to_the_fallback_mode():
    if not hasattr(offboard, "offboard_lost"):
        pytest.skip("autopilot/navigation/offboard.py is still the placeholder (no offboard_lost)")
    b = flying()
    b.offboard_stream = True
    b.run(1.0)
    assert b.set_mode(Mode.OFFBOARD) == ACCEPTED
    b.run(1.0)
    b.offboard_stream = False
    b.run(3.0)
    fallback = offboard.loss_fallback_mode(b.params)
    assert b.count("Offboard control lost") == 1 and b.cmd.status.mode is not Mode.OFFBOARD
    assert b.cmd.status.mode in (fallback, Mode.AUTO_LAND)


# --------------------------------------------------------------------------- the simulator's battery drain


def test_sim_battery_drains_at_the_set_rate_stops_at_the_floor_and_recharges_to_a_raised_floor():
    motors = MotorSettings()
    params = SimParameters(WindSettings(), SensorSettings(), motors)
    assert params.get("SIM_BAT_DRAIN") == 0.0 and params.get("SIM_BAT_MIN_PCT") == 0.0  # the physical model
    params.set("SIM_BAT_DRAIN", 100.0)
    params.set("SIM_BAT_MIN_PCT", 20.0)
    b = Battery()
    for _ in range(250 * 10):  # 10 s at the simulator's 250 Hz, light load
        b.step(50.0, 0.004, motors.battery_drain_s, motors.battery_min_pct / 100.0)
    assert b.remaining_frac == pytest.approx(0.9, abs=1e-6)  # 10 % of the pack in 10 s, whatever the load
    for _ in range(250 * 100):
        b.step(50.0, 0.004, motors.battery_drain_s, motors.battery_min_pct / 100.0)
    assert b.remaining_frac == pytest.approx(0.2, abs=1e-9)  # stopped at SIM_BAT_MIN_PCT
    b.step(50.0, 0.004, 0.0, 0.5)  # the floor raised above the charge: the charge rises to it
    assert b.remaining_frac == pytest.approx(0.5, abs=1e-9)
    physical = Battery()
    physical.step(400.0, 1.0)
    assert physical.remaining_frac == pytest.approx(1.0 - physical.current_a / physical.capacity_as)
