"""Whether the precision landing may start its last second, the docking, and whether it must climb out of it:
the vehicle's heading square to the deck *at the touch*, and no turn change of the deck due before it.

Why (issue 34; quad_x on a figure-8 of 2 m lobes at 2 m/s, 30 landings; its legs span 1.01 m on a 1.3 m deck, so
at 25 deg or more off square a foot hangs over the edge): every failure touched 14-43 deg off square, though the
docking started within 10 deg of it, as the approach asks.  Either the deck reversed its turn during the docking
(12 of 15: :mod:`turn_rhythm`), or the vehicle, still catching up with the deck's heading, turned on past it at
0.2-0.35 rad/s for the whole second (3 of 15; most of the windy figure-8's failures).  quad_x yaws at 0.3-0.4
rad/s^2 while the chase tilts it, so neither can be corrected in the air within the second.

PLD_DOCK_CHK, a bitmask (default 7):

- 1: the docking is timed to touch square.  It may start when the vehicle's heading, moved on at its yaw rate now,
  will be within ALIGNED_AT_TOUCH_RAD of square at the touch, ``ahead_s`` from now (the deck's heading moved on at
  its turn rate: :meth:`DeckHeading.off_square_rad`), whatever it is now; through the docking the heading then
  keeps turning at that rate, corrected by that prediction's error, until LATE_S after the touch was due
  (:meth:`DockGate.yaw_setpoint`).  The
  docking's length is what [F 3]'s spline makes it (0.94-1.06 s measured from its start to the first foot's
  touch), and a yaw rate held needs no yaw torque: the prediction holds where a heading still catching up
  with the deck's turned on past it.  Without this bit: within ALIGNED_RAD of square now, the deck's heading
  tracked through the docking (:class:`DeckHeading`);
- 2: no turn change of the deck expected before the touch and RHYTHM_MARGIN_S after it (:class:`TurnRhythm`);
- 4: while docking, with the feet still ABORT_ABOVE_M above the deck or more, a heading that will touch more than
  ABORT_RAD off square climbs back to the approach.

Frames and units: yaw NED in rad (clockwise from above), rates rad/s, time in microseconds, heights metres.
"""

from __future__ import annotations

import math

import numpy as np

from autopilot.navigation.deck_heading import DeckHeading
from autopilot.navigation.turn_rhythm import TurnRhythm
from autopilot.parameters import ParamDef, ParamType, param
from mavsim_core.quaternion import wrap_pi

PARAMS: tuple[ParamDef, ...] = (
    param(
        "PLD_DOCK_CHK", 7, 0, 7, "",
        "Precision landing docking checks (bitmask; ours): 1 timed to touch square to the deck, "
        "2 no turn change of the deck due before it, 4 climb out of a docking that will touch off square",
        ParamType.INT32,
    ),
)  # fmt: skip

SQUARE_AT_TOUCH, TURN_RHYTHM, ABORT_OFF_SQUARE = 1, 2, 4
ALIGNED_AT_TOUCH_RAD = math.radians(8.0)  # square at the touch within this: 8 cm of room for the feet's position
# Timed to touch square, the heading may turn at most this fast against the deck's (rad/s): measured on the
# figure-8 (30 landings), the prediction was 5-10 deg off at 0.1-0.5 rad/s and 8-17 deg at 0.6-1.0 rad/s, which
# came right after the deck's reversals, when its model's turn rate was still settling.
RELATIVE_RATE_MAX_RAD_S = 0.5
TURN_SETTLE_S = 1.0  # ... and the deck's turn has held this long (s) since its latest change (its model settles)
LATE_S = 0.2  # the timed heading is flown this long after the touch was due, then the deck's again
RHYTHM_MARGIN_S = 0.4  # the turn change is dated when the deck model has taken it up, 0.1-0.3 s after it began
ABORT_RAD = math.radians(15.0)  # touching this far off square leaves 3 cm for the feet's position error
# Below this the docking goes on (the vehicle could not stop before the deck).  0.3 m let the random path's turn
# starts in the docking's last 0.4 s put quad_x down 18-30 deg off square, a foot over the edge (4 of 30 landings);
# at 0.15 it climbs out of them: random calm 26 -> 29/30 and 29 -> 30/30 (two sets of seeds), the other cells of
# landing_turning.toml and landing_windy.toml as they were (docs/landing.md, "Climbing out lower").
ABORT_ABOVE_M = 0.15


def yaw_rate_ned(rate_frd_rad_s: np.ndarray, roll_rad: float, pitch_rad: float) -> float:
    """The heading's rate of change (rad/s) from the body rates (FRD, rad/s) and the roll and pitch (ZYX Euler)."""
    p, q, r = (float(x) for x in rate_frd_rad_s)
    return (q * math.sin(roll_rad) + r * math.cos(roll_rad)) / max(math.cos(pitch_rad), 0.1)


