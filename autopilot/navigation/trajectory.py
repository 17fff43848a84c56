"""Jerk-limited trajectories: position, velocity and acceleration of a move from any state to a goal at rest.

PX4's automatic moves limit speed (MPC_XY_CRUISE), acceleration (MPC_ACC_HOR) and jerk (MPC_JERK_AUTO);
this module plans such a move in closed form.  One axis (:class:`AxisMove`) goes from its state
(position, velocity, acceleration) to a goal with zero velocity and acceleration in at most seven
constant-jerk segments: change the velocity to a peak speed (jerk up, hold the acceleration, jerk
down), cruise, and brake to rest the same way.  The peak speed is the cruise limit when the move is
long enough, else the one (found by bisection) whose braking ends on the goal.  The acceleration is
continuous, the jerk bounded, and the move ends exactly on the goal (no creeping tail).

In 3-D (:class:`Move`) each axis is planned on its own with a share of the limits; the shares'
squares add up to one, so the speed, acceleration and jerk (norms) stay within the limits.  From rest
the shares are the direction cosines of the line to the goal, so every axis is a scaled copy of one
profile and the move is a straight line.  From a moving state (a goal changed mid-move) an axis that
still has to brake gets a share for that too, and the path bends smoothly onto the new goal (there the
norms may pass the limits by a few per cent while an axis that was accelerating ramps its acceleration
down at its jerk limit and the other speeds up: each axis keeps its own share).

Units: metres, m/s, m/s^2, m/s^3 (any frame; the flight tasks use NED); time in seconds from the start.
Pure: no clock, no I/O.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

Segment = tuple[float, float]  # (duration s, jerk m/s^3)
_BISECT_STEPS = 60
MAX_NEEDS_SHARE = 0.9  # axes whose start state needs a share (shares()) take at most this of the limits
_EPS = 1e-9


@dataclass(frozen=True, slots=True)
class Limits:
    """Limits of a move: speed (m/s), acceleration (m/s^2) and jerk (m/s^3), all > 0."""

    speed_m_s: float
    accel_m_s2: float
    jerk_m_s3: float

    def scaled(self, share: float) -> Limits:
        return Limits(self.speed_m_s * share, self.accel_m_s2 * share, self.jerk_m_s3 * share)


def _advance(p: float, v: float, a: float, t: float, j: float) -> tuple[float, float, float]:
    """State (m, m/s, m/s^2) after ``t`` s at constant jerk ``j``."""
    return p + v * t + a * t * t / 2 + j * t * t * t / 6, v + a * t + j * t * t / 2, a + j * t


def velocity_change(v0: float, a0: float, v1: float, accel: float, jerk: float) -> list[Segment]:
    """Constant-jerk segments taking (v0 m/s, a0 m/s^2) to (v1, 0) with |a| <= max(accel, |a0|), |j| <= jerk."""
    v_stop = v0 + a0 * abs(a0) / (2 * jerk)  # the speed reached by ramping the acceleration straight to zero
    if abs(v1 - v_stop) < _EPS:
        return [(abs(a0) / jerk, -math.copysign(jerk, a0))]
    s = 1.0 if v1 > v_stop else -1.0
    a_in, dv = s * a0, s * (v1 - v0)  # in the direction of the change (dv > a_in |a_in| / 2 jerk)
    if a_in > accel:  # above the limit (a smaller limit than the one it was flying): down to it first
        hold = (dv - a_in * a_in / (2 * jerk)) / accel
        return [((a_in - accel) / jerk, -s * jerk), (hold, 0.0), (accel / jerk, -s * jerk)]
    peak = math.sqrt(jerk * dv + a_in * a_in / 2)
    hold = 0.0
    if peak > accel:
        peak, hold = accel, (dv - (2 * accel * accel - a_in * a_in) / (2 * jerk)) / accel
    return [((peak - a_in) / jerk, s * jerk), (max(hold, 0.0), 0.0), (peak / jerk, -s * jerk)]


def _distance(segments: list[Segment], v0: float, a0: float) -> tuple[float, float, float]:
    p, v, a = 0.0, v0, a0
    for t, j in segments:
        p, v, a = _advance(p, v, a, t, j)
    return p, v, a


class JerkPath:
    """Motion through constant-jerk segments from (``p0`` m, ``v0`` m/s, ``a0`` m/s^2): the state at each
    segment's start (``starts``: time, position, velocity, acceleration, jerk) and ``duration_s``."""

    def __init__(self, p0: float, v0: float, a0: float, segs: list[Segment]) -> None:
        self.starts: list[tuple[float, float, float, float, float]] = []
        t, p, v, a = 0.0, p0, v0, a0
        for dur, j in segs:
            if dur > 0:
                self.starts.append((t, p, v, a, j))
                p, v, a = _advance(p, v, a, dur, j)
                t += dur
        self.duration_s = t

    def at(self, t: float) -> tuple[float, float, float, float]:
        """Position, velocity, acceleration and jerk ``t`` s after the start (0 <= t < duration_s; a path
        with segments)."""
        seg = self.starts[0]
        for s in self.starts:
            if s[0] > t:
                break
            seg = s
        t0, p, v, a, j = seg
        p, v, a = _advance(p, v, a, max(t - t0, 0.0), j)
        return p, v, a, j


