"""The precision landing's vocabulary: its parameters (PLD_*, PX4's names and [F 3]'s values), its phases, PX4's
two modes and the landing target as the task reads it.  :mod:`autopilot.navigation.precland` flies them.

Frames and units: the target's position is relative to the vehicle (target minus vehicle, NED m), its velocity and
acceleration over the ground (NED m/s, m/s^2), time in microseconds; the parameters' units are in PARAMS.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from enum import Enum
from typing import Any

import numpy as np

from autopilot.parameters import ParamDef, ParameterStore, ParamType, param

PARAMS: tuple[ParamDef, ...] = (
    param("PLD_BTOUT", 5.0, 0.0, 50.0, "s", "Landing target lost longer than this: search"),
    param("PLD_HACC_RAD", 0.2, 0.0, 10.0, "m", "Horizontal acceptance radius above the target (PX4)"),
    param("PLD_FAPPR_ALT", 0.1, 0.0, 10.0, "m", "Below this height above the target a lost target stops no descent"),
    param("PLD_SRCH_ALT", 10.0, 0.0, 100.0, "m", "Search height above the ground"),
    param("PLD_SRCH_TOUT", 10.0, 0.0, 100.0, "s", "Longest search (also the longest preparation without target)"),
    param("PLD_MAX_SRCH", 3, 0, 100, "", "Most searches before the fallback", ParamType.INT32),
    param("PLD_PREP_ALT", 2.8, 0.5, 20.0, "m", "Preparation hover height above the ground [F 3]"),
    param("PLD_TRK_ALT", 1.0, 0.2, 10.0, "m", "Tracking height above the target [F 3]"),
    param("PLD_APPR_RAD", 0.05, 0.01, 1.0, "m", "Approach: horizontal error below this starts the docking [F 3]"),
    param("PLD_TRK_SPD", 1.0, 0.1, 10.0, "m/s", "Mean speed of the tracking and docking splines [F 3]"),
)


class PrecLandPhase(Enum):
    PREPARATION = "preparation"
    TRACKING = "tracking"
    APPROACHING = "approaching"
    DOCKING = "docking"
    TOUCHDOWN = "touchdown"  # legs on a moving deck: held level at low thrust before the cut (navigation.touchdown)
    SEARCH = "search"
    FALLBACK = "fallback"
    DONE = "done"


class PrecLandMode(Enum):
    """NAV_LAND param 2 as in PX4: 1 opportunistic, 2 required."""

    OPPORTUNISTIC = 1
    REQUIRED = 2


@dataclass(frozen=True, slots=True)
class LandingTargetInput:
    """The landing target as the task reads it: position relative to the vehicle (target minus
    vehicle, m NED), velocity over the ground (m/s NED), validity and time (µs)."""

    timestamp_us: int
    rel_pos_ned_m: np.ndarray
    vel_ned_m_s: np.ndarray
    valid: bool = True
    acc_ned_m_s2: np.ndarray | None = None  # the target's acceleration over the ground (a turning UGV)
    turn_rad_s: float | None = None  # its turn rate (rad/s, clockwise from above) if the deck model has one
    square_yaw_rad: float | None = None  # the heading of the deck's edges now (rad NED, modulo 90 deg), if known


@dataclass(frozen=True, slots=True)
class PrecLandConfig:
    """The PARAMS' values (see PARAMS for units); ``from_store`` reads them, defaults otherwise."""

    btout_s: float = 5.0
    hacc_rad_m: float = 0.2
    fappr_alt_m: float = 0.1
    srch_alt_m: float = 10.0
    srch_tout_s: float = 10.0
    max_srch: int = 3
    prep_alt_m: float = 2.8
    trk_alt_m: float = 1.0
    appr_rad_m: float = 0.05
    trk_spd_m_s: float = 1.0

    @staticmethod
    def from_store(store: ParameterStore) -> PrecLandConfig:
        vals: dict[str, Any] = {f.name: store.get(d.name) for f, d in zip(fields(PrecLandConfig), PARAMS, strict=True)}
        vals["max_srch"] = int(vals["max_srch"])
        return PrecLandConfig(**vals)
