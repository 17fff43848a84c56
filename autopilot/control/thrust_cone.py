"""A cone the thrust axis must stay in: the horizontal thrust shortened until the vehicle's down axis lies within a
half-angle of a direction (a camera that must keep a target in view, :mod:`autopilot.navigation.view_limited_catchup`).

The vehicle's down axis is minus the thrust direction (the thrust points along body -z).  Shortening the horizontal
part of the thrust (the vertical part kept, as the tilt limit does) moves the down axis back toward straight down.
A cone that straight down itself is outside of is not enforced (shortening cannot reach it: the target is too far
off to the side for the camera whatever the vehicle does; the guidance has to climb or turn the camera).

Frames and units: NED, thrust in newtons, angles in radians.  Pure.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

BISECT_STEPS = 16  # the horizontal share found to 1/65536


@dataclass(frozen=True, slots=True)
class AxisCone:
    """The vehicle's down axis kept within ``half_angle_rad`` of ``direction_ned`` (any length, NED)."""

    direction_ned: tuple[float, float, float]
    half_angle_rad: float


def _inside(tx: float, ty: float, tz: float, cone: AxisCone, cos_half: float, norm_dir: float) -> bool:
    dn, de, dd = cone.direction_ned
    t = math.sqrt(tx * tx + ty * ty + tz * tz)
    if t <= 0.0:
        return True
    return (-tx * dn - ty * de - tz * dd) / (t * norm_dir) >= cos_half


def horizontal_share(thrust_ned_n: tuple[float, float, float], cone: AxisCone) -> float:
    """The largest share k (0..1) of the horizontal thrust that keeps the down axis inside ``cone`` with the vertical
    thrust kept: 1 when the whole thrust already does (or the cone cannot be met even straight down, or the cone or
    thrust are not usable), else found by bisection."""
    tx, ty, tz = thrust_ned_n
    dn, de, dd = cone.direction_ned
    norm_dir = math.sqrt(dn * dn + de * de + dd * dd)
    values = (tx, ty, tz, norm_dir, cone.half_angle_rad)
    if not all(math.isfinite(v) for v in values) or norm_dir <= 0.0 or tz >= 0.0:
        return 1.0  # (no upward thrust: not flying on it; nothing to limit)
    cos_half = math.cos(max(0.0, min(math.pi, cone.half_angle_rad)))
    if _inside(tx, ty, tz, cone, cos_half, norm_dir) or not _inside(0.0, 0.0, tz, cone, cos_half, norm_dir):
        return 1.0
    lo, hi = 0.0, 1.0  # inside at lo, outside at hi
    for _ in range(BISECT_STEPS):
        mid = 0.5 * (lo + hi)
        if _inside(tx * mid, ty * mid, tz, cone, cos_half, norm_dir):
            lo = mid
        else:
            hi = mid
    return lo