class AxisMove:
    """One axis from (``p0`` m, ``v0`` m/s, ``a0`` m/s^2) to ``goal`` at rest within ``limits``."""

    def __init__(self, p0: float, v0: float, a0: float, goal: float, limits: Limits) -> None:
        self.goal = goal
        lim = limits
        if lim.speed_m_s <= _EPS or lim.accel_m_s2 <= _EPS or lim.jerk_m_s3 <= _EPS:
            self._build(p0, 0.0, 0.0, [])  # no share of the limits: the axis stays (and ends) where it is
            self.goal = p0
            return
        dist = goal - p0

        def plan(peak: float) -> tuple[list[Segment], float]:
            """The segments through ``peak`` m/s (without a cruise) and the distance they cover."""
            segs = velocity_change(v0, a0, peak, lim.accel_m_s2, lim.jerk_m_s3)
            segs += velocity_change(peak, 0.0, 0.0, lim.accel_m_s2, lim.jerk_m_s3)
            return segs, _distance(segs, v0, a0)[0]

        top = lim.speed_m_s
        hi_segs, hi_d = plan(top)
        lo_segs, lo_d = plan(-top)
        if dist >= hi_d:  # long enough to cruise toward the goal
            segs = hi_segs[:3] + [((dist - hi_d) / top, 0.0)] + hi_segs[3:]
        elif dist <= lo_d:  # a long way back (or moving fast away from it)
            segs = lo_segs[:3] + [((lo_d - dist) / top, 0.0)] + lo_segs[3:]
        else:  # the peak speed whose braking ends on the goal (the distance grows with it)
            lo, hi = -top, top
            for _ in range(_BISECT_STEPS):
                mid = (lo + hi) / 2
                segs, d = plan(mid)
                lo, hi = (mid, hi) if d < dist else (lo, mid)
            segs = plan((lo + hi) / 2)[0]
        self._build(p0, v0, a0, segs)

    def _build(self, p0: float, v0: float, a0: float, segs: list[Segment]) -> None:
        self.path = JerkPath(p0, v0, a0, segs)
        self.duration_s = self.path.duration_s

    def sample(self, t: float) -> tuple[float, float, float, float]:
        """Position (m), velocity (m/s), acceleration (m/s^2) and jerk (m/s^3) ``t`` s after the start;
        before it the start state, from ``duration_s`` on the goal at rest."""
        if t >= self.duration_s:
            return self.goal, 0.0, 0.0, 0.0
        return self.path.at(t)


def shares(delta: np.ndarray, vel: np.ndarray, acc: np.ndarray, limits: Limits) -> np.ndarray:
    """Each axis's share of the limits (squares add up to 1): from rest the line's direction cosines; an axis
    that moves or accelerates also gets a share for stopping that (its stopping distance counts as distance).

    An axis's share is never below what its start state needs: its speed and acceleration within its
    share's limits (the other axes give up the difference; together such axes take at most
    MAX_NEEDS_SHARE while another axis has a way to go).  With less, the axis could not ramp its
    acceleration down in time: a go-to sent as a take-off's climb braked (0.1 m/s up, 1 m/s^2 down, the
    goal 15 m away at the same height) got a 5 % share, took 2 s to end the braking at its share's jerk,
    was then sinking at 1 m/s, and dived 4.4 m before its share's acceleration could stop it."""
    stop = np.abs(vel) * limits.speed_m_s / limits.accel_m_s2 + np.abs(acc) * limits.speed_m_s / limits.jerk_m_s3
    w = np.abs(delta) + stop
    n = float(np.linalg.norm(w))
    share = w / n if n > _EPS else np.zeros(len(delta))
    need = np.minimum(np.maximum(np.abs(vel) / limits.speed_m_s, np.abs(acc) / limits.accel_m_s2), 1.0)
    forced = np.zeros(len(delta), dtype=bool)
    while np.any(short := ~forced & (share < need - _EPS)):
        forced |= short
        rest = float(np.linalg.norm(share[~forced]))
        f = float(np.linalg.norm(need[forced]))
        # the needs take at most MAX_NEEDS_SHARE of the limits while other axes have a way to go (with none,
        # an axis at the cruise speed left a climb none: it stayed, and the setpoint jumped at the end)
        scale = min(1.0, (MAX_NEEDS_SHARE if rest > _EPS else 1.0) / f)
        others = math.sqrt(max(1.0 - (f * scale) ** 2, 0.0)) / rest if rest > _EPS else 0.0
        share = np.where(forced, need * scale, share * others)
    return share


