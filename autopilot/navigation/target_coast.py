"""The landing target's point moved on in time, between measurements and while it is unseen: at its velocity,
turning at the rate its heading turned, so that a deck driving a circle is predicted on the circle.

A precision landing docks blind (the camera is too close to the deck to see the marker whole) for a second
or more.  Moved on straight, a deck turning at 1 m/s on a 2 m radius is 0.25 m off after 1 s (half its
0.5 m/s^2 times t^2); turned at its turn rate (:class:`TurnRate`: the heading of its measured velocity over
the last second), the prediction stays on the circle.  Below TURNING_FROM_M_S over the ground (a still or
slow deck, whose heading is mostly the marker's noise) the point moves on straight, as before.  The speed
is held (an along-track acceleration is not extrapolated).

Frames and units: NED, metres, m/s, m/s^2, seconds.  Pure.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

TURNING_FROM_M_S = 0.5  # slower than this over the ground: moved on straight
MAX_TURN_RATE_RAD_S = 1.5  # a turn rate is held to this (a 2 m circle at 2 m/s turns at 1 rad/s)
TURN_WINDOW_S = 1.0  # the turn rate is the heading's change over this long
STILL_M_S = 0.2  # a deck slower than this is still: no acceleration fed forward (and precland's docking waits)
TURN_DEAD_BAND_RAD_S = 0.2  # a slower turn is taken for a straight drive's weave and noise ...
TURN_DEAD_BAND_M_S2 = 0.25  # ... and so is one whose acceleration across the track (rate x speed) is smaller


class TurnRate:
    """The target's turn rate (rad/s, positive clockwise seen from above: north toward east) from the headings
    of its measured velocity over the last TURN_WINDOW_S: a rate from the differenced velocity's acceleration
    would turn a straight-driving deck with its noise (measured: 1 m/s line, 0.03 -> 0.04 m mean touchdown)."""

    def __init__(self) -> None:
        self._headings: deque[tuple[int, float]] = deque()  # (time us, unwrapped heading rad)
        self._speed = 0.0  # the latest measured speed over the ground, m/s
        self._model_rad_s: float | None = None  # the deck model's own turn rate, when it has one

    def add(self, t_us: int, vel_ned_m_s: np.ndarray, model_rad_s: float | None = None) -> None:
        """A measured velocity (m/s NED) at ``t_us``; a slow one (below TURNING_FROM_M_S) forgets the headings.
        ``model_rad_s``: the turn rate of a deck model that estimates it (deck_turn_filter), used instead of the
        headings' (still within the dead bands and MAX_TURN_RATE_RAD_S)."""
        self._model_rad_s = model_rad_s if model_rad_s is not None and math.isfinite(model_rad_s) else None
        vx, vy = float(vel_ned_m_s[0]), float(vel_ned_m_s[1])
        if vx * vx + vy * vy < TURNING_FROM_M_S * TURNING_FROM_M_S or not (math.isfinite(vx) and math.isfinite(vy)):
            self._headings.clear()
            return
        h, self._speed = math.atan2(vy, vx), math.hypot(vx, vy)
        if self._headings:
            last = self._headings[-1][1]
            h = last + math.remainder(h - last, math.tau)
            if t_us <= self._headings[-1][0]:
                return
        self._headings.append((t_us, h))
        while len(self._headings) > 2 and self._headings[1][0] <= t_us - TURN_WINDOW_S * 1e6:
            self._headings.popleft()

    def rate(self) -> float:
        """The turn rate over the window (0 without half a window of headings, or inside the dead bands: a
        straight drive's heading noise and weave, extrapolated over 1.5 s blind at 3 m/s, put a landing 1-2 cm
        further off in the benchmark; a 2 m circle at 1 m/s turns at 0.5 rad/s, 0.5 m/s^2)."""
        if self._model_rad_s is not None and self._headings:
            w = self._model_rad_s
        elif len(self._headings) < 2:
            return 0.0
        else:
            (t0, h0), (t1, h1) = self._headings[0], self._headings[-1]
            span_s = (t1 - t0) * 1e-6
            if span_s < 0.5 * TURN_WINDOW_S:
                return 0.0
            w = (h1 - h0) / span_s
        if abs(w) < TURN_DEAD_BAND_RAD_S or abs(w) * self._speed < TURN_DEAD_BAND_M_S2:
            return 0.0
        return max(-MAX_TURN_RATE_RAD_S, min(MAX_TURN_RATE_RAD_S, w))


def coast(
    pos_ned_m: np.ndarray,
    vel_ned_m_s: np.ndarray,
    acc_ned_m_s2: np.ndarray,
    dt_s: float,
    turn_rad_s: float = 0.0,
    move_share: float = 1.0,
) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Position, velocity and acceleration ``dt_s`` later, turning at ``turn_rad_s`` (the velocity and
    acceleration turned with it; straight on below TURNING_FROM_M_S).  Moving straight, the position moves
    by ``move_share`` (0-1) of the velocity: a still deck's measured velocity is the marker's noise, and
    moved on at it for 2 s of blind docking its point drifted 0.1 m."""
    if dt_s <= 0.0:
        return pos_ned_m, vel_ned_m_s, acc_ned_m_s2
    vx, vy, vz = (float(v) for v in vel_ned_m_s)
    w = turn_rad_s if vx * vx + vy * vy >= TURNING_FROM_M_S * TURNING_FROM_M_S else 0.0
    th = w * dt_s
    if abs(th) < 1e-9:
        return pos_ned_m + vel_ned_m_s * (dt_s * move_share), vel_ned_m_s, acc_ned_m_s2
    s, c = math.sin(th), math.cos(th)
    ax, ay, az = (float(a) for a in acc_ned_m_s2)
    moved = np.array([(vx * s - vy * (1.0 - c)) / w, (vy * s + vx * (1.0 - c)) / w, vz * dt_s])
    return (
        pos_ned_m + moved,
        np.array([vx * c - vy * s, vx * s + vy * c, vz]),
        np.array([ax * c - ay * s, ax * s + ay * c, az]),
    )


def acc_weight(target_vel_ned_m_s: np.ndarray) -> float:
    """How much of the target's acceleration to feed forward (0-1) by its speed: none below STILL_M_S / 2, all
    above 1.5 STILL_M_S, linear between (a still deck's differenced velocity is the marker's noise)."""
    speed = math.hypot(float(target_vel_ned_m_s[0]), float(target_vel_ned_m_s[1]))
    return min(1.0, max(0.0, speed / STILL_M_S - 0.5))
