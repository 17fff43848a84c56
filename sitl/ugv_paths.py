"""Paths for the ground vehicle (UGV): straight line, circle, figure-8, random waypoints.

World frame NED in metres, yaw in radians from North towards East (positive = turning
right, clockwise seen from above).  A path is a chain of segments, each a straight line
or a circular arc of signed curvature k (1/m, k > 0 turns right); the target moves along
it at a speed profile that starts at rest and accelerates at ``accel_m_s2`` up to the set
speed.  Everything is a pure function of time (seconds since the path started).

:func:`unicycle_command` turns the target and the vehicle's pose into a forward speed and
a yaw-rate command for a unicycle (Kanayama's tracking law), clipped to the limits.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class UgvLimits:
    """Drive limits: forward speed (m/s), longitudinal acceleration (m/s^2), yaw rate (rad/s)."""

    speed_max_m_s: float = 4.5  # MBZIRC 2017's truck drove its figure-8 at 4.2 m/s (15 km/h)
    accel_m_s2: float = 1.5
    yaw_rate_max_rad_s: float = 1.5


@dataclass(frozen=True)
class Segment:
    """A straight line (``curvature_1_m`` 0) or an arc, ``length_m`` long (may be ``math.inf``)."""

    length_m: float
    curvature_1_m: float = 0.0


@dataclass(frozen=True)
class Pose2:
    """Planar pose in NED: north, east (m), yaw (rad)."""

    north_m: float
    east_m: float
    yaw_rad: float


@dataclass(frozen=True)
class PathTarget:
    """The target on the path at one time: pose (NED m, rad), velocity (NED m/s), speed, yaw rate."""

    pose: Pose2
    velocity_ne_m_s: tuple[float, float]
    speed_m_s: float
    yaw_rate_rad_s: float
    accel_m_s2: float


@dataclass(frozen=True)
class UnicycleCommand:
    """Forward speed (m/s, body x) and yaw rate (rad/s, NED: positive turns right)."""

    speed_m_s: float
    yaw_rate_rad_s: float


def _advance(p: Pose2, seg_curvature: float, d: float) -> Pose2:
    """Pose after ``d`` metres along a line/arc of curvature ``seg_curvature`` from ``p``."""
    if seg_curvature == 0.0:
        return Pose2(p.north_m + d * math.cos(p.yaw_rad), p.east_m + d * math.sin(p.yaw_rad), p.yaw_rad)
    yaw = p.yaw_rad + seg_curvature * d
    k = seg_curvature
    return Pose2(
        p.north_m + (math.sin(yaw) - math.sin(p.yaw_rad)) / k,
        p.east_m - (math.cos(yaw) - math.cos(p.yaw_rad)) / k,
        yaw,
    )


@dataclass(frozen=True)
class UgvPath:
    """A chain of segments from ``start``, driven at ``speed_m_s`` within ``limits``.

    ``periodic``: the chain repeats (circle, figure-8); otherwise the last segment
    continues straight on past its end.
    """

    start: Pose2
    segments: tuple[Segment, ...]
    speed_m_s: float
    limits: UgvLimits = UgvLimits()
    periodic: bool = False

    def __post_init__(self) -> None:
        if not 0.0 <= self.speed_m_s <= self.limits.speed_max_m_s:
            raise ValueError(f"speed {self.speed_m_s} m/s outside [0, {self.limits.speed_max_m_s}]")

    def distance_m(self, t_s: float) -> tuple[float, float, float]:
        """Arc length (m), speed (m/s) and acceleration (m/s^2) at time ``t_s`` (trapezoid start)."""
        t = max(0.0, t_s)
        a, v = self.limits.accel_m_s2, self.speed_m_s
        t_ramp = v / a
        if t < t_ramp:
            return 0.5 * a * t * t, a * t, a
        return 0.5 * v * t_ramp + v * (t - t_ramp), v, 0.0

    def pose_at(self, s_m: float) -> tuple[Pose2, float]:
        """Pose and curvature at arc length ``s_m``."""
        p = self.start
        if self.periodic:
            period = sum(seg.length_m for seg in self.segments)
            laps = math.floor(s_m / period)
            s_m -= laps * period
            p = _advance_laps(p, self.segments, laps)
        for seg in self.segments:
            if s_m <= seg.length_m:
                return _advance(p, seg.curvature_1_m, s_m), seg.curvature_1_m
            p = _advance(p, seg.curvature_1_m, seg.length_m)
            s_m -= seg.length_m
        return _advance(p, 0.0, s_m), 0.0

    def target(self, t_s: float) -> PathTarget:
        """Where the vehicle should be at ``t_s`` and how it should move there."""
        s, v, a = self.distance_m(t_s)
        pose, k = self.pose_at(s)
        vel = (v * math.cos(pose.yaw_rad), v * math.sin(pose.yaw_rad))
        return PathTarget(pose, vel, v, v * k, a)


def _advance_laps(p: Pose2, segments: tuple[Segment, ...], laps: int) -> Pose2:
    """A closed chain returns to its start position; each lap adds its net heading change."""
    turn = sum(seg.length_m * seg.curvature_1_m for seg in segments)
    return Pose2(p.north_m, p.east_m, p.yaw_rad + laps * turn)


def straight_line(start: Pose2, speed_m_s: float, limits: UgvLimits = UgvLimits()) -> UgvPath:
    """Straight on from ``start`` for ever."""
    return UgvPath(start, (Segment(math.inf),), speed_m_s, limits)


def circle(
    start: Pose2, radius_m: float, speed_m_s: float, limits: UgvLimits = UgvLimits(), clockwise: bool = True
) -> UgvPath:
    """A circle of ``radius_m`` through ``start``, tangent to its heading (clockwise from above)."""
    k = (1.0 if clockwise else -1.0) / radius_m
    return UgvPath(start, (Segment(2 * math.pi * radius_m, k),), speed_m_s, limits, periodic=True)


def figure8(start: Pose2, radius_m: float, speed_m_s: float, limits: UgvLimits = UgvLimits()) -> UgvPath:
    """Two circles of ``radius_m`` touching at ``start``: one clockwise, then one counter-clockwise."""
    lap = 2 * math.pi * radius_m
    return UgvPath(
        start, (Segment(lap, 1.0 / radius_m), Segment(lap, -1.0 / radius_m)), speed_m_s, limits, periodic=True
    )


def random_waypoints(
    start: Pose2,
    speed_m_s: float,
    rng: np.random.Generator,
    limits: UgvLimits = UgvLimits(),
    count: int = 100,
    leg_m: tuple[float, float] = (3.0, 15.0),
    turn_radius_m: float = 3.0,
) -> UgvPath:
    """Random waypoints joined by straight legs and arcs of ``turn_radius_m`` (seeded ``rng``).

    Each leg is ``leg_m`` long (uniform), and each turn to the next waypoint up to 120 deg
    either way; the arcs keep the yaw rate at speed/radius.
    """
    segs: list[Segment] = []
    for _ in range(count):
        segs.append(Segment(float(rng.uniform(*leg_m))))
        turn = float(rng.uniform(-2 * math.pi / 3, 2 * math.pi / 3))
        segs.append(Segment(abs(turn) * turn_radius_m, math.copysign(1.0 / turn_radius_m, turn)))
    return UgvPath(start, tuple(segs), speed_m_s, limits)


def wrap_pi(a: float) -> float:
    """Angle wrapped to [-pi, pi)."""
    return (a + math.pi) % (2 * math.pi) - math.pi


def unicycle_command(
    target: PathTarget,
    pose: Pose2,
    limits: UgvLimits = UgvLimits(),
    gains: tuple[float, float, float] = (1.0, 0.5, 2.0),
) -> UnicycleCommand:
    """Kanayama's tracking law: feed-forward speed/yaw rate plus feedback on the pose error.

    ``gains`` = (k_x in 1/s, k_y in rad/m^2, k_yaw in rad/m; the last two are multiplied by
    the speed).  The error is taken in the vehicle's frame (x forward, y right).  The result
    is clipped to the speed and yaw-rate limits; the acceleration limit is the wheel
    controller's job (:class:`sitl.ugv.UgvDrive`).
    """
    kx, ky, kyaw = gains
    dn, de = target.pose.north_m - pose.north_m, target.pose.east_m - pose.east_m
    c, s = math.cos(pose.yaw_rad), math.sin(pose.yaw_rad)
    ex, ey = c * dn + s * de, -s * dn + c * de
    eyaw = wrap_pi(target.pose.yaw_rad - pose.yaw_rad)
    v = target.speed_m_s * math.cos(eyaw) + kx * ex
    w = target.yaw_rate_rad_s + target.speed_m_s * (ky * ey + kyaw * math.sin(eyaw))
    v = min(max(v, -limits.speed_max_m_s), limits.speed_max_m_s)
    w = min(max(w, -limits.yaw_rate_max_rad_s), limits.yaw_rate_max_rad_s)
    return UnicycleCommand(v, w)
