"""The failsafes' decision as a pure function (autopilot.commander.failsafes.decide), in tables of situations.

Each row is a situation (what the estimate, the links, the battery and the mode say, the parameters, and what
was reported before) and what a pilot would then see: the STATUSTEXTs said, the alarm raised (its words and the
action it asks for), and whether it is remembered, so that it is not raised twice.  The commander applies the
decision (tests/test_failsafes.py flies it).
"""

from __future__ import annotations

from dataclasses import replace

import pytest
from pymavlink.dialects.v20 import common as mavlink

from autopilot.commander.failsafes import (
    DESCEND,
    TERMINATE,
    FailsafeInputs,
    FailsafeMemory,
    FailsafeParams,
    already_flown,
    decide,
    fallback_chain,
)
from autopilot.commander.mode_requirements import EstimateValidity
from autopilot.topics import BatteryWarning
from mavsim_core.px4_modes import Mode

INFO, WARNING = mavlink.MAV_SEVERITY_INFO, mavlink.MAV_SEVERITY_WARNING
CRITICAL, EMERGENCY = mavlink.MAV_SEVERITY_CRITICAL, mavlink.MAV_SEVERITY_EMERGENCY
GOOD = EstimateValidity(attitude=True, position=True, height=True)
NO_POSITION = EstimateValidity(attitude=True, position=False, height=True)
NO_HEIGHT = EstimateValidity(attitude=True, position=False, height=False)
NO_ATTITUDE = EstimateValidity(attitude=False, position=True, height=True)
# PX4's defaults: RC loss 0.5 s -> Return, data link loss 10 s -> report only, battery -> warn only
DEFAULTS = FailsafeParams(0.5, 2, 0, 10.0, 0, 0, 0, Mode.POSCTL)
# Flying in AUTO.LOITER with a good estimate, sticks and a ground station fresh, a full battery.
FLYING = FailsafeInputs(
    armed=True, in_air=True, mode=Mode.AUTO_LOITER, estimate=GOOD, manual_age_s=0.1, gcs_age_s=1.0,
    offboard_lost=False, battery_frac=0.8, battery_level=BatteryWarning.NONE, params=DEFAULTS,
)  # fmt: skip
QUIET = FailsafeMemory()


def situation(params: dict | None = None, **now) -> FailsafeInputs:
    return replace(FLYING, params=replace(DEFAULTS, **(params or {})), **now)