class DockGate:
    """See the module docstring.  ``checks``: PLD_DOCK_CHK."""

    def __init__(self, checks: int = 7) -> None:
        self.checks = int(checks)
        self.rhythm = TurnRhythm()
        self._yaw_plan: tuple[int, float, float, float] | None = None  # (start us, yaw rad, rate rad/s, length s)
        self.planned_off_rad: float | None = None  # the heading's predicted offset from square at the touch, rad
        self._waited: dict[str, float] = {}  # seconds held by each kind of reason since the last summary
        self._asked_us: int | None = None

    def waited(self) -> str:
        """What held the docking since the last call, and how long ("" if nothing did)."""
        text = ", ".join(f"{why} {s:.1f} s" for why, s in self._waited.items() if s > 0.0)
        self._waited, self._asked_us = {}, None
        return text

    def _held(self, now_us: int, why: str, kind: str) -> str:
        if self._asked_us is not None:
            self._waited[kind] = self._waited.get(kind, 0.0) + max(0.0, (now_us - self._asked_us) * 1e-6)
        self._asked_us = now_us
        return why

    def observe_turn(self, t_us: int, turn_rad_s: float) -> None:
        """The deck's turn rate (rad/s) measured at ``t_us``."""
        self.rhythm.add(t_us, turn_rad_s)

    def hold_reason(
        self, now_us: int, heading: DeckHeading, yaw_rad: float, yaw_rate_rad_s: float, ahead_s: float
    ) -> str:
        """Why the docking, expected to touch ``ahead_s`` from now, may not start now ("" when it may)."""
        if self.checks & SQUARE_AT_TOUCH:
            off = heading.off_square_rad(now_us, yaw_rad, yaw_rate_rad_s, ahead_s)
            if off is not None and abs(off) > ALIGNED_AT_TOUCH_RAD:
                return self._held(now_us, "heading off square at the touch", "off square at the touch")
            turning = heading.turn_rad_s
            if off is not None and abs(yaw_rate_rad_s - turning) > RELATIVE_RATE_MAX_RAD_S:
                return self._held(now_us, "heading turning too fast against the deck's", "turning against the deck")
        elif not heading.aligned(now_us, yaw_rad):
            return self._held(now_us, "heading off square", "off square")
        if self.checks & TURN_RHYTHM:
            if not self.rhythm.clear(now_us, ahead_s + RHYTHM_MARGIN_S):
                return self._held(now_us, "the deck's turn changes before the touch", "turn change due")
            if self.rhythm.steady_s(now_us) < TURN_SETTLE_S:
                return self._held(now_us, "the deck's turn has just changed", "turn just changed")
        self._asked_us = None
        return ""

    def start(self, now_us: int, heading: DeckHeading, yaw_rad: float, yaw_rate_rad_s: float, ahead_s: float) -> None:
        """The docking starts now, to touch ``ahead_s`` from now: its heading's trajectory (PLD_DOCK_CHK bit 1)."""
        off = heading.off_square_rad(now_us, yaw_rad, yaw_rate_rad_s, ahead_s)
        if not self.checks & SQUARE_AT_TOUCH or off is None or ahead_s <= 0.0:
            self._yaw_plan, self.planned_off_rad = None, None
            return
        self._yaw_plan = (now_us, yaw_rad, yaw_rate_rad_s - off / ahead_s, ahead_s)
        self.planned_off_rad = off

    def yaw_setpoint(self, now_us: int) -> tuple[float, float] | None:
        """The docking's heading setpoint now (rad) and its rate (rad/s): the heading at the start turned on at the
        rate that makes it square at the touch; None without a plan, or LATE_S after the touch was due (the deck's
        heading then: a touch 0.8 s late, the rate held on, had a windy circle's landing 13 deg off square)."""
        if self._yaw_plan is None:
            return None
        t0_us, yaw0, rate, length_s = self._yaw_plan
        t_s = max(0.0, (now_us - t0_us) * 1e-6)
        return None if t_s > length_s + LATE_S else (wrap_pi(yaw0 + rate * t_s), rate)

    def abort_reason(
        self,
        now_us: int,
        heading: DeckHeading,
        yaw_rad: float,
        yaw_rate_rad_s: float,
        ahead_s: float,
        feet_above_m: float,
    ) -> str:
        """Why a docking that touches ``ahead_s`` from now, the feet ``feet_above_m`` above the deck, must climb
        back to the approach ("" when it goes on)."""
        if not self.checks & ABORT_OFF_SQUARE or feet_above_m < ABORT_ABOVE_M:
            return ""
        off = heading.off_square_rad(now_us, yaw_rad, yaw_rate_rad_s, ahead_s)
        if off is None or abs(off) <= ABORT_RAD:
            return ""
        return f"heading {math.degrees(off):+.0f} deg off square at the touch"
