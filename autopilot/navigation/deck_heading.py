"""The precision landing's heading: square to the deck, so that every foot comes down on it.

A square deck takes a vehicle's feet best with the vehicle's axes along its edges: quad_x's feet are
0.65 m from its centre on its diagonals, the deck's half side 0.65 m, so square to the deck they have
0.19 m of room each way and turned 45 deg to it none.  A landing that holds its own heading (PX4's)
meets a deck turned any way, and a turning deck turns under it.

:class:`DeckHeading` gives the yaw setpoint.  The deck's edges come from the target's orientation in
LANDING_TARGET (``square_yaw_rad``, the vision companion's marker pose), else from the deck's velocity heading while
it drives faster than HEADING_SPEED_M_S (a ground vehicle drives along its axis), moved on between fixes at the
deck's turn rate.  Of the four headings along them the setpoint aims at the one nearest to the vehicle's heading,
at most YAW_ERROR_MAX_RAD (15 deg) ahead of the vehicle, and the deck's turn rate goes with it as the yaw rate fed
forward (PositionSetpoint.yaw_rate_rad_s, PX4's yawspeed setpoint): without it the attitude loop lags a turning
deck.  With no deck heading known, or PLD_DECK_YAW = 0, it is the landing's own heading (the one it last flew,
once a deck heading was known), with no rate.

Frames and units: yaw in rad, NED (clockwise from north seen from above), in (-pi, pi]; turn rates rad/s,
clockwise from above; time in microseconds.
"""

from __future__ import annotations

import math

import numpy as np

from autopilot.parameters import ParamDef, ParameterStore, ParamType, param
from mavsim_core.quaternion import wrap_pi

PARAMS: tuple[ParamDef, ...] = (
    param(
        "PLD_DECK_YAW", 1, 0, 1, "",
        "Precision landing heading: 0 the heading it started with (PX4), 1 square to the deck's edges (ours)",
        ParamType.INT32,
    ),
)  # fmt: skip

QUARTER = math.pi / 2
HEADING_SPEED_M_S = 0.5  # a deck slower than this gives no heading from its velocity
STALE_S = 3.0  # a deck heading older than this (no fix) is dropped: the landing holds the last setpoint
ALIGNED_RAD = math.radians(10.0)  # within this of square the vehicle counts as aligned (docking may start)
# The setpoint at most this far from the vehicle's heading: quad_x yaws at 0.4-1 rad/s^2 (two motors at full speed,
# two at 40 %); asked for up to 45 deg, it held the yaw there for seconds and lost a figure-8 (2 m/s) 4 times in 10.
YAW_ERROR_MAX_RAD = math.radians(15.0)
TURN_FF_MAX_RAD_S = 2.5  # the deck's turn rate fed forward at most (rad/s): a figure-8's 2 m lobes at 4.2 m/s


def square(yaw_rad: float) -> float:
    """A heading modulo 90 deg, in [-pi/4, pi/4) (of each element, given an array)."""
    return (yaw_rad + math.pi / 4) % QUARTER - math.pi / 4


def nearest_square(square_yaw_rad: float, near_rad: float) -> float:
    """Of the four headings square_yaw_rad + k 90 deg, the one nearest to ``near_rad`` (wrapped to (-pi, pi])."""
    k = round(wrap_pi(near_rad - square_yaw_rad) / QUARTER)
    return wrap_pi(square_yaw_rad + k * QUARTER)


class DeckHeading:
    """See the module docstring.  ``yaw_rad``: the landing's own heading (the fallback)."""

    def __init__(self, yaw_rad: float, enabled: bool = True) -> None:
        self.own_yaw_rad = yaw_rad
        self.enabled = enabled
        self._square: tuple[int, float] | None = None  # (time us, the deck's square heading then, rad)
        self._turn_rad_s = 0.0
        self._yaw_sp = yaw_rad

    @staticmethod
    def from_store(store: ParameterStore, yaw_rad: float) -> DeckHeading:
        return DeckHeading(yaw_rad, bool(int(store.get("PLD_DECK_YAW"))))

    def observe(
        self, now_us: int, square_yaw_rad: float | None, vel_ned_m_s: np.ndarray, turn_rad_s: float | None
    ) -> None:
        """A fix of the deck: its square heading now (None: the sender gave no orientation), velocity over the
        ground (m/s NED) and turn rate (rad/s; None: unknown, taken as none)."""
        self._turn_rad_s = 0.0 if turn_rad_s is None or not math.isfinite(turn_rad_s) else float(turn_rad_s)
        if square_yaw_rad is not None and math.isfinite(square_yaw_rad):
            self._square = (now_us, square(square_yaw_rad))
        elif math.hypot(float(vel_ned_m_s[0]), float(vel_ned_m_s[1])) >= HEADING_SPEED_M_S:
            self._square = (now_us, square(math.atan2(float(vel_ned_m_s[1]), float(vel_ned_m_s[0]))))

    @property
    def turn_rad_s(self) -> float:
        """The deck's latest turn rate (rad/s, clockwise from above; 0 unknown)."""
        return self._turn_rad_s

    def deck_square(self, now_us: int) -> float | None:
        """The deck's square heading now (rad, modulo 90 deg; None: unknown or stale)."""
        if self._square is None or (now_us - self._square[0]) * 1e-6 > STALE_S:
            return None
        return square(self._square[1] + self._turn_rad_s * max(0.0, (now_us - self._square[0]) * 1e-6))

    def setpoint(self, now_us: int, vehicle_yaw_rad: float) -> tuple[float, float]:
        """The yaw setpoint now (rad) and its rate (rad/s, fed forward): square to the deck, nearest to the
        vehicle's heading, turning with the deck."""
        deck = self.deck_square(now_us) if self.enabled else None
        if deck is None:
            return (self._yaw_sp if self.enabled and self._square is not None else self.own_yaw_rad), 0.0
        target = nearest_square(deck, vehicle_yaw_rad)
        step = max(-YAW_ERROR_MAX_RAD, min(YAW_ERROR_MAX_RAD, wrap_pi(target - vehicle_yaw_rad)))
        self._yaw_sp = wrap_pi(vehicle_yaw_rad + step)
        return self._yaw_sp, max(-TURN_FF_MAX_RAD_S, min(TURN_FF_MAX_RAD_S, self._turn_rad_s))

    def off_square_rad(
        self, now_us: int, vehicle_yaw_rad: float, yaw_rate_rad_s: float = 0.0, ahead_s: float = 0.0
    ) -> float | None:
        """The vehicle's heading off square to the deck (rad, in [-pi/4, pi/4)) ``ahead_s`` from now, the vehicle
        turning on at ``yaw_rate_rad_s`` and the deck at its turn rate; None when no deck heading is known (or
        PLD_DECK_YAW is 0)."""
        deck = self.deck_square(now_us + int(ahead_s * 1e6)) if self.enabled else None
        if deck is None:
            return None
        return square(vehicle_yaw_rad + yaw_rate_rad_s * ahead_s - deck)

    def aligned(self, now_us: int, vehicle_yaw_rad: float) -> bool:
        """True when the vehicle's heading is within ALIGNED_RAD of square to the deck (or no alignment is asked)."""
        off = self.off_square_rad(now_us, vehicle_yaw_rad)
        return off is None or abs(off) <= ALIGNED_RAD
