"""The failure detector with nothing running: loss of attitude control, its reaction, the crash check,
and a thrust loss without a flip.

A real :class:`Commander` with the real parameter catalogue fed 50 Hz estimates (test_failsafes'
FailBench: a point following its setpoints, whose roll the test sets; :class:`MotorOut`: one whose
motor 1 gives nothing, so it sinks upright with that motor's output at its limit, as quad_x does with
the designed gains).  The test reads what a ground station sees: the STATUSTEXTs, armed or not, and
the HEARTBEAT system_status of the telemetry.
"""

from __future__ import annotations

import math

from pymavlink.dialects.v20 import common as mavlink
from test_failsafes import EMERGENCY, FailBench, flying

from autopilot.topics import ActuatorStatus
from mavsim_core.px4_modes import Mode

from test_commander import ACCEPTED, DT_US

WARN = "Critical failure detected (roll): termination disabled (CBRK_FLIGHTTERM)"


def test_roll_beyond_fd_fail_r_for_its_time_is_reported_once_and_the_wreck_disarmed():
    b = flying()  # PX4's defaults: FD_FAIL_R 60 deg for 0.3 s, CBRK_FLIGHTTERM 121212 (warn only)
    b.roll = math.radians(70.0)
    b.run(0.26)
    assert not any("Critical failure" in t for t in b.texts())
    b.run(0.06)
    assert b.texts().count(WARN) == 1
    assert b.cmd.status.armed and b.telemetry().system_status == EMERGENCY
    b.roll = math.pi  # on its back
    b.run(1.9)  # tilted and still (this bench's acceleration is 0) for less than 2 s
    assert b.cmd.status.armed and b.texts().count(WARN) == 1
    b.run(0.2)
    assert not b.cmd.status.armed and b.texts()[-2:] == ["Crash detected: disarming", "Disarmed (crash detected)"]
    assert b.telemetry().system_status == EMERGENCY  # until the next arming


def test_with_flight_termination_enabled_the_motors_stop_at_once():
    b = flying(CBRK_FLIGHTTERM=0)
    b.roll = math.radians(-80.0)
    b.run(0.32)
    texts = b.texts()
    assert "Critical failure detected (roll): terminating" in texts
    assert texts[-1] == "Disarmed (flight termination)" and not b.cmd.status.armed
    assert b.telemetry().system_status == EMERGENCY


def test_a_vehicle_tipping_over_right_after_arming_is_locked_down():
    b = FailBench()
    b.run(1.0)
    assert b.arm() == ACCEPTED
    b.roll = math.radians(90.0)  # COM_LKDOWN_TKO 3 s after arming: lockdown whatever CBRK_FLIGHTTERM
    b.run(0.5)
    assert "Critical failure detected (roll): lockdown" in b.texts()
    assert not b.cmd.status.armed


def test_short_excursions_acro_and_disabled_axes_are_not_failures():
    b = flying()
    for _ in range(5):  # 0.28 s beyond 60 deg, then back: the timer starts again each time
        b.roll = math.radians(75.0)
        b.run(0.28)
        b.roll = 0.0
        b.run(0.2)
    b.roll = math.radians(59.0)  # steep, but within the limit
    b.run(3.0)
    b.params.set("FD_FAIL_R", 0)  # roll not checked
    b.roll = math.pi
    b.run(1.0)
    b.params.set("FD_FAIL_R", 60)
    b.roll = 0.0
    b.sticks = (0.0, 0.0, 0.5, 0.0)
    b.run(0.2)
    assert b.set_mode(Mode.ACRO) == ACCEPTED  # ACRO flips on purpose: PX4 does not check it
    b.roll = math.pi
    b.run(3.0)
    assert not any("Critical failure" in t or "crash" in t for t in b.texts()), b.texts()
    assert b.cmd.status.armed and b.telemetry().system_status == mavlink.MAV_STATE_ACTIVE


# --------------------------------------------------------------------------- thrust loss (no flip)

LOST = "Critical failure detected (thrust loss, likely motor 1): descending at full throttle"


class MotorOut(FailBench):
    """Motor 1 gives nothing from :attr:`lost` on: the vehicle sinks at ``sink_m_s`` (0: it holds its height, as
    a hexacopter can) whatever the setpoint, motor 1's output at the limit and its opposite at idle."""

    def __init__(self) -> None:
        super().__init__()
        self.lost = False
        self.sink_m_s = 2.0
        self.outputs = (1.0, 0.0, 0.7, 0.7)
        self.throttle = 0.6  # collective thrust, fraction of the maximum

    def _thrust(self) -> ActuatorStatus:
        if not (self.lost and self.cmd.status.armed):
            return super()._thrust()
        return ActuatorStatus(self.t_us, self.outputs, 0.0, self.throttle, 2.0 * self.throttle)

    def _follow(self, sp) -> None:
        if not (self.lost and self.cmd.status.armed):
            super()._follow(sp)
            return
        old = self.pos.copy()
        self.pos[2] = min(self.pos[2] + self.sink_m_s * DT_US * 1e-6, 0.0)
        self.vel = (self.pos - old) / (DT_US * 1e-6)


def motor_out(**params: float) -> MotorOut:
    b = MotorOut()
    for name, value in params.items():
        b.params.set(name, value)
    b.fly_up()
    return b


