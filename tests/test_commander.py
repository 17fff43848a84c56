"""The commander with nothing running: arming, modes, take-off, reposition, auto-disarm.

A real :class:`Commander` with the real parameter catalogue is fed 50 Hz estimates of
a point that goes exactly where the setpoint says (no physics: the ground is at down
= 0 m and holds the point up).  Commands go through the MAVLink command table
(:mod:`autopilot.mavlink.commands`) as a ground station's COMMAND_LONG would, and the
test reads what a ground station sees: the MAV_RESULT of the COMMAND_ACK, the
STATUSTEXTs and the published :class:`CommanderStatus` (armed, mode, landed state).
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink

from autopilot.commander import Commander
from autopilot.mavlink import commands
from autopilot.param_catalogue import default_store
from autopilot.topics import (
    ActuatorStatus,
    AttitudeSetpoint,
    BatteryState,
    BatteryWarning,
    GpsSample,
    LandedState,
    VehicleEstimate,
)
from mavsim_core.geodesy import ned_to_geodetic
from mavsim_core.px4_modes import Mode
from mavsim_core.quaternion import from_euler

ORIGIN = (47.397742, 8.545594, 488.0)  # estimator origin: lat, lon deg, alt AMSL m (home is here)
DT_US = 20_000  # the commander's 50 Hz
GPS = GpsSample(0, 3, ORIGIN[0], ORIGIN[1], ORIGIN[2], np.zeros(3), 0.8, 1.2, 12)
ACCEPTED, DENIED, UNSUPPORTED = mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_DENIED, mavlink.MAV_RESULT_UNSUPPORTED
NAN7 = (math.nan,) * 7


class Bench:
    """A commander and a point that follows its position setpoint (velocity where the position is NaN)."""

    def __init__(self) -> None:
        self.params = default_store()
        self.cmd = Commander(self.params, "QUADROTOR")
        self.t_us = 0
        self.pos = np.zeros(3)
        self.vel = np.zeros(3)
        self.roll = 0.0
        self.attitude_valid = True
        self.position_valid = True
        self.gps: GpsSample | None = GPS
        self.events: list[tuple[float, str]] = []  # (simulated s, STATUSTEXT)

    def run(self, seconds: float) -> None:
        for _ in range(round(seconds * 1e6 / DT_US)):
            self.t_us += DT_US
            est = VehicleEstimate(
                timestamp_us=self.t_us, q_wxyz=from_euler(self.roll, 0.0, 0.0), rate_frd_rad_s=np.zeros(3),
                accel_ned_m_s2=np.zeros(3), pos_ned_m=self.pos.copy(), vel_ned_m_s=self.vel.copy(),
                attitude_valid=self.attitude_valid, position_valid=self.position_valid,
                origin_lat_deg=ORIGIN[0], origin_lon_deg=ORIGIN[1], origin_alt_amsl_m=ORIGIN[2],
                roll_rad=self.roll,
            )  # fmt: skip
            sp = self.cmd.update(self.t_us, est, self.gps, self.gps is not None, self._thrust())
            self._follow(sp)
            self.drain()

    def _thrust(self) -> ActuatorStatus:
        """Carrying the weight in the air or climbing; resting on the ground otherwise."""
        sp = self.cmd.status.position_setpoint_ned_m
        on_ground = self.pos[2] >= 0.0
        climbing = sp is not None and math.isfinite(sp[2]) and sp[2] < -0.01
        frac = 1.0 if self.cmd.status.armed and (not on_ground or climbing) else 0.3
        return ActuatorStatus(self.t_us, (frac * 0.5,) * 4, 0.0, frac * 0.5, frac)  # hover at half the range

    def _follow(self, sp) -> None:
        old = self.pos.copy()
        if sp is not None:
            target = np.where(np.isfinite(sp.pos_ned_m), sp.pos_ned_m, self.pos + sp.vel_ned_m_s * DT_US * 1e-6)
            self.pos = target.astype(float)
        self.pos[2] = min(self.pos[2], 0.0)  # the ground
        self.vel = (self.pos - old) / (DT_US * 1e-6)

    def drain(self) -> None:
        self.events += [(self.t_us * 1e-6, text) for _, text in self.cmd.pop_events()]

    def texts(self) -> list[str]:
        return [text for _, text in self.events]

    def command(self, command: int, *params: float) -> int:
        """A COMMAND_LONG through the command table; its MAV_RESULT."""
        p = tuple(params) + (0.0,) * (7 - len(params))
        result = commands.handle_vehicle_command(self.cmd, command, p, mavlink.MAV_FRAME_GLOBAL)
        self.drain()
        return result

    def set_mode(self, mode: Mode) -> int:
        result = self.cmd.set_mode(mode)
        self.drain()
        return result

    def arm(self, force: bool = False) -> int:
        return self.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1, commands.FORCE_MAGIC if force else 0)

    def disarm(self, force: bool = False) -> int:
        return self.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, commands.FORCE_MAGIC if force else 0)

    def takeoff(self, alt_amsl_m: float = math.nan) -> int:
        return self.command(mavlink.MAV_CMD_NAV_TAKEOFF, *NAN7[:6], alt_amsl_m)

    def fly_up(self) -> None:
        """Ready, armed, taken off to MIS_TAKEOFF_ALT and holding."""
        self.run(1.0)
        assert self.arm() == ACCEPTED
        assert self.takeoff() == ACCEPTED
        self.run(6.0)
        assert "Takeoff complete: holding" in self.texts()
        assert self.cmd.status.in_air and self.cmd.status.mode is Mode.AUTO_LOITER


# --------------------------------------------------------------------------- arming


def test_arming_refused_with_every_reason_before_any_data():
    b = Bench()
    assert b.arm() == DENIED
    assert b.texts() == [
        "Arming denied: attitude estimate not ready; no 3D GPS fix; position estimate not ready; home position not set"
    ]
    assert not b.cmd.status.armed
    assert b.arm(force=True) == DENIED  # even forced: nothing to fly on
    assert b.texts()[-1] == "Arming denied: no sensor data"


def test_arming_refused_tilted_no_gps_low_battery_and_forced():
    b = Bench()
    b.gps = None
    b.roll = math.radians(20.0)
    b.cmd.set_battery(BatteryState(14.8, 1.0, 0.10))
    b.run(0.5)
    assert b.cmd.status.prearm_failures == ("no 3D GPS fix", "vehicle not level (20 deg)", "battery low (10%)")
    assert b.arm() == DENIED
    assert b.texts()[-1] == "Arming denied: no 3D GPS fix; vehicle not level (20 deg); battery low (10%)"
    assert b.cmd.status.battery_warning is BatteryWarning.LOW
    # BAT_LOW_THR is the pre-arm threshold
    b.params.set("BAT_LOW_THR", 0.12)  # PX4's minimum
    b.cmd.set_battery(BatteryState(14.8, 1.0, 0.13))
    assert "battery low (13%)" not in b.cmd.status.prearm_failures
    # force: armed whatever the checks say
    assert b.arm(force=True) == ACCEPTED
    assert b.cmd.status.armed and b.texts()[-1] == "Armed"


def test_arm_and_disarm():
    b = Bench()
    b.run(0.5)
    assert b.texts()[0].startswith("Home set: 47.3977420, 8.5455940, 488.0 m")
    assert b.cmd.status.home is not None and b.cmd.status.prearm_failures == ()
    assert b.arm() == ACCEPTED
    st = b.cmd.status
    assert st.armed and st.mode is Mode.POSCTL and st.landed_state is LandedState.ON_GROUND
    assert b.texts()[-1] == "Armed"
    assert b.arm() == ACCEPTED  # already armed: accepted, nothing said
    assert b.texts().count("Armed") == 1
    assert b.disarm() == ACCEPTED
    assert not b.cmd.status.armed and b.texts()[-1] == "Disarmed (command)"
    assert b.disarm() == ACCEPTED  # already disarmed


def test_disarm_in_air_refused_unless_forced():
    b = Bench()
    b.fly_up()
    assert b.disarm() == DENIED
    assert b.texts()[-1] == "Disarm denied: vehicle in air (land first or force)"
    assert b.cmd.status.armed
    assert b.disarm(force=True) == ACCEPTED
    assert not b.cmd.status.armed and b.texts()[-1] == "Disarmed (command)"


# --------------------------------------------------------------------------- modes


def test_mode_changes_on_the_ground():
    b = Bench()
    b.run(0.5)
    assert b.set_mode(Mode.AUTO_RTL) == ACCEPTED  # disarmed: accepted, acts once armed (as PX4)
    assert b.cmd.status.mode is Mode.AUTO_RTL and b.texts()[-1] == "Mode AUTO.RTL"
    assert b.set_mode(Mode.MANUAL) == DENIED
    assert b.texts()[-1] == "Mode MANUAL not available on this vehicle"
    assert b.set_mode(Mode.OFFBOARD) == DENIED  # no setpoints streaming (PX4's rule, armed or not)
    assert b.texts()[-1].startswith("Mode OFFBOARD denied: ")
    assert b.set_mode(Mode.STABILIZED) == DENIED
    assert b.texts()[-1] == "Mode STABILIZED denied: no manual control input"
    assert b.cmd.status.mode is Mode.AUTO_RTL
    # DO_SET_MODE: base mode, PX4 main mode, sub mode
    assert b.command(mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 4, 3) == ACCEPTED
    assert b.cmd.status.mode is Mode.AUTO_LOITER
    assert b.command(mavlink.MAV_CMD_DO_SET_MODE, 0, 3) == DENIED
    assert b.texts()[-1] == "Mode change denied: only custom (PX4) modes are supported"
    assert b.command(mavlink.MAV_CMD_DO_SET_MODE, 1, 9, 0) == DENIED
    assert b.texts()[-1] == "Mode change denied: unknown custom mode 0x90000"
    assert b.cmd.status.mode is Mode.AUTO_LOITER
    # armed in AUTO.TAKEOFF: it takes off at once
    assert b.set_mode(Mode.AUTO_TAKEOFF) == ACCEPTED
    assert b.arm() == ACCEPTED
    assert b.texts()[-2:] == ["Armed", "Taking off to 2.5 m above home"]
    assert b.cmd.status.landed_state is LandedState.TAKEOFF


def test_mode_changes_armed_need_a_position_and_land_is_landing():
    b = Bench()
    b.fly_up()
    assert b.command(mavlink.MAV_CMD_NAV_LAND) == ACCEPTED
    assert b.cmd.status.mode is Mode.AUTO_LAND and b.texts()[-1] == "Mode AUTO.LAND"
    b.run(0.1)
    assert b.cmd.status.landed_state is LandedState.LANDING
    assert b.set_mode(Mode.AUTO_LAND) == ACCEPTED  # the same mode: nothing changes
    b.position_valid = False
    b.run(0.1)
    assert b.set_mode(Mode.POSCTL) == DENIED
    assert b.texts()[-1] == "Mode POSCTL denied: no position estimate"
    assert b.command(mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH) == DENIED
    assert b.cmd.status.mode is Mode.AUTO_LAND


def test_land_and_return_refused_on_the_ground_disarmed():
    b = Bench()
    b.run(0.5)
    assert b.command(mavlink.MAV_CMD_NAV_LAND) == DENIED
    assert b.texts()[-1] == "Land denied: vehicle not armed"
    assert b.command(mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH) == DENIED
    assert b.texts()[-1] == "Return denied: vehicle not armed"


# --------------------------------------------------------------------------- auto-disarm


def test_auto_disarm_after_landing():
    b = Bench()
    b.fly_up()
    assert b.command(mavlink.MAV_CMD_NAV_LAND) == ACCEPTED
    b.run(12.0)
    times = {text: t for t, text in b.events}
    assert "Landing detected" in times and "Disarmed (landed)" in times
    assert times["Disarmed (landed)"] - times["Landing detected"] == pytest.approx(
        b.params.get("COM_DISARM_LAND"), abs=0.021
    )
    st = b.cmd.status
    assert not st.armed and st.landed_state is LandedState.ON_GROUND and not st.in_air
    assert b.pos[2] == 0.0


def test_auto_disarm_when_no_takeoff_follows_arming():
    b = Bench()
    b.run(0.5)
    armed_at = b.t_us * 1e-6
    assert b.arm() == ACCEPTED
    b.run(12.0)
    (t,) = [t for t, text in b.events if text == "Disarmed (no takeoff)"]
    assert t - armed_at == pytest.approx(b.params.get("COM_DISARM_PRFLT"), abs=0.021)
    assert not b.cmd.status.armed


# --------------------------------------------------------------------------- take-off


@pytest.mark.parametrize(
    "alt_amsl_m, above_home_m, note",
    [
        (math.nan, 2.5, None),  # not given: MIS_TAKEOFF_ALT
        (498.0, 10.0, None),  # AMSL
        (488.3, 1.0, None),  # at least 1 m
        (5.0, 5.0, "Takeoff altitude 5 m is below home: using 5 m above home"),  # MAVProxy's "takeoff 5"
    ],
)
def test_takeoff_altitude_rules(alt_amsl_m, above_home_m, note):
    b = Bench()
    b.run(0.5)
    assert b.arm() == ACCEPTED
    before = len(b.events)
    assert b.takeoff(alt_amsl_m) == ACCEPTED
    said = b.texts()[before:]
    assert said == ([note] if note else []) + [f"Taking off to {above_home_m:.1f} m above home", "Mode AUTO.TAKEOFF"]
    assert b.cmd.status.mode is Mode.AUTO_TAKEOFF and b.cmd.status.landed_state is LandedState.TAKEOFF
    b.run(above_home_m / b.params.get("MPC_TKO_SPEED") + 3.0)
    assert "Takeoff complete: holding" in b.texts()
    assert b.cmd.status.mode is Mode.AUTO_LOITER
    assert -b.pos[2] == pytest.approx(above_home_m, abs=1e-6)


def test_takeoff_refused():
    b = Bench()
    assert b.takeoff() == DENIED
    assert b.texts()[-1] == "Takeoff denied: no home position"
    b.run(0.5)
    assert b.takeoff() == DENIED
    assert b.texts()[-1] == "Takeoff denied: vehicle not armed"
    b.fly_up()
    assert b.takeoff() == DENIED
    assert b.texts()[-1] == "Takeoff denied: already flying"


# --------------------------------------------------------------------------- reposition


def test_reposition():
    b = Bench()
    b.run(0.5)
    assert b.command(mavlink.MAV_CMD_DO_REPOSITION, -1, 0, 0, math.nan, *ORIGIN) == DENIED
    assert b.texts()[-1] == "Reposition denied: vehicle not flying"
    b.fly_up()
    lat, lon, _ = ned_to_geodetic([10.0, 5.0, 0.0], *ORIGIN)
    # speed -1 (cruise), yaw NaN (keep), lat/lon of 10 m north 5 m east, 4 m above the origin
    assert b.command(mavlink.MAV_CMD_DO_REPOSITION, -1, 0, 0, math.nan, lat, lon, ORIGIN[2] + 4.0) == ACCEPTED
    assert b.cmd.status.mode is Mode.AUTO_LOITER
    b.run(15.0)
    np.testing.assert_allclose(b.pos, [10.0, 5.0, -4.0], atol=1e-6)
    # lat/lon not given (NaN) and altitude not given: stay here
    assert b.command(mavlink.MAV_CMD_DO_REPOSITION, 2.0, 0, 0, math.pi / 2, math.nan, math.nan, math.nan) == ACCEPTED
    b.run(3.0)
    np.testing.assert_allclose(b.pos, [10.0, 5.0, -4.0], atol=1e-6)
    assert b.cmd.setpoint.yaw_rad == pytest.approx(math.pi / 2)  # param4 is yaw in radians (east)
    assert b.command(mavlink.MAV_CMD_DO_REPOSITION, -1, 0, 0, math.nan, 95.0, lon, math.nan) == DENIED
    assert b.texts()[-1] == "Reposition denied: latitude/longitude 95, 8.54566 out of range"
    far_lat, far_lon, _ = ned_to_geodetic([1500.0, 0.0, 0.0], *ORIGIN)
    assert b.command(mavlink.MAV_CMD_DO_REPOSITION, -1, 0, 0, math.nan, far_lat, far_lon, math.nan) == DENIED
    assert b.texts()[-1] == "Reposition denied: target more than 1 km away"
    b.position_valid = False
    b.run(0.02)
    b.drain()
    assert b.command(mavlink.MAV_CMD_DO_REPOSITION, -1, 0, 0, math.nan, lat, lon, math.nan) == DENIED
    assert b.texts()[-1] == "Reposition denied: no position estimate"


def test_a_reposition_or_a_speed_change_while_an_attitude_is_flown_starts_from_the_estimate():
    """The setpoint flown may be an attitude (a stick mode, the descend failsafe, a precision landing's touchdown):
    DO_REPOSITION and DO_CHANGE_SPEED then start from where the vehicle is (they read a position setpoint's
    position, velocity and acceleration, which an attitude setpoint has not)."""
    b = Bench()
    b.fly_up()
    here = b.pos.copy()
    b.cmd.setpoint = AttitudeSetpoint(np.array([1.0, 0.0, 0.0, 0.0]), None, 0.3)
    lat, lon, _ = ned_to_geodetic([6.0, -3.0, 0.0], *ORIGIN)
    assert b.command(mavlink.MAV_CMD_DO_REPOSITION, -1, 0, 0, math.nan, lat, lon, math.nan) == ACCEPTED
    b.cmd.setpoint = AttitudeSetpoint(np.array([1.0, 0.0, 0.0, 0.0]), None, 0.3)
    assert b.command(mavlink.MAV_CMD_DO_CHANGE_SPEED, 1, 2.0, -1) == ACCEPTED
    b.run(15.0)
    np.testing.assert_allclose(b.pos, [6.0, -3.0, here[2]], atol=1e-6)


def test_a_reposition_sent_as_the_take_off_brakes_keeps_its_height():
    # MAVSDK's goto_location (Hold, then DO_REPOSITION in one go) as the take-off's climb brakes: the move
    # starts from the take-off's setpoint, once with too small a share of the limits for the vertical axis
    # to end the braking: a flight controller took it down 4.9 m to the ground at 1.1 m/s.
    b = Bench()
    b.run(1.0)
    assert b.arm() == ACCEPTED and b.takeoff() == ACCEPTED
    b.run(3.0)  # braking the climb (NED: accelerating down) ...
    while b.cmd.setpoint.vel_ned_m_s[2] < -0.15:  # ... to its last 0.15 m/s
        b.run(0.02)
    assert b.cmd.setpoint.acc_ned_m_s2[2] > 0.9
    top = float(b.pos[2])
    lat, lon, _ = ned_to_geodetic([15.0, 0.0, 0.0], *ORIGIN)
    alt = ORIGIN[2] - top
    assert b.set_mode(Mode.AUTO_LOITER) == ACCEPTED
    assert b.command(mavlink.MAV_CMD_DO_REPOSITION, -1, 0, 0, math.pi / 2, lat, lon, alt) == ACCEPTED
    heights = []
    for _ in range(400):
        b.run(0.02)
        heights.append(float(b.pos[2]))
    assert max(heights) - top < 0.1 and top - min(heights) < 0.1, (top, min(heights), max(heights))
    np.testing.assert_allclose(b.pos, [15.0, 0.0, top], atol=1e-6)


# --------------------------------------------------------------------------- status record


def test_status_is_a_frozen_record_published_on_every_change():
    b = Bench()
    b.run(0.1)
    before = b.cmd.status
    with pytest.raises(AttributeError):
        before.armed = True  # type: ignore[misc]
    assert b.arm() == ACCEPTED
    assert b.cmd.status is not before and b.cmd.status.armed and not before.armed
    b.cmd.set_battery(BatteryState(13.0, 2.0, 0.04, 4, 2000.0))
    assert b.cmd.status.battery.remaining_frac == 0.04
    assert b.cmd.status.battery_warning is BatteryWarning.EMERGENCY
