"""The failure detector with nothing running: loss of attitude control, its reaction, the crash check.

A real :class:`Commander` with the real parameter catalogue fed 50 Hz estimates (test_failsafes'
FailBench: a point following its setpoints, whose roll the test sets).  The test reads what a ground
station sees: the STATUSTEXTs, armed or not, and the HEARTBEAT system_status of the telemetry.
"""

from __future__ import annotations

import math

from pymavlink.dialects.v20 import common as mavlink
from test_failsafes import EMERGENCY, FailBench, flying

from mavsim_core.px4_modes import Mode

from test_commander import ACCEPTED

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
