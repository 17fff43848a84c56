"""Local NED (m) <-> latitude, longitude, altitude, on a local tangent plane.

A flat-earth (equirectangular) local projection on a sphere, the kind PX4 and ArduPilot use
for local positions: dlat = north / R, dlon = east / (R cos lat0), altitude = alt0 - down,
with R = 6378137 m (WGS-84 equatorial radius).  The simulator makes its GPS fixes with
:func:`ned_to_geodetic` and the flight controller turns them back with
:func:`geodetic_to_ned`, so positions round-trip exactly (to float rounding) between the two.

Why not ``pymap3d`` (``ned2geodetic`` / ``geodetic2ned``, on the WGS-84 ellipsoid)?  Measured
against it (``tests/test_core_geodesy.py``): over 1 km the two disagree by 1.9 m horizontally
at Zurich (lat 47.4, the default home), 2.6 m at lat 60 and 6.6 m at the equator: a scale
error of 0.2-0.7 % from using one radius instead of the ellipsoid's meridian and normal radii.
Vertically the difference is the earth's curvature, 0.08 m at 1 km, which a tangent plane
ignores by definition.  A call costs 1.4 us here (either direction) against 26 us for
``geodetic2ned`` and 340 us for ``ned2geodetic`` (an iterative ECEF -> geodetic).  Nothing
inside the simulation sees the scale error, since both processes use this mapping; only a
comparison with a map or a real GPS over kilometres would.  So this module stays: PX4's
kind of mapping, 20-250x cheaper, and no change to any flown figure.  ``pymap3d`` is a test
dependency only, as the reference the tests measure this mapping against.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

EARTH_RADIUS_M = 6378137.0


def ned_to_geodetic(
    pos_ned_m: np.ndarray | Sequence[float], lat0_deg: float, lon0_deg: float, alt0_m: float
) -> tuple[float, float, float]:
    """NED offset from a reference -> (lat deg, lon deg, alt m AMSL)."""
    lat = lat0_deg + math.degrees(pos_ned_m[0] / EARTH_RADIUS_M)
    lon = lon0_deg + math.degrees(pos_ned_m[1] / (EARTH_RADIUS_M * math.cos(math.radians(lat0_deg))))
    lon = (lon + 180.0) % 360.0 - 180.0
    return lat, lon, alt0_m - float(pos_ned_m[2])


def geodetic_to_ned(
    lat_deg: float, lon_deg: float, alt_m: float, lat0_deg: float, lon0_deg: float, alt0_m: float
) -> np.ndarray:
    """(lat, lon, alt) -> NED offset (m) from the reference."""
    north = math.radians(lat_deg - lat0_deg) * EARTH_RADIUS_M
    dlon_deg = (lon_deg - lon0_deg + 180.0) % 360.0 - 180.0  # across the antimeridian too
    east = math.radians(dlon_deg) * EARTH_RADIUS_M * math.cos(math.radians(lat0_deg))
    return np.array([north, east, alt0_m - alt_m])