# (name, situation, memory before, alarm expected: (severity, words, action) or None, texts said, memory after)
ROWS = [
    ("all well", situation(), QUIET, None, (), QUIET),
    # -- data link (NAV_DLL_ACT, COM_DL_LOSS_T)
    ("data link lost, default: report only", situation(gcs_age_s=10.5), QUIET,
     (CRITICAL, "Data link lost", None), (), FailsafeMemory(gcs_lost=True)),
    ("data link lost, NAV_DLL_ACT 2: return", situation({"dll_act": 2}, gcs_age_s=10.5), QUIET,
     (CRITICAL, "Data link lost", Mode.AUTO_RTL), (), FailsafeMemory(gcs_lost=True)),
    ("data link lost, NAV_DLL_ACT 3: land", situation({"dll_act": 3}, gcs_age_s=11.0), QUIET,
     (CRITICAL, "Data link lost", Mode.AUTO_LAND), (), FailsafeMemory(gcs_lost=True)),
    ("data link silent 9.5 s: not yet", situation({"dll_act": 2}, gcs_age_s=9.5), QUIET, None, (), QUIET),
    ("data link still lost: not again", situation({"dll_act": 2}, gcs_age_s=20.0), FailsafeMemory(gcs_lost=True),
     None, (), FailsafeMemory(gcs_lost=True)),
    ("data link regained", situation(), FailsafeMemory(gcs_lost=True), None, ((INFO, "Data link regained"),), QUIET),
    ("no ground station ever: nothing watched", situation({"dll_act": 3}, gcs_age_s=None), QUIET, None, (), QUIET),
    # -- sticks (NAV_RCL_ACT, COM_RC_LOSS_T, COM_RCL_EXCEPT)
    ("sticks lost: return (default)", situation(manual_age_s=0.6), QUIET,
     (CRITICAL, "Manual control lost", Mode.AUTO_RTL), (), FailsafeMemory(rc_lost=True)),
    ("sticks silent 0.4 s: not yet", situation(manual_age_s=0.4), QUIET, None, (), QUIET),
    ("sticks lost, NAV_RCL_ACT 1: hold", situation({"rcl_act": 1}, manual_age_s=0.6), QUIET,
     (CRITICAL, "Manual control lost", Mode.AUTO_LOITER), (), FailsafeMemory(rc_lost=True)),
    ("sticks lost, NAV_RCL_ACT 5: terminate", situation({"rcl_act": 5}, manual_age_s=0.6), QUIET,
     (CRITICAL, "Manual control lost", TERMINATE), (), FailsafeMemory(rc_lost=True)),
    ("sticks lost, NAV_RCL_ACT 6: lockdown", situation({"rcl_act": 6}, manual_age_s=0.6), QUIET,
     (CRITICAL, "Manual control lost", TERMINATE), (), FailsafeMemory(rc_lost=True)),
    ("sticks lost, NAV_RCL_ACT 0: report only", situation({"rcl_act": 0}, manual_age_s=0.6), QUIET,
     (CRITICAL, "Manual control lost", None), (), FailsafeMemory(rc_lost=True)),
    ("sticks lost in Hold, Hold excepted", situation({"rcl_except": 2}, manual_age_s=0.6), QUIET,
     (CRITICAL, "Manual control lost", None), (), FailsafeMemory(rc_lost=True)),
    ("sticks lost in Mission, Hold excepted", situation({"rcl_except": 2}, mode=Mode.AUTO_MISSION, manual_age_s=0.6),
     QUIET, (CRITICAL, "Manual control lost", Mode.AUTO_RTL), (), FailsafeMemory(rc_lost=True)),
    ("sticks lost in Mission, Mission excepted", situation({"rcl_except": 1}, mode=Mode.AUTO_MISSION,
     manual_age_s=0.6), QUIET, (CRITICAL, "Manual control lost", None), (), FailsafeMemory(rc_lost=True)),
    ("sticks regained", situation(), FailsafeMemory(rc_lost=True), None, ((INFO, "Manual control regained"),), QUIET),
    ("never any sticks: nothing watched", situation(manual_age_s=None), QUIET, None, (), QUIET),
    # -- battery (COM_LOW_BAT_ACT)
    ("battery low: warn", situation(battery_frac=0.14, battery_level=BatteryWarning.LOW), QUIET, None,
     ((WARNING, "Low battery (14% left): return advised"),), FailsafeMemory(battery_level=BatteryWarning.LOW)),
    ("battery critical, act 0: warn", situation(battery_frac=0.06, battery_level=BatteryWarning.CRITICAL), QUIET,
     None, ((CRITICAL, "Critical battery (6% left): landing advised"),),
     FailsafeMemory(battery_level=BatteryWarning.CRITICAL)),
    ("battery critical, act 3: return", situation({"low_bat_act": 3}, battery_frac=0.06,
     battery_level=BatteryWarning.CRITICAL), QUIET, (CRITICAL, "Critical battery (6% left)", Mode.AUTO_RTL), (),
     FailsafeMemory(battery_level=BatteryWarning.CRITICAL)),
    ("battery critical, act 2: land", situation({"low_bat_act": 2}, battery_frac=0.06,
     battery_level=BatteryWarning.CRITICAL), QUIET, (CRITICAL, "Critical battery (6% left)", Mode.AUTO_LAND), (),
     FailsafeMemory(battery_level=BatteryWarning.CRITICAL)),
    ("battery emergency, act 3: land", situation({"low_bat_act": 3}, battery_frac=0.04,
     battery_level=BatteryWarning.EMERGENCY), FailsafeMemory(battery_level=BatteryWarning.CRITICAL),
     (EMERGENCY, "Emergency battery (4% left)", Mode.AUTO_LAND), (),
     FailsafeMemory(battery_level=BatteryWarning.EMERGENCY)),
    ("battery emergency, act 0: warn", situation(battery_frac=0.04, battery_level=BatteryWarning.EMERGENCY), QUIET,
     None, ((EMERGENCY, "Emergency battery (4% left): land now"),),
     FailsafeMemory(battery_level=BatteryWarning.EMERGENCY)),
    ("battery critical on the ground, act 3: warn", situation({"low_bat_act": 3}, in_air=False, battery_frac=0.06,
     battery_level=BatteryWarning.CRITICAL), QUIET, None, ((CRITICAL, "Critical battery (6% left): landing advised"),),
     FailsafeMemory(battery_level=BatteryWarning.CRITICAL)),
    ("battery level already reported", situation({"low_bat_act": 3}, battery_frac=0.05,
     battery_level=BatteryWarning.CRITICAL), FailsafeMemory(battery_level=BatteryWarning.CRITICAL), None, (),
     FailsafeMemory(battery_level=BatteryWarning.CRITICAL)),
    ("battery charge risen: level lowered", situation(battery_frac=0.2, battery_level=BatteryWarning.NONE),
     FailsafeMemory(battery_level=BatteryWarning.LOW), None, (), QUIET),
    ("disarmed: battery not watched, memory cleared", situation(armed=False, in_air=False, battery_frac=0.06,
     battery_level=BatteryWarning.CRITICAL), FailsafeMemory(battery_level=BatteryWarning.LOW), None, (), QUIET),
    # -- the estimate (COM_POSCTL_NAVL)
    ("position lost with sticks: altitude control", situation(estimate=NO_POSITION), QUIET,
     (CRITICAL, "Position estimate lost", Mode.ALTCTL), (), FailsafeMemory(position_lost=True)),
    ("position lost, COM_POSCTL_NAVL 1: land", situation({"posctl_navl": 1}, estimate=NO_POSITION), QUIET,
     (CRITICAL, "Position estimate lost", Mode.AUTO_LAND), (), FailsafeMemory(position_lost=True)),
    ("position lost without sticks: land", situation(estimate=NO_POSITION, manual_age_s=None), QUIET,
     (CRITICAL, "Position estimate lost", Mode.AUTO_LAND), (), FailsafeMemory(position_lost=True)),
    ("position and height lost: descend", situation(estimate=NO_HEIGHT, manual_age_s=None), QUIET,
     (CRITICAL, "Position estimate lost", DESCEND), (), FailsafeMemory(position_lost=True)),
    ("position lost in ALTCTL: nothing to do", situation(estimate=NO_POSITION, mode=Mode.ALTCTL), QUIET, None, (),
     QUIET),
    ("position lost in AUTO.LAND: lands on the height", situation(estimate=NO_POSITION, mode=Mode.AUTO_LAND), QUIET,
     None, (), QUIET),
    ("position lost on the ground: nothing", situation(estimate=NO_POSITION, in_air=False), QUIET, None, (), QUIET),
    ("position regained", situation(), FailsafeMemory(position_lost=True), None,
     ((INFO, "Position estimate regained"),), QUIET),
    ("attitude lost: descend", situation(estimate=NO_ATTITUDE), QUIET,
     (CRITICAL, "Attitude estimate lost", DESCEND), (), FailsafeMemory(attitude_lost=True)),
    ("attitude still lost: not again", situation(estimate=NO_ATTITUDE), FailsafeMemory(attitude_lost=True), None, (),
     FailsafeMemory(attitude_lost=True)),
    ("attitude lost on the ground: nothing", situation(estimate=NO_ATTITUDE, in_air=False), QUIET, None, (), QUIET),
    ("no estimate yet: nothing watched", situation(estimate=None, manual_age_s=5.0), QUIET, None, (), QUIET),
    # -- offboard (COM_OBL_RC_ACT's fallback)
    ("offboard lost: its fallback", situation(mode=Mode.OFFBOARD, offboard_lost=True), QUIET,
     (CRITICAL, "Offboard control lost", Mode.POSCTL), (), FailsafeMemory(offboard_lost=True)),
    ("offboard lost, fallback land", situation({"offboard_fallback": Mode.AUTO_LAND}, mode=Mode.OFFBOARD,
     offboard_lost=True), QUIET, (CRITICAL, "Offboard control lost", Mode.AUTO_LAND), (),
     FailsafeMemory(offboard_lost=True)),
    ("offboard still lost: not again", situation(mode=Mode.OFFBOARD, offboard_lost=True),
     FailsafeMemory(offboard_lost=True), None, (), FailsafeMemory(offboard_lost=True)),
    ("offboard left: forgotten", situation(), FailsafeMemory(offboard_lost=True), None, (), QUIET),
]  # fmt: skip


