"""The geofence: its geometry from the fence plan and the breach check the commander runs at 50 Hz.

Mirrors PX4's geofence (``src/modules/navigator/geofence.cpp`` and its GF_* parameters):

- the fence plan (MAV_MISSION_TYPE_FENCE) holds inclusion and exclusion polygons (runs of
  NAV_FENCE_POLYGON_VERTEX_* items, each carrying the polygon's vertex count in param1) and
  circles (NAV_FENCE_CIRCLE_*, radius in param1); altitudes of fence items are not used; a circle
  of radius 0 (MAVSDK's users send one at (0, 0) when they want none; PX4 stores it) encloses
  nothing and is left out, whether inclusion or exclusion;
- the vehicle must be inside the union of the inclusions (when there is one) and outside every
  exclusion, no farther than GF_MAX_HOR_DIST from home and no higher than GF_MAX_VER_DIST above
  home (0 disables either limit);
- with GF_PREDICT the check is made on the point where the vehicle would stop: the position plus
  the braking distance ``|v|^2 / (2 a)`` and a margin along the velocity (PX4 predicts with the
  position controller's braking distance), so the GF_ACTION (:class:`GfAction`) starts before the
  fence is crossed.  A vehicle at rest is checked at its position, without the margin.

Frames and units: positions are metres NED relative to the estimator origin (the origin given to
:meth:`Geofence.from_items`; vertices mapped with :func:`mavsim_core.geodesy.geodetic_to_ned`),
velocities m/s, accelerations m/s^2, radii and distances m.  The fence is horizontal only: the
height limit is GF_MAX_VER_DIST above home (PX4 has no per-polygon altitudes either).

Polygons are shapely polygons, prepared once in :meth:`Geofence.from_items`; circles are exact
distance tests (no buffered polygon), so one check costs a few microseconds.  Nothing here reads a
clock, opens a socket or speaks MAVLink.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum
from typing import Callable

import numpy as np
import shapely
from shapely.geometry import Polygon

from autopilot.parameters import ParamDef, ParamType, param
from mavsim_core import mission_items as mi
from mavsim_core.geodesy import geodetic_to_ned
from mavsim_core.mission_items import MissionItem

PARAMS: tuple[ParamDef, ...] = (
    param(
        "GF_ACTION", 2, 0, 5, "",
        "Geofence breach action: 0 none, 1 warning, 2 hold mode, 3 return mode, 4 terminate, 5 land mode",
        ParamType.INT32,
    ),
    param("GF_MAX_HOR_DIST", 0.0, 0.0, 10000.0, "m", "Max horizontal distance from home (0: disabled)"),
    param("GF_MAX_VER_DIST", 0.0, 0.0, 10000.0, "m", "Max height above home (0: disabled)"),
    param("GF_PREDICT", 1, 0, 1, "", "Predict the breach from the velocity (stop before the fence)", ParamType.INT32),
)  # fmt: skip

POLYGONS = (mi.FENCE_POLYGON_INCLUSION, mi.FENCE_POLYGON_EXCLUSION)
CIRCLES = (mi.FENCE_CIRCLE_INCLUSION, mi.FENCE_CIRCLE_EXCLUSION)
REST_SPEED_M_S = 1e-6  # below this the vehicle is at rest: no direction to predict along, no margin
MIN_BRAKE_M_S2 = 0.1  # a braking acceleration <= 0 (a bad parameter) is taken as this, never a division by 0

# A limit: (north, east, down) m -> None, or (the reason when the vehicle is past it, when only predicted to be).
Limit = Callable[[float, float, float], tuple[str, str] | None]


class GfAction(IntEnum):
    """GF_ACTION: what the commander does on a breach (PX4's numbers)."""

    NONE = 0
    WARNING = 1
    HOLD = 2
    RETURN = 3
    TERMINATE = 4
    LAND = 5


class FenceError(ValueError):
    """The fence items do not make a fence; the message names the item (seq) and why."""


@dataclass(frozen=True)
class Breach:
    """A breach (or a predicted one) for the commander's STATUSTEXT and GF_ACTION."""

    reason: str  # e.g. "Geofence: approaching the inclusion polygon boundary"
    predicted: bool  # only the predicted point is outside; the vehicle itself is still inside


@dataclass(frozen=True)
class _Circles:
    """Circles as arrays: centres (k, 2) north/east m and squared radii (k,) m^2."""

    centres: np.ndarray
    radii_sq: np.ndarray

    @classmethod
    def of(cls, circles: list[tuple[float, float, float]]) -> _Circles:
        arr = np.array(circles, dtype=float).reshape(-1, 3)
        return cls(arr[:, :2].copy(), arr[:, 2] ** 2)

    def __len__(self) -> int:
        return len(self.radii_sq)

    def contain(self, north: float, east: float) -> bool:
        """The point is in (or on) at least one circle."""
        if not len(self):
            return False
        d = self.centres - (north, east)
        return bool(np.any(d[:, 0] ** 2 + d[:, 1] ** 2 <= self.radii_sq))


def _union(polygons: list[Polygon]) -> shapely.Geometry | None:
    """The polygons' union, prepared for repeated point tests (None without polygons)."""
    if not polygons:
        return None
    geom = shapely.union_all(polygons)
    shapely.prepare(geom)
    return geom


def _in(geom: shapely.Geometry | None, north: float, east: float) -> bool:
    """The point is in (or on the boundary of) the geometry; x is north, y east."""
    return geom is not None and bool(shapely.intersects_xy(geom, north, east))


class Geofence:
    """Inclusion and exclusion polygons and circles, in metres NED north/east from the estimator origin."""

    def __init__(
        self,
        inclusion_polygons: list[Polygon],
        exclusion_polygons: list[Polygon],
        inclusion_circles: list[tuple[float, float, float]],
        exclusion_circles: list[tuple[float, float, float]],
    ) -> None:
        """Polygons in (north, east) m; circles as (north m, east m, radius m)."""
        self.inclusion_polygons = tuple(inclusion_polygons)
        self.exclusion_polygons = tuple(exclusion_polygons)
        self._inc_poly = _union(inclusion_polygons)
        self._exc_poly = _union(exclusion_polygons)
        self._inc_circ = _Circles.of(inclusion_circles)
        self._exc_circ = _Circles.of(exclusion_circles)
        kinds = [k for k, n in (("polygon", len(inclusion_polygons)), ("circle", len(inclusion_circles))) if n]
        self._inclusion_name = "inclusion " + (kinds[0] if len(kinds) == 1 else "fence")

    @classmethod
    def from_items(cls, items: list[MissionItem], origin_lat_deg: float, origin_lon_deg: float) -> Geofence:
        """The fence of a fence plan, placed relative to the origin; :class:`FenceError` if the items are not one.

        A polygon is a run of consecutive items with the same command whose length equals their
        param1 (the vertex count, >= 3); a circle is one item with its radius (m) in param1 (0: left out).
        """
        polys: dict[int, list[Polygon]] = {c: [] for c in POLYGONS}
        circles: dict[int, list[tuple[float, float, float]]] = {c: [] for c in CIRCLES}
        i = 0
        while i < len(items):
            item = items[i]
            if item.command in POLYGONS:
                n = _vertex_count(item)
                run = items[i : i + n]
                same = next(
                    (k for k, v in enumerate(run) if v.command != item.command or v.param1 != item.param1), len(run)
                )
                if same < n:
                    where = f"item {run[same].seq} ends it" if same < len(run) else "the plan ends"
                    raise FenceError(
                        f"item {item.seq} ({item.name}): polygon of {n} vertices has only {same} ({where})"
                    )
                polys[item.command].append(_polygon(run, origin_lat_deg, origin_lon_deg))
                i += n
            elif item.command in CIRCLES:
                if item.param1 != 0:  # radius 0: nothing (mission_checks says so at upload)
                    circles[item.command].append(_circle(item, origin_lat_deg, origin_lon_deg))
                i += 1
            else:
                raise FenceError(f"item {item.seq} ({item.name}): not a fence item")
        return cls(
            polys[mi.FENCE_POLYGON_INCLUSION],
            polys[mi.FENCE_POLYGON_EXCLUSION],
            circles[mi.FENCE_CIRCLE_INCLUSION],
            circles[mi.FENCE_CIRCLE_EXCLUSION],
        )

    @property
    def empty(self) -> bool:
        """No polygon and no circle (the distance and height limits may still apply)."""
        return not (self.has_inclusion or self._exc_poly is not None or len(self._exc_circ))

    @property
    def has_inclusion(self) -> bool:
        return self._inc_poly is not None or len(self._inc_circ) > 0

    def inside(self, pos_ned_m: np.ndarray) -> bool:
        """Horizontally inside the union of the inclusions (if any) and outside every exclusion."""
        north, east = float(pos_ned_m[0]), float(pos_ned_m[1])
        return self._inclusion_ok(north, east) and self._exclusion_hit(north, east) is None

    def _inclusion_ok(self, north: float, east: float) -> bool:
        if not self.has_inclusion:
            return True
        return _in(self._inc_poly, north, east) or self._inc_circ.contain(north, east)

    def _exclusion_hit(self, north: float, east: float) -> str | None:
        """The name of an exclusion the point is in, or None."""
        if _in(self._exc_poly, north, east):
            return "exclusion polygon"
        if self._exc_circ.contain(north, east):
            return "exclusion circle"
        return None

    def check(
        self,
        pos_ned_m: np.ndarray,
        vel_ned_m_s: np.ndarray,
        home_ned_m: np.ndarray | None,
        max_hor_m: float,
        max_ver_m: float,
        predict: bool,
        brake_accel_m_s2: float,
        margin_m: float = 1.0,
    ) -> Breach | None:
        """The breach at this position (or, with ``predict``, at the point where braking now would stop).

        ``max_hor_m``/``max_ver_m``: GF_MAX_HOR_DIST/GF_MAX_VER_DIST (<= 0 or no home: not checked);
        ``brake_accel_m_s2``: the deceleration the stopping distances assume (MPC_ACC_HOR);
        ``margin_m``: added to a moving vehicle's stopping distance.  An actual breach is reported
        before a predicted one; None when neither the position nor the predicted point breaks a limit.
        """
        north, east, down = float(pos_ned_m[0]), float(pos_ned_m[1]), float(pos_ned_m[2])
        actual = (north, east, down)
        pred = stop_point(actual, vel_ned_m_s, brake_accel_m_s2, margin_m) if predict else actual
        limits: list[Limit] = [self._fence_limit]
        if home_ned_m is not None and max_hor_m > 0:
            limits.append(_distance_limit(float(home_ned_m[0]), float(home_ned_m[1]), max_hor_m))
        if home_ned_m is not None and max_ver_m > 0:
            limits.append(_height_limit(float(home_ned_m[2]), max_ver_m))
        found: Breach | None = None
        for limit in limits:
            hit = limit(*actual)
            if hit is not None:
                return Breach(f"Geofence: {hit[0]}", predicted=False)
            if found is None and pred != actual and (hit := limit(*pred)) is not None:
                found = Breach(f"Geofence: {hit[1]}", predicted=True)
        return found

    def _fence_limit(self, north: float, east: float, down: float) -> tuple[str, str] | None:
        """(actual reason, predicted reason) if the point breaks the polygons or circles, else None."""
        if not self._inclusion_ok(north, east):
            name = self._inclusion_name
            return f"outside the {name}", f"approaching the {name} boundary"
        name_or_none = self._exclusion_hit(north, east)
        if name_or_none is not None:
            return f"inside the {name_or_none}", f"approaching the {name_or_none} boundary"
        return None


def stop_point(
    pos: tuple[float, float, float], vel: np.ndarray, brake: float, margin: float
) -> tuple[float, float, float]:
    """Where the vehicle would stop: horizontally along its velocity, vertically only when climbing."""
    north, east, down = pos
    brake = brake if brake > 0 else MIN_BRAKE_M_S2
    vn, ve, vd = float(vel[0]), float(vel[1]), float(vel[2])
    speed = math.hypot(vn, ve)
    if speed > REST_SPEED_M_S and math.isfinite(speed):
        ahead = speed * speed / (2.0 * brake) + margin
        north, east = north + vn / speed * ahead, east + ve / speed * ahead
    if -vd > REST_SPEED_M_S and math.isfinite(vd):
        down -= vd * vd / (2.0 * brake) + margin
    return north, east, down


def _distance_limit(home_north: float, home_east: float, max_hor_m: float) -> Limit:
    def limit(north: float, east: float, down: float) -> tuple[str, str] | None:
        if math.hypot(north - home_north, east - home_east) <= max_hor_m:
            return None
        what = f"max distance {max_hor_m:g} m from home"
        return f"beyond {what}", f"approaching {what}"

    return limit


def _height_limit(home_down: float, max_ver_m: float) -> Limit:
    def limit(north: float, east: float, down: float) -> tuple[str, str] | None:
        if home_down - down <= max_ver_m:
            return None
        what = f"max height {max_ver_m:g} m"
        return f"above {what}", f"approaching {what}"

    return limit


def _vertex_count(item: MissionItem) -> int:
    n = item.param1
    if not (math.isfinite(n) and n == int(n) and n >= 3):
        raise FenceError(f"item {item.seq} ({item.name}): vertex count (param1) {n:g} must be a whole number >= 3")
    return int(n)


def _polygon(run: list[MissionItem], lat0: float, lon0: float) -> Polygon:
    """The polygon of one run of vertices, in (north, east) m; FenceError if it crosses itself."""
    pts = [tuple(geodetic_to_ned(v.lat_deg, v.lon_deg, 0.0, lat0, lon0, 0.0)[:2]) for v in run]
    poly = Polygon(pts)
    if not poly.is_valid:
        why = shapely.is_valid_reason(poly)
        raise FenceError(f"item {run[0].seq} ({run[0].name}): polygon of {len(run)} vertices is not simple: {why}")
    return poly


def _circle(item: MissionItem, lat0: float, lon0: float) -> tuple[float, float, float]:
    r = item.param1
    if not (math.isfinite(r) and r > 0):
        raise FenceError(f"item {item.seq} ({item.name}): radius (param1) {r:g} m must be > 0")
    centre = geodetic_to_ned(item.lat_deg, item.lon_deg, 0.0, lat0, lon0, 0.0)
    return float(centre[0]), float(centre[1]), float(r)
