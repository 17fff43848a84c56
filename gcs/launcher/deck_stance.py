"""How a multicopter stands on the ground vehicle's deck, as a pilot judges a landing (issue 34).

A landing is a success when all its feet are on the deck, it stands level on it and it is still there
:data:`STAY_ON_DECK_S` later.  "Level" is measured the way a person would check it: the vehicle's height above
the deck equals its height above flat ground within :data:`LEVEL_TOLERANCE_M` (a leg hanging over the deck's
edge, or resting on the edge, tilts the vehicle and changes that height).  A vehicle whose centre is over the
deck but that fails either check is "on the deck's edge": a failure, and the campaign says so.

Frames and units: NED metres from the multicopter's start point (the simulator's truth), the attitude
quaternion FRD -> NED as HIL_STATE_QUATERNION carries it ``(w, x, y, z)``, the UGV's yaw in radians from North;
the deck is the square of side ``UgvGeometry.deck_side_m`` centred on the UGV's body, its top
``UgvGeometry.deck_top_m`` above the ground.

Flat-ground reference: the vertical offset between the multicopter and the UGV while both stand on the ground
before the take-off (``rest_dz_m``).  On the deck the multicopter's centre should be ``deck_top_m`` higher than
that, whatever the two bodies' own reference points are.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Sequence

import numpy as np

from mavsim_core import quaternion as quat
from sitl.ugv import UgvGeometry

STAY_ON_DECK_S = 5.0  # simulated seconds after the disarm: still on the deck, still level
LEVEL_TOLERANCE_M = 0.02  # height above the deck against height above flat ground (the 2 cm)


@dataclass(frozen=True)
class Stance:
    """Where the multicopter stands relative to the deck at one instant.

    ``centre_on_deck``: its centre over the deck's square and off the ground; ``feet_on_deck``: how many of its
    ``feet`` are inside the square; ``level_error_m``: its height above the deck minus its height above flat
    ground (positive: higher, e.g. propped on the edge); NaN without a flat-ground reference; ``square_off_deg``:
    its heading off square to the deck's edges (0: its axes along them, 45: along the diagonals), NaN without an
    attitude.
    """

    centre_on_deck: bool
    feet_on_deck: int
    feet: int
    level_error_m: float
    square_off_deg: float = math.nan

    @property
    def standing(self) -> bool:
        """All feet on the deck and level on it (within :data:`LEVEL_TOLERANCE_M`)."""
        return (
            self.centre_on_deck
            and self.feet_on_deck == self.feet
            and math.isfinite(self.level_error_m)
            and abs(self.level_error_m) <= LEVEL_TOLERANCE_M
        )

    def problem(self) -> str:
        """Why this is not a landing on the deck ("" if it is one)."""
        if self.standing:
            return ""
        if not self.centre_on_deck:
            return "off the deck"
        if self.feet_on_deck < self.feet:
            return f"on the deck's edge: {self.feet - self.feet_on_deck} of {self.feet} feet off the deck"
        if not math.isfinite(self.level_error_m):
            return "on the deck, level unknown (no flat-ground reference)"
        return f"on the deck's edge: {100 * self.level_error_m:+.1f} cm from a level stance"


def feet_ned(
    pos_ned_m: Sequence[float],
    q_frd_to_ned: Sequence[float],
    leg_positions_frd_m: Sequence[Sequence[float]],
    leg_size_m: Sequence[float],
) -> np.ndarray:
    """Each leg's foot (the bottom of its box) in NED metres: ``(n, 3)``."""
    r = quat.to_matrix(np.asarray(q_frd_to_ned, dtype=float))
    feet_frd = np.asarray(leg_positions_frd_m, dtype=float) + np.array([0.0, 0.0, leg_size_m[2] / 2.0])
    return np.asarray(pos_ned_m, dtype=float) + feet_frd @ r.T


def deck_frame(point_ned_m: Sequence[float], ugv_ned_m: Sequence[float], ugv_yaw_rad: float) -> tuple[float, float]:
    """A point's horizontal offset from the deck's centre in the UGV's frame: (forward, right), metres."""
    dn, de = float(point_ned_m[0] - ugv_ned_m[0]), float(point_ned_m[1] - ugv_ned_m[1])
    c, s = math.cos(ugv_yaw_rad), math.sin(ugv_yaw_rad)
    return c * dn + s * de, -s * dn + c * de


def in_deck(point_ned_m: Sequence[float], ugv_ned_m: Sequence[float], ugv_yaw_rad: float, geom: UgvGeometry) -> bool:
    """A point's horizontal position inside the deck's square (in the UGV's frame)."""
    fwd, right = deck_frame(point_ned_m, ugv_ned_m, ugv_yaw_rad)
    half = geom.deck_side_m / 2
    return abs(fwd) <= half and abs(right) <= half


def stance(
    pos_ned_m: Sequence[float],
    q_frd_to_ned: Sequence[float] | None,
    ugv_ned_m: Sequence[float],
    ugv_yaw_rad: float,
    geom: UgvGeometry,
    legs: tuple[Sequence[Sequence[float]], Sequence[float]],
    rest_dz_m: float | None,
) -> Stance:
    """The multicopter's :class:`Stance` on the deck (see the module docstring).

    ``legs``: the vehicle file's leg positions (FRD m) and leg box size (m); ``q_frd_to_ned`` None counts every
    foot as off the deck (no attitude: not judged); ``rest_dz_m``: the multicopter's NED z minus the UGV's while
    both stood on flat ground (None: no reference, the level is not judged)."""
    centre = in_deck(pos_ned_m, ugv_ned_m, ugv_yaw_rad, geom) and -pos_ned_m[2] > 0.5 * geom.deck_top_m
    positions, size = legs
    on = 0
    if q_frd_to_ned is not None:
        on = sum(in_deck(f, ugv_ned_m, ugv_yaw_rad, geom) for f in feet_ned(pos_ned_m, q_frd_to_ned, positions, size))
    level = math.nan
    if rest_dz_m is not None:
        # on flat ground: z_v - z_u = rest_dz; standing on the deck: deck_top_m higher (z is down)
        level = -((pos_ned_m[2] - ugv_ned_m[2]) - rest_dz_m) - geom.deck_top_m
    square = math.nan
    if q_frd_to_ned is not None:
        rel_deg = math.degrees(quat.to_euler(np.asarray(q_frd_to_ned, dtype=float))[2] - ugv_yaw_rad)
        square = abs((rel_deg + 45.0) % 90.0 - 45.0)
    return Stance(bool(centre), int(on), len(positions), float(level), square)