def test_a_motor_lost_without_a_flip_is_reported_after_a_second_and_disarmed_still_on_the_ground():
    b = motor_out()
    b.lost = True
    b.run(0.98)  # sinking at full throttle, level, for less than ArduPilot's 1 s
    assert not any("Critical failure" in t for t in b.texts())
    b.run(0.06)
    assert b.texts().count(LOST) == 1 and b.cmd.status.armed
    assert b.telemetry().system_status == EMERGENCY
    b.run(0.3)  # 2.5 m at 2 m/s: on the ground; still for less than 2 s
    assert b.pos[2] == 0.0 and b.cmd.status.armed and b.cmd.status.in_air  # (the land detector waits for low thrust)
    b.run(2.0)
    assert not b.cmd.status.armed
    assert b.texts()[-2:] == ["Crash detected: disarming", "Disarmed (crash detected)"]
    assert b.texts().count(LOST) == 1 and b.telemetry().system_status == EMERGENCY  # until the next arming


def test_a_fall_too_short_for_the_check_ends_stuck_on_the_ground_and_that_is_reported_and_disarmed():
    """A fall from 2.5 m whose lean passed 45 deg for a moment (the timer starts again) lands before the 1 s of
    the check: on the ground, upright, a motor at its limit and the position controller asking for a climb, it
    is a thrust loss too (seed 111 of the end-to-end motor loss: the motors ran on at full throttle)."""
    b = motor_out()
    b.lost = True
    b.cmd.vel_sp_down_m_s = -3.0  # the position controller asks to climb back (as it does in a fall)
    b.run(0.8)
    b.roll = math.radians(50.0)
    b.run(0.1)
    b.roll = 0.0
    b.run(0.5)
    assert b.pos[2] == 0.0 and not any("Critical failure" in t for t in b.texts()), b.texts()
    assert b.cmd.status.armed and b.cmd.status.in_air  # (the land detector waits for low thrust)
    b.run(1.0)
    stuck = "Critical failure detected (thrust loss, likely motor 1): on the ground at full throttle"
    assert b.texts().count(stuck) == 1 and b.cmd.status.armed
    b.run(1.05)
    assert not b.cmd.status.armed
    assert b.texts()[-2:] == ["Crash detected: disarming", "Disarmed (crash detected)"]


def test_a_vehicle_that_lost_thrust_but_holds_its_height_is_reported_and_not_disarmed_in_the_air():
    b = motor_out()
    b.lost, b.sink_m_s = True, 0.5
    b.run(1.1)
    assert b.texts().count(LOST) == 1
    b.sink_m_s = 0.0  # the other motors carry it (a hexacopter): still, but 1.9 m up
    b.run(5.0)
    assert b.cmd.status.armed and b.pos[2] < -1.0 and not any("Crash" in t for t in b.texts())


def test_a_descent_the_controller_asks_for_is_no_thrust_loss_but_sinking_faster_than_asked_is():
    b = motor_out()
    b.lost, b.sink_m_s = True, 1.0  # a go-to down at 1.1 m/s while yawing: a motor at its limit, 10 deg lean
    b.roll = math.radians(10.0)
    b.cmd.vel_sp_down_m_s = 1.1
    b.run(1.2)
    assert not any("Critical failure" in t for t in b.texts()), b.texts()
    b.cmd.vel_sp_down_m_s = 0.3  # asked to slow down (a landing's last metre), still sinking at 1 m/s: lost
    b.run(1.1)
    assert b.texts().count(LOST) == 1


def test_no_thrust_loss_while_climbing_holding_tilted_short_unsaturated_in_acro_or_without_the_crash_check():
    b = motor_out()
    b.lost, b.sink_m_s = True, -1.0  # climbing at full throttle: a hard climb, not a loss
    b.run(2.0)
    b.sink_m_s = 0.0
    b.run(2.0)
    b.sink_m_s, b.roll = 1.0, math.radians(50.0)  # sinking but tilted beyond 45 deg: the attitude checks' case
    b.run(1.5)
    b.sink_m_s, b.roll = 0.4, math.radians(22.0)  # braking at 4 m/s^2 with a motor at its limit: manoeuvring
    b.run(1.5)
    b.sink_m_s, b.roll = 0.15, 0.0  # level, a motor at its limit (a yaw), the height dipping a little
    b.run(1.5)
    b.roll, b.sink_m_s = 0.0, 2.0
    for _ in range(3):  # sinking at full throttle, 0.9 s at a time
        b.run(0.9)
        b.sink_m_s = -2.0
        b.run(0.9)
        b.sink_m_s = 2.0
    b.outputs, b.sink_m_s = (0.9, 0.5, 0.7, 0.7), 0.5  # sinking, but no motor at its limit
    b.run(1.5)
    b.outputs, b.throttle = (1.0, 0.0, 0.0, 0.0), 0.2  # a motor at its limit, but a low throttle asked
    b.run(1.5)
    assert not any("Critical failure" in t for t in b.texts()), b.texts()
    assert b.pos[2] < -0.5, "in the air"
    b.sticks = (0.0, 0.0, 0.5, 0.0)
    b.run(0.2)
    assert b.set_mode(Mode.ACRO) == ACCEPTED  # the attitude not controlled: not checked (as FD_FAIL_*)
    b.outputs, b.throttle = (1.0, 0.0, 0.7, 0.7), 0.6
    b.run(1.5)
    assert not any("Critical failure" in t for t in b.texts()), b.texts()
    c = motor_out(FS_CRASH_CHECK=0)
    c.lost = True
    c.run(6.0)  # reported, on the ground, but the crash check is off: the pilot disarms
    assert c.texts().count(LOST) == 1 and c.cmd.status.armed and c.pos[2] == 0.0
