"""Where to aim on the deck so that the vehicle comes to rest at its centre after the motors stop.

The precision landing cuts the motors when the first foot touches the deck.  Until then the vehicle is tilted:
its thrust's horizontal part is what keeps it with a deck that turns (the turn's acceleration across the track) and
holds it against the wind.  With the motors off that part is gone; the vehicle pivots on the foot onto the other
feet and ends displaced against it.  Measured on 60 landings of quad_x on a 2 m circle at 2 m/s in the windy
scenario (the kept logs of two 30-run campaigns, ``benchmarks/touchdown_analysis.py`` and a least-squares fit of the
displacement from the first contact to rest on the thrust's horizontal acceleration at the contact), the
displacement is ``-0.032 s^2 x a_h`` along ``a_h`` (residual 2.7 cm, 3.4 cm across it): 3 cm at a_h 1-2 m/s^2,
8 cm at 2-3, 13 cm at 3-4 (12-18 deg of tilt), while the deck's edges leave quad_x's feet 19 cm of room.

:class:`CutLead` predicts that push at the touch: the deck's acceleration (the vehicle then moves with the deck)
plus the push that holds it against the wind, the thrust's horizontal acceleration less the vehicle's own
(``a_h - a``: the vehicle's manoeuvres cancel out, so the aim does not chase its own corrections), low-passed.  The
aim point is ``PLD_CUT_LEAD x`` that push off the deck's centre (into the turn, upwind), at most MAX_OFFSET_M.
``a_h = g tan(tilt)`` along the thrust's horizontal direction (vertical balance: the descent's acceleration is
small at the contact).

A first version led by the low-passed ``a_h`` alone: the windy circle gained as much, but on the figure-8 the aim
chased the vehicle's own corrections and lagged the deck's reversing turn, the docking was aborted at the 0.2 m
limit 7 times in 11 landings (3 before) and 3 landed where 7 had (the same seeds).

Frames and units: NED, the attitude quaternion ``(w, x, y, z)`` FRD -> NED, m/s^2, metres, seconds.
"""

from __future__ import annotations

import math

import numpy as np

from autopilot.parameters import ParamDef, param
from mavsim_core import quaternion as quat
from mavsim_core.constants import GRAVITY_M_S2

PARAMS: tuple[ParamDef, ...] = (
    param(
        "PLD_CUT_LEAD", 0.032, 0.0, 0.1, "s^2",
        "Precision landing aims off the deck's centre by this times the thrust's horizontal acceleration "
        "(the drift after the motor cut; 0: at the centre; ours)",
    ),
)  # fmt: skip

TAU_S = 0.5  # low-pass time constant of the thrust's horizontal acceleration
MAX_OFFSET_M = 0.15  # the aim point at most this far from the deck's centre
MIN_UP = 0.5  # the thrust axis's upward part is taken as at least this (tilt beyond 60 deg: no lead from it)


def thrust_horizontal_m_s2(q_frd_to_ned: np.ndarray) -> np.ndarray:
    """The thrust's horizontal acceleration (m/s^2, north and east) that balances gravity at this attitude."""
    up = quat.to_matrix(np.asarray(q_frd_to_ned, dtype=float)) @ np.array([0.0, 0.0, -1.0])  # thrust axis, NED
    return GRAVITY_M_S2 * up[:2] / max(-float(up[2]), MIN_UP)


class CutLead:
    """The aim point's offset (see the module docstring); :meth:`reset` at the start of each approach."""

    def __init__(self) -> None:
        self._wind = np.zeros(2)  # the push against the wind (m/s^2, north and east), low-passed
        self._deck = np.zeros(2)  # the deck's latest acceleration (m/s^2)
        self._last_us: int | None = None

    def reset(self) -> None:
        """Start from no offset (the wind's push ramped in over TAU_S by :meth:`update`)."""
        self._wind, self._deck = np.zeros(2), np.zeros(2)
        self._last_us = None

    def update(
        self, now_us: int, q_frd_to_ned: np.ndarray, accel_ned_m_s2: np.ndarray, deck_acc_ned_m_s2: np.ndarray
    ) -> None:
        """One step: the attitude and the vehicle's acceleration (m/s^2 NED, gravity removed) give the wind's push,
        low-passed; ``deck_acc_ned_m_s2`` is the deck's acceleration now.  NaN or time going back: no change."""
        wind = thrust_horizontal_m_s2(q_frd_to_ned) - np.asarray(accel_ned_m_s2, dtype=float)[:2]
        deck = np.asarray(deck_acc_ned_m_s2, dtype=float)[:2]
        if not (np.all(np.isfinite(wind)) and np.all(np.isfinite(deck))):
            return
        if self._last_us is not None and now_us <= self._last_us:
            return
        if self._last_us is not None:
            k = min(1.0, (now_us - self._last_us) * 1e-6 / TAU_S)
            self._wind = self._wind + k * (wind - self._wind)
        self._deck, self._last_us = deck, now_us

    def push_m_s2(self) -> np.ndarray:
        """The thrust's horizontal push expected at the touch (m/s^2, north and east)."""
        return self._deck + self._wind

    def offset_ned_m(self, lead_s2: float) -> np.ndarray:
        """The aim point's offset from the deck's centre (m NED, zero down) for PLD_CUT_LEAD ``lead_s2``."""
        off = lead_s2 * self.push_m_s2()
        n = math.hypot(float(off[0]), float(off[1]))
        if n > MAX_OFFSET_M:
            off = off * (MAX_OFFSET_M / n)
        return np.array([float(off[0]), float(off[1]), 0.0])
