"""The failure detector's decision (autopilot.commander.failure_detector.FailureDetector.step), in a table.

Each row holds one situation for a while (an attitude, the motors' outputs, a sink rate, the mode and the time
since arming, the parameters), fed at 250 Hz as frozen FailureInputs, and says what a pilot then sees: the
STATUSTEXTs, whether the motors are stopped (and why), and whether HEARTBEAT shows a critical failure.  The
commander applies the decision (tests/test_failure_detector.py flies it).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from autopilot.commander.failure_detector import (
    CBRK_FLIGHTTERM_KEY,
    FailureDetector,
    FailureInputs,
    FailureParams,
    StopMotors,
)
from autopilot.topics import NO_ACTUATORS, ActuatorStatus, VehicleEstimate
from mavsim_core.px4_modes import Mode
from mavsim_core.quaternion import from_euler

DT_US = 4_000
# PX4's defaults: 60 degrees for 0.3 s, termination disabled by the circuit breaker, lockdown 3 s after arming
DEFAULTS = FailureParams(60, 60, 0.3, 0.3, CBRK_FLIGHTTERM_KEY, 3.0, 1, 0.5, 1.5)
LEVEL = dict(roll_deg=0.0, pitch_deg=0.0, vel_down=0.0, accel=(0.0, 0.0, 0.0), down_m=-10.0)
FULL = ActuatorStatus(0, (1.0, 0.6, 1.0, 0.6), 30.0, 0.8, 1.6)  # motors 1 and 3 at their limit


def estimate(roll_deg, pitch_deg, vel_down, accel, down_m) -> VehicleEstimate:
    roll, pitch = math.radians(roll_deg), math.radians(pitch_deg)
    return VehicleEstimate(
        0, from_euler(roll, pitch, 0.0), np.zeros(3), np.array(accel, float), np.array([0.0, 0.0, down_m]),
        np.array([0.0, 0.0, vel_down]), True, True, 47.0, 8.0, 500.0, roll_rad=roll, pitch_rad=pitch,
    )  # fmt: skip


def hold(
    seconds: float,
    params: dict | None = None,
    armed_s: float = 10.0,
    mode: Mode = Mode.POSCTL,
    actuators: ActuatorStatus = NO_ACTUATORS,
    vel_sp_down: float = math.nan,
    **attitude,
):
    """Feed one situation for ``seconds`` (armed ``armed_s`` before it): the steps said/done, the last
    critical flag."""  # fmt: skip
    detector, p = FailureDetector(), replace(DEFAULTS, **(params or {}))
    est = estimate(**{**LEVEL, **attitude})
    steps, critical, armed = [], False, True
    for k in range(round(seconds * 1e6 / DT_US)):
        now = int(armed_s * 1e6) + k * DT_US
        inputs = FailureInputs(now, armed, 0, True, mode, est, actuators, vel_sp_down, 0.0, p)
        decision = detector.step(inputs)
        steps += decision.steps
        critical = decision.critical_failure
        armed = armed and not any(isinstance(s, StopMotors) for s in decision.steps)
    return [s if isinstance(s, StopMotors) else s[1] for s in steps], critical


ROLL = "Critical failure detected (roll)"
# (name, situation, what is said and done, critical failure at the end)
ROWS = [
    ("level flight", dict(seconds=2.0), [], False),
    ("rolled 70 deg for 0.2 s: not yet", dict(seconds=0.2, roll_deg=70.0), [], False),
    ("rolled 70 deg for 0.5 s, breaker in: warn only", dict(seconds=0.5, roll_deg=70.0),
     [f"{ROLL}: termination disabled (CBRK_FLIGHTTERM)"], True),
    ("pitched 70 deg: the pitch axis", dict(seconds=0.5, pitch_deg=-70.0),
     ["Critical failure detected (pitch): termination disabled (CBRK_FLIGHTTERM)"], True),
    ("rolled 70 deg, breaker out: terminate", dict(seconds=0.5, roll_deg=70.0, params={"flightterm_breaker": 0}),
     [f"{ROLL}: terminating", StopMotors("flight termination")], False),
    ("rolled 70 deg 1 s after arming: lockdown", dict(seconds=0.5, roll_deg=70.0, armed_s=1.0),
     [f"{ROLL}: lockdown", StopMotors("lockdown")], False),
    ("rolled 70 deg 1 s after arming, COM_LKDOWN_TKO 0: warn", dict(seconds=0.5, roll_deg=70.0, armed_s=1.0,
     params={"lockdown_s": 0.0}), [f"{ROLL}: termination disabled (CBRK_FLIGHTTERM)"], True),
    ("rolled 70 deg, FD_FAIL_R 0: roll not checked", dict(seconds=1.0, roll_deg=70.0, params={"fail_r_deg": 0}),
     [], False),
    ("rolled 70 deg in ACRO: not checked", dict(seconds=1.0, roll_deg=70.0, mode=Mode.ACRO), [], False),
    ("on its back, still, 3 s: crash", dict(seconds=3.0, roll_deg=180.0),
     [f"{ROLL}: termination disabled (CBRK_FLIGHTTERM)", "Crash detected: disarming", StopMotors("crash detected")],
     False),  # (disarmed since)
    ("on its back, FS_CRASH_CHECK 0: no crash check", dict(seconds=3.0, roll_deg=180.0, params={"crash_check": 0}),
     [f"{ROLL}: termination disabled (CBRK_FLIGHTTERM)"], True),
    ("on its back, tumbling (not still): no crash", dict(seconds=3.0, roll_deg=180.0, accel=(5.0, 0.0, 0.0)),
     [f"{ROLL}: termination disabled (CBRK_FLIGHTTERM)"], True),
    ("sinking level at full throttle for 1.2 s: thrust loss", dict(seconds=1.2, vel_down=1.0, actuators=FULL),
     ["Critical failure detected (thrust loss, likely motor 1): descending at full throttle"], True),
    ("sinking level at full throttle for 0.8 s: not yet", dict(seconds=0.8, vel_down=1.0, actuators=FULL), [], False),
    ("sinking as asked at full throttle: no loss", dict(seconds=1.5, vel_down=1.0, actuators=FULL, vel_sp_down=1.0),
     [], False),
    ("full throttle on the ground, climb asked: stuck, then grounded", dict(seconds=3.5, down_m=0.0, actuators=FULL,
     vel_sp_down=-1.0), ["Critical failure detected (thrust loss, likely motor 1): on the ground at full throttle",
                         "Crash detected: disarming", StopMotors("crash detected")], False),
]  # fmt: skip


@pytest.mark.parametrize("name, situation, said, critical", ROWS, ids=[row[0] for row in ROWS])
def test_failure_decision(name, situation, said, critical):
    got, got_critical = hold(**situation)
    assert got == said
    assert got_critical is critical


def test_disarmed_everything_clears():
    detector = FailureDetector()
    est = estimate(**{**LEVEL, "roll_deg": 70.0})
    for k in range(150):
        detector.step(FailureInputs(k * DT_US, True, 0, True, Mode.POSCTL, est, NO_ACTUATORS, math.nan, 0.0, DEFAULTS))
    assert detector.lost_control
    decision = detector.step(FailureInputs(0, False, 0, True, Mode.POSCTL, est, NO_ACTUATORS, math.nan, 0.0, DEFAULTS))
    assert decision.steps == () and not decision.critical_failure and not detector.lost_control