@pytest.mark.parametrize("name, now, before, alarm, texts, after", ROWS, ids=[row[0] for row in ROWS])
def test_failsafe_decision(name, now, before, alarm, texts, after):
    decision, memory = decide(now, before)
    got = None if decision.alarm is None else (decision.alarm.severity, decision.alarm.what, decision.alarm.target)
    assert got == alarm
    assert decision.texts == texts
    assert memory == after


def test_one_alarm_per_call_and_the_pass_resumes_after_it():
    """Sticks and the data link lost together: the sticks' alarm first, then (resumed) the data link's."""
    now = situation({"dll_act": 3}, manual_age_s=0.6, gcs_age_s=10.5)
    first, memory = decide(now, QUIET)
    assert first.alarm is not None and first.alarm.what == "Manual control lost" and first.resume_at is not None
    second, memory = decide(now, memory, first.resume_at)
    assert second.alarm is not None and (second.alarm.what, second.alarm.target) == ("Data link lost", Mode.AUTO_LAND)
    assert memory == FailsafeMemory(rc_lost=True, gcs_lost=True)
    third, _ = decide(now, memory, second.resume_at) if second.resume_at is not None else (None, None)
    assert third is None or third.alarm is None


@pytest.mark.parametrize(
    "flown, target, kept",
    [
        (Mode.AUTO_LAND, Mode.AUTO_RTL, True),  # landing is not turned into a return
        (Mode.AUTO_RTL, Mode.AUTO_RTL, True),
        (DESCEND, Mode.AUTO_LAND, True),
        (Mode.AUTO_LOITER, Mode.AUTO_RTL, False),
        (Mode.AUTO_RTL, Mode.AUTO_LAND, False),
        (Mode.POSCTL, Mode.AUTO_LOITER, False),
        (Mode.AUTO_LAND, Mode.ALTCTL, False),  # not ranked: the action is taken
    ],
)
def test_an_action_never_downgrades_a_more_cautious_mode(flown, target, kept):
    assert already_flown(flown, target) is kept


@pytest.mark.parametrize(
    "target, chain",
    [
        (Mode.AUTO_RTL, [Mode.AUTO_RTL, Mode.AUTO_LAND, DESCEND]),
        (Mode.AUTO_LOITER, [Mode.AUTO_LOITER, Mode.AUTO_LAND, DESCEND]),
        (Mode.AUTO_LAND, [Mode.AUTO_LAND, DESCEND]),
        (Mode.ALTCTL, [Mode.ALTCTL, Mode.AUTO_LAND, DESCEND]),
        (DESCEND, [DESCEND]),
    ],
)
def test_a_refused_action_falls_back_to_land_then_descend(target, chain):
    assert fallback_chain(target) == chain
