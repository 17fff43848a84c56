"""Entering a mode and arming, decided as pure functions, in tables of situations.

Mode entry (autopilot.commander.mode_requirements.entry_refusal): each row is a situation (what the estimate,
the sticks, the offboard stream, home and the vehicle say) and the mode asked for; what a pilot then sees is
the refusal's STATUSTEXT, or none (the mode is entered).  Arming (autopilot.commander.prearm_checks): the
reasons a ground station lists, and the STATUSTEXT refusing an arming request.  The commander applies both
(tests/test_commander.py, tests/test_manual_modes.py fly them).
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from autopilot.commander.mode_requirements import EstimateValidity, ModeEntryInputs, entry_refusal, input_refusal
from autopilot.commander.prearm_checks import PrearmInputs, arming_refusal, prearm_failures
from autopilot.topics import BatteryState, GpsSample, HomePosition, VehicleEstimate
from mavsim_core.px4_modes import Mode
from mavsim_core.quaternion import from_euler

GOOD = EstimateValidity(attitude=True, position=True, height=True)
NO_POSITION = EstimateValidity(attitude=True, position=False, height=True)
NO_HEIGHT = EstimateValidity(attitude=True, position=False, height=False)
NO_ATTITUDE = EstimateValidity(attitude=False, position=False, height=False)
NO_OFFBOARD = "no offboard setpoints streaming"
# Flying with a good estimate, a home, fresh sticks and an offboard stream.
FLYING = ModeEntryInputs(
    armed=True, in_air=True, estimate=GOOD, has_home=True, manual_age_s=0.1, rc_loss_t_s=0.5, offboard_refusal=None
)


def now(**changes) -> ModeEntryInputs:
    return replace(FLYING, **changes)


ROWS = [
    # (name, mode asked for, situation, refusal said (None: entered))
    ("hold", Mode.AUTO_LOITER, now(), None),
    ("manual mode: not on this vehicle", Mode.MANUAL, now(), "Mode MANUAL not available on this vehicle"),
    ("position mode without a position", Mode.POSCTL, now(estimate=NO_POSITION),
     "Mode POSCTL denied: no position estimate"),
    ("hold without a position", Mode.AUTO_LOITER, now(estimate=NO_POSITION),
     "Mode AUTO.LOITER denied: no position estimate"),
    ("altitude mode on the height alone", Mode.ALTCTL, now(estimate=NO_POSITION), None),
    ("altitude mode without a height", Mode.ALTCTL, now(estimate=NO_HEIGHT), "Mode ALTCTL denied: no height estimate"),
    ("land on the height alone", Mode.AUTO_LAND, now(estimate=NO_POSITION), None),
    ("stabilized on the attitude alone", Mode.STABILIZED, now(estimate=NO_HEIGHT), None),
    ("acro without an attitude", Mode.ACRO, now(estimate=NO_ATTITUDE), "Mode ACRO denied: no attitude estimate"),
    ("no estimate at all", Mode.AUTO_LOITER, now(estimate=None), "Mode AUTO.LOITER denied: no estimate"),
    ("return without home", Mode.AUTO_RTL, now(has_home=False), "Return denied: no home position"),
    ("return", Mode.AUTO_RTL, now(), None),
    ("altitude mode, sticks silent 0.6 s", Mode.ALTCTL, now(manual_age_s=0.6),
     "Mode ALTCTL denied: no manual control input"),
    ("stabilized, never any sticks", Mode.STABILIZED, now(manual_age_s=None),
     "Mode STABILIZED denied: no manual control input"),
    ("position mode without sticks: holds", Mode.POSCTL, now(manual_age_s=None), None),
    ("offboard without a stream", Mode.OFFBOARD, now(offboard_refusal=NO_OFFBOARD),
     f"Mode OFFBOARD denied: {NO_OFFBOARD}"),
    ("offboard with a stream", Mode.OFFBOARD, now(), None),
    ("take-off disarmed", Mode.AUTO_TAKEOFF, now(armed=False, in_air=False), "Takeoff denied: vehicle not armed"),
    ("take-off in the air", Mode.AUTO_TAKEOFF, now(), "Takeoff denied: already flying"),
    ("take-off armed on the ground", Mode.AUTO_TAKEOFF, now(in_air=False), None),
    ("precision landing on the ground", Mode.AUTO_PRECLAND, now(in_air=False),
     "Precision landing denied: vehicle not flying"),
    ("precision landing flying", Mode.AUTO_PRECLAND, now(), None),
    ("follow target disarmed", Mode.AUTO_FOLLOW_TARGET, now(armed=False, in_air=False),
     "Follow target denied: vehicle not flying"),
    ("mission (its plan is checked when it starts)", Mode.AUTO_MISSION, now(), None),
]  # fmt: skip


@pytest.mark.parametrize("name, mode, situation, said", ROWS, ids=[row[0] for row in ROWS])
def test_mode_entry_decision(name, mode, situation, said):
    assert entry_refusal(mode, situation) == said


def test_disarmed_modes_need_their_inputs_too():
    """Disarmed, a mode is accepted for later, but only with its sticks or stream (set_mode's check)."""
    assert input_refusal(Mode.ALTCTL, now(armed=False, manual_age_s=None)) == "no manual control input"
    assert input_refusal(Mode.OFFBOARD, now(armed=False, offboard_refusal=NO_OFFBOARD)) == NO_OFFBOARD
    assert input_refusal(Mode.POSCTL, now(armed=False, manual_age_s=None)) is None


def _estimate(roll_deg: float = 0.0, attitude: bool = True, position: bool = True) -> VehicleEstimate:
    roll = math.radians(roll_deg)
    return VehicleEstimate(
        0, from_euler(roll, 0.0, 0.0), np.zeros(3), np.zeros(3), np.zeros(3), np.zeros(3), attitude, position,
        47.0, 8.0, 500.0, roll_rad=roll,
    )  # fmt: skip


GPS = GpsSample(0, 3, 47.0, 8.0, 500.0, np.zeros(3), 1.0, 1.0, 10)
HOME = HomePosition(47.0, 8.0, 500.0, np.zeros(3), 0.0)
READY = PrearmInputs(_estimate(), GPS, HOME, BatteryState(16.0, 5.0, 0.9), (), 10.0, 0.15)

PREARM_ROWS = [
    # (name, situation, the reasons listed)
    ("ready", READY, []),
    ("no attitude, no position", replace(READY, est=_estimate(attitude=False, position=False)),
     ["attitude estimate not ready", "position estimate not ready"]),
    ("no estimate", replace(READY, est=None), ["attitude estimate not ready", "position estimate not ready"]),
    ("no GPS", replace(READY, gps=None), ["no 3D GPS fix"]),
    ("a 2D fix", replace(READY, gps=replace(GPS, fix_type=2)), ["no 3D GPS fix"]),
    ("the EKF's own", replace(READY, estimator_failures=("Gyro failed: no data",)), ["Gyro failed: no data"]),
    ("no home", replace(READY, home=None), ["home position not set"]),
    ("tilted 20 deg", replace(READY, est=_estimate(roll_deg=20.0)), ["vehicle not level (20 deg)"]),
    ("battery at 10 %", replace(READY, battery=BatteryState(14.0, 5.0, 0.10)), ["battery low (10%)"]),
    ("battery unknown", replace(READY, battery=BatteryState(math.nan, -1.0, -1.0)), []),
    ("terminated", replace(READY, terminated=True), ["flight terminated (reboot to clear)"]),
    ("outside the fence", replace(READY, fence_failures=("vehicle outside the geofence",)),
     ["vehicle outside the geofence"]),
    ("in the order a ground station lists them", replace(READY, gps=None, est=_estimate(roll_deg=20.0),
     battery=BatteryState(14.0, 5.0, 0.10)), ["no 3D GPS fix", "vehicle not level (20 deg)", "battery low (10%)"]),
]  # fmt: skip


@pytest.mark.parametrize("name, situation, reasons", PREARM_ROWS, ids=[row[0] for row in PREARM_ROWS])
def test_prearm_reasons(name, situation, reasons):
    assert prearm_failures(situation) == reasons


@pytest.mark.parametrize(
    "failures, force, has_estimate, said",
    [
        ([], False, True, None),
        (
            ["no 3D GPS fix", "home position not set"],
            False,
            True,
            "Arming denied: no 3D GPS fix; home position not set",
        ),
        (["no 3D GPS fix"], True, True, None),  # forced: armed whatever the checks say
        (["attitude estimate not ready"], True, False, "Arming denied: no sensor data"),  # ... but not blind
        ([], False, False, "Arming denied: no sensor data"),
    ],
)
def test_arming_decision(failures, force, has_estimate, said):
    assert arming_refusal(failures, force, has_estimate) == said
