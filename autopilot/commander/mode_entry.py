"""Entering a mode: what it needs, and the flight task that flies it.

:func:`enter` is the commander's one mode switch (``Commander._enter``): it refuses a mode that
cannot run now, with a STATUSTEXT saying why (not available, no position / height / attitude
estimate, no home, not armed or not flying where that matters, no sticks for the manual modes,
no offboard setpoint stream), else builds and starts the mode's task and switches.

What each mode needs, as PX4's mode requirements: a position estimate for POSCTL, the AUTO
modes and OFFBOARD; a height (barometer) for ALTCTL and AUTO.LAND; only an attitude for
STABILIZED and ACRO, which also need recent MANUAL_CONTROL (``COM_RC_LOSS_T``), as ALTCTL does.
POSCTL without sticks holds position (what it did before sticks existed).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from pymavlink.dialects.v20 import common as S

from autopilot.commander import mission_control, mission_landing, mode_requirements, precision_landing
from autopilot.commander.mode_requirements import NEEDS_STICKS, EstimateValidity
from autopilot.navigation import LandTask, LoiterTask, TakeoffTask, started
from autopilot.navigation.follow_target import FollowTargetTask, fresh_target
from autopilot.navigation.manual_modes import AcroTask, AltCtlTask, PosCtlTask, StabilizedTask
from autopilot.navigation.offboard import OffboardTask, offboard_refusal
from mavsim_core.px4_modes import Mode

if TYPE_CHECKING:
    from autopilot.commander.commander import Commander


def estimate_refusal(c: Commander, mode: Mode) -> str | None:
    """Why the estimate cannot fly ``mode`` now, or None."""
    return mode_requirements.estimate_refusal(mode, EstimateValidity.of(c.est))


def input_refusal(c: Commander, mode: Mode) -> str | None:
    """Why ``mode`` lacks its outside input now (sticks, an offboard setpoint stream), or None; armed or not."""
    manual_age_s = c.inputs.manual_age_s(c.now_us, c.wall_s) if mode in NEEDS_STICKS else None
    why = mode_requirements.sticks_refusal(mode, manual_age_s, c.params.get("COM_RC_LOSS_T"))
    if why is None and mode is Mode.OFFBOARD:
        return offboard_refusal(c.inputs, c.now_us, c.wall_s, c.params)
    return why


def enter(c: Commander, mode: Mode, takeoff_down_m: float | None = None) -> int:
    """Switch ``c`` to ``mode`` and start its task; refuse (with a reason) if it cannot run now."""
    from autopilot.commander.commander import AVAILABLE

    e = c.est
    if mode not in AVAILABLE:
        c.say(S.MAV_SEVERITY_CRITICAL, f"Mode {mode.label} not available on this vehicle")
        return S.MAV_RESULT_DENIED
    why = estimate_refusal(c, mode)
    if why is not None or e is None:
        c.say(S.MAV_SEVERITY_CRITICAL, f"Mode {mode.label} denied: {why}")
        return S.MAV_RESULT_DENIED
    if mode is Mode.AUTO_RTL and c.home is None:
        c.say(S.MAV_SEVERITY_CRITICAL, "Return denied: no home position")
        return S.MAV_RESULT_DENIED
    why = input_refusal(c, mode)
    if why is not None:
        c.say(S.MAV_SEVERITY_CRITICAL, f"Mode {mode.label} denied: {why}")
        return S.MAV_RESULT_DENIED
    if mode is Mode.AUTO_TAKEOFF:
        if not c.armed:
            c.say(S.MAV_SEVERITY_CRITICAL, "Takeoff denied: vehicle not armed")
            return S.MAV_RESULT_DENIED
        if c.in_air:
            c.say(S.MAV_SEVERITY_CRITICAL, "Takeoff denied: already flying")
            return S.MAV_RESULT_DENIED
        assert c.home is not None
        if takeoff_down_m is None:
            takeoff_down_m = c.home.pos_ned_m[2] - c.params.get("MIS_TAKEOFF_ALT")
        c.task = started(TakeoffTask(takeoff_down_m, c.params), e, c.now_us)
        c.say(S.MAV_SEVERITY_INFO, f"Taking off to {c.home.pos_ned_m[2] - takeoff_down_m:.1f} m above home")
    elif mode is Mode.AUTO_LOITER:
        if mode is not c.mode or c.task is None:
            c.task = started(LoiterTask(), e, c.now_us)
    elif mode in (Mode.POSCTL, Mode.ALTCTL, Mode.STABILIZED, Mode.ACRO):
        if mode is not c.mode or c.task is None:
            c.task = started(_manual_task(c, mode), e, c.now_us)
    elif mode is Mode.OFFBOARD:
        c.task = started(OffboardTask(c.params, lambda: c.inputs.offboard, c.hover_thrust_frac), e, c.now_us)
    elif mode is Mode.AUTO_LAND:
        c.task = started(LandTask(c.home.pos_ned_m[2] if c.home else e.pos_ned_m[2], c.params), e, c.now_us)
    elif mode is Mode.AUTO_RTL:
        c.task = started(mission_landing.return_task(c, e), e, c.now_us)  # as RTL_TYPE says
    elif mode is Mode.AUTO_MISSION and (result := mission_control.start_mission(c)) != S.MAV_RESULT_ACCEPTED:
        return result
    elif mode is Mode.AUTO_PRECLAND:
        if not (c.armed and c.in_air):
            c.say(S.MAV_SEVERITY_CRITICAL, "Precision landing denied: vehicle not flying")
            return S.MAV_RESULT_DENIED
        c.task = started(precision_landing.new_task(c, c.precland_mode), e, c.now_us)
    elif mode is Mode.AUTO_FOLLOW_TARGET:
        if not (c.armed and c.in_air):
            c.say(S.MAV_SEVERITY_CRITICAL, "Follow target denied: vehicle not flying")
            return S.MAV_RESULT_DENIED
        target = lambda: fresh_target(c.inputs, c.now_us, c.wall_s)  # noqa: E731
        ground = c.home.pos_ned_m[2] if c.home else e.pos_ned_m[2]
        c.task = started(FollowTargetTask(c.params, target, ground, c.say), e, c.now_us)
    c._switch_mode(mode)
    return S.MAV_RESULT_ACCEPTED


def _manual_task(c: Commander, mode: Mode):
    """The task of a stick mode; it reads the latest MANUAL_CONTROL through ``c.inputs``."""
    sticks = lambda: c.inputs.manual  # noqa: E731
    if mode is Mode.POSCTL:
        return PosCtlTask(c.params, sticks)
    if mode is Mode.ALTCTL:
        return AltCtlTask(c.params, sticks)
    if mode is Mode.STABILIZED:
        return StabilizedTask(c.params, sticks, c.hover_thrust_frac)
    return AcroTask(c.params, sticks, c.hover_thrust_frac)
