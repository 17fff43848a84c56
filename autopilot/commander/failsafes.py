"""Failsafes: what the commander does by itself when something it relies on fails.

:func:`check` runs in every commander update (armed or not).  Today: a position estimate
lost in flight lands (AUTO.LAND on the height estimate).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

from pymavlink.dialects.v20 import common as S

from autopilot.parameters import ParamDef, param
from mavsim_core.px4_modes import Mode

if TYPE_CHECKING:
    from autopilot.commander.commander import Commander

# The parameters this module reads (listed in autopilot/param_catalogue.py).
PARAMS: tuple[ParamDef, ...] = (param("COM_RC_LOSS_T", 0.5, 0.0, 35.0, "s", "Manual control (RC) loss time-out"),)


@dataclass
class FailsafeState:
    """What the failsafes have reported and done so far (so each is said once)."""


def check(c: Commander, now_us: int) -> None:
    """Act on the failures of this update."""
    est = c.est
    if est is None:
        return
    if c.armed and c.in_air and not est.position_valid and c.mode is not Mode.AUTO_LAND:
        c.say(S.MAV_SEVERITY_CRITICAL, "Position estimate lost: landing")
        c._enter(Mode.AUTO_LAND)