class Move:
    """A jerk-limited move of a point (any number of axes) from a state to ``goal`` at rest.

    ``pos``, ``vel``, ``acc``: the start state (m, m/s, m/s^2); ``limits``: on the norms of the speed,
    acceleration and jerk.  :meth:`sample` gives position, velocity and acceleration (arrays) at a time
    since the start; ``duration_s`` is when every axis has arrived.
    """

    def __init__(self, pos: np.ndarray, vel: np.ndarray, acc: np.ndarray, goal: np.ndarray, limits: Limits) -> None:
        pos, vel, acc = (np.nan_to_num(np.asarray(x, dtype=float)) for x in (pos, vel, acc))
        self.goal = np.asarray(goal, dtype=float).copy()
        self.limits = limits
        share = shares(self.goal - pos, vel, acc, limits)
        self.axes = [
            AxisMove(float(pos[i]), float(vel[i]), float(acc[i]), float(self.goal[i]), limits.scaled(float(share[i])))
            for i in range(len(self.goal))
        ]
        self.duration_s = max((ax.duration_s for ax in self.axes), default=0.0)

    def sample(self, t: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Position (m), velocity (m/s) and acceleration (m/s^2) ``t`` s after the start (the goal at rest from
        ``duration_s`` on)."""
        if t >= self.duration_s:
            return self.goal.copy(), np.zeros(len(self.goal)), np.zeros(len(self.goal))
        rows = [ax.sample(t) for ax in self.axes]
        return (np.array([r[0] for r in rows]), np.array([r[1] for r in rows]), np.array([r[2] for r in rows]))

    def shift(self, delta: np.ndarray) -> None:
        """Move the whole trajectory by ``delta`` (an estimator reset)."""
        self.goal += delta
        for ax, d in zip(self.axes, np.asarray(delta, dtype=float).tolist()):
            ax.goal += d
            ax.path.starts = [(t, p + d, v, a, j) for t, p, v, a, j in ax.path.starts]


class LineProfile:
    """Distance along a line of ``length`` m flown from speed ``v_in`` to ``v_out`` (m/s, both at zero
    acceleration) within ``limits``: a jerk-limited change up to a peak speed, a cruise, a jerk-limited
    change down to ``v_out`` (a mission leg entered and left at speed, :mod:`.mission_leg`).

    The peak is the speed limit when the line is long enough, else the highest whose two changes fit.
    An exit speed that cannot be reached within the line is lowered; an entry speed that cannot brake to
    the exit speed within it is lowered too (the caller's setpoint then steps down, as a shorter line
    than the braking distance leaves no other way).  ``v_in`` and ``v_out`` hold the speeds flown.
    """

    def __init__(self, length_m: float, v_in: float, v_out: float, limits: Limits) -> None:
        L, top = max(float(length_m), 0.0), limits.speed_m_s
        acc, jerk = limits.accel_m_s2, limits.jerk_m_s3

        def change(v0: float, v1: float) -> list[Segment]:
            return velocity_change(v0, 0.0, v1, acc, jerk)

        def covered(v0: float, v1: float) -> float:
            return _distance(change(v0, v1), v0, 0.0)[0]

        v_in, v_out = min(max(v_in, 0.0), top), min(max(v_out, 0.0), top)
        if v_out > v_in and covered(v_in, v_out) > L:
            v_out = _highest(lambda v: covered(v_in, v) <= L, v_in, v_out)
        elif v_in > v_out and covered(v_in, v_out) > L:
            v_in = _highest(lambda v: covered(v, v_out) <= L, v_out, v_in)
        self.length_m, self.v_in, self.v_out = L, v_in, v_out

        def through(peak: float) -> float:
            return covered(v_in, peak) + covered(peak, v_out)

        low = max(v_in, v_out)
        peak = top if through(top) <= L else _highest(lambda v: through(v) <= L, low, top)
        cruise_s = (L - through(peak)) / peak if peak > _EPS else 0.0
        self.path = JerkPath(0.0, v_in, 0.0, change(v_in, peak) + [(max(cruise_s, 0.0), 0.0)] + change(peak, v_out))
        self.duration_s = self.path.duration_s

    def sample(self, t: float) -> tuple[float, float, float]:
        """Distance (m), speed (m/s) and acceleration (m/s^2) along the line ``t`` s after the start: the
        start before it, the end at ``v_out`` from ``duration_s`` on."""
        if t <= 0.0 or not self.path.starts:
            return (0.0, self.v_in, 0.0) if t < self.duration_s else (self.length_m, self.v_out, 0.0)
        if t >= self.duration_s:
            return self.length_m, self.v_out, 0.0
        s, v, a, _ = self.path.at(t)
        return min(s, self.length_m), v, a


def _highest(fits: Callable[[float], bool], lo: float, hi: float) -> float:
    """The highest value in [lo, hi] for which ``fits`` holds, by bisection (``fits(lo)`` is assumed)."""
    for _ in range(_BISECT_STEPS):
        mid = (lo + hi) / 2
        lo, hi = (mid, hi) if fits(mid) else (lo, mid)
    return lo
