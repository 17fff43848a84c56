"""What each mode needs before it may be entered, as PX4's mode requirements: pure functions of typed inputs.

A position estimate for POSCTL, the AUTO modes and OFFBOARD; a height (barometer) for ALTCTL and AUTO.LAND;
only an attitude for STABILIZED and ACRO, which also need recent MANUAL_CONTROL (``COM_RC_LOSS_T``), as ALTCTL
does.  POSCTL without sticks holds position (what it did before sticks existed).  Each function returns the
refusal's reason (the words after "Mode X denied: ") or None; the commander says it and refuses.
"""

from __future__ import annotations

from dataclasses import dataclass

from autopilot.topics import VehicleEstimate
from mavsim_core.px4_modes import Mode

HEIGHT_ONLY = (Mode.ALTCTL, Mode.AUTO_LAND)  # modes that fly on a height estimate without a position
ATTITUDE_ONLY = (Mode.STABILIZED, Mode.ACRO)  # modes that need nothing but an attitude
NEEDS_STICKS = (Mode.ALTCTL, Mode.STABILIZED, Mode.ACRO)


@dataclass(frozen=True)
class EstimateValidity:
    """What the estimator says it can give now."""

    attitude: bool
    position: bool
    height: bool

    @classmethod
    def of(cls, est: VehicleEstimate | None) -> EstimateValidity | None:
        """The validity flags of ``est`` (None without an estimate)."""
        if est is None:
            return None
        return cls(est.attitude_valid, est.position_valid, est.height_valid)


def estimate_refusal(mode: Mode, validity: EstimateValidity | None) -> str | None:
    """Why the estimate cannot fly ``mode`` now, or None."""
    if validity is None:
        return "no estimate"
    if mode in ATTITUDE_ONLY:
        return None if validity.attitude else "no attitude estimate"
    if mode in HEIGHT_ONLY:
        return None if (validity.position or validity.height) else "no height estimate"
    return None if validity.position else "no position estimate"


def sticks_refusal(mode: Mode, manual_age_s: float | None, rc_loss_t_s: float) -> str | None:
    """Why ``mode`` lacks the pilot's sticks now (MANUAL_CONTROL ``manual_age_s`` old, None: never), or None."""
    if mode in NEEDS_STICKS and (manual_age_s is None or manual_age_s > rc_loss_t_s):
        return "no manual control input"
    return None


# Modes this flight controller can fly (POSCTL without sticks holds position).
AVAILABLE = frozenset({
    Mode.POSCTL, Mode.ALTCTL, Mode.STABILIZED, Mode.ACRO, Mode.OFFBOARD, Mode.AUTO_TAKEOFF, Mode.AUTO_LOITER,
    Mode.AUTO_MISSION, Mode.AUTO_RTL, Mode.AUTO_LAND, Mode.AUTO_PRECLAND, Mode.AUTO_FOLLOW_TARGET,
})  # fmt: skip


@dataclass(frozen=True)
class ModeEntryInputs:
    """What entering a mode depends on now (ages in s, both clocks; None: never seen)."""

    armed: bool
    in_air: bool
    estimate: EstimateValidity | None
    has_home: bool
    manual_age_s: float | None  # the pilot's sticks (MANUAL_CONTROL)
    rc_loss_t_s: float  # COM_RC_LOSS_T
    offboard_refusal: (
        str | None
    )  # why no offboard setpoints stream (:func:`autopilot.navigation.offboard.offboard_refusal`)


def input_refusal(mode: Mode, s: ModeEntryInputs) -> str | None:
    """Why ``mode`` lacks its outside input now (sticks, an offboard setpoint stream), or None; armed or not."""
    why = sticks_refusal(mode, s.manual_age_s, s.rc_loss_t_s)
    if why is None and mode is Mode.OFFBOARD:
        return s.offboard_refusal
    return why


def entry_refusal(mode: Mode, s: ModeEntryInputs) -> str | None:
    """The STATUSTEXT refusing ``mode`` now, or None when it may be entered (its task can then start; AUTO.MISSION
    still needs a mission: :func:`autopilot.commander.mission_control.start_mission`)."""
    if mode not in AVAILABLE:
        return f"Mode {mode.label} not available on this vehicle"
    why = estimate_refusal(mode, s.estimate)
    if why is not None:
        return f"Mode {mode.label} denied: {why}"
    if mode is Mode.AUTO_RTL and not s.has_home:
        return "Return denied: no home position"
    why = input_refusal(mode, s)
    if why is not None:
        return f"Mode {mode.label} denied: {why}"
    if mode is Mode.AUTO_TAKEOFF and not s.armed:
        return "Takeoff denied: vehicle not armed"
    if mode is Mode.AUTO_TAKEOFF and s.in_air:
        return "Takeoff denied: already flying"
    flying = s.armed and s.in_air
    if mode is Mode.AUTO_PRECLAND and not flying:
        return "Precision landing denied: vehicle not flying"
    if mode is Mode.AUTO_FOLLOW_TARGET and not flying:
        return "Follow target denied: vehicle not flying"
    return None
