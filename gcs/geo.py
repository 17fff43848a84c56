"""Flat-earth conversion between NED offsets and latitude/longitude/altitude.

Good to centimetres over the few hundred metres a demo flies:
``dlat = north / R`` and ``dlon = east / (R cos lat0)`` radians with
R = 6378137 m (WGS-84 equatorial radius); altitude is AMSL metres, so
``alt = alt0 - down``.
"""

from __future__ import annotations

import math

EARTH_RADIUS_M = 6378137.0


def ned_to_global(
    lat0_deg: float, lon0_deg: float, alt0_amsl_m: float, north_m: float, east_m: float, down_m: float
) -> tuple[float, float, float]:
    """(lat deg, lon deg, alt AMSL m) of a point ``north/east/down`` metres from the reference."""
    lat_deg = lat0_deg + math.degrees(north_m / EARTH_RADIUS_M)
    lon_deg = lon0_deg + math.degrees(east_m / (EARTH_RADIUS_M * math.cos(math.radians(lat0_deg))))
    return lat_deg, lon_deg, alt0_amsl_m - down_m


def global_to_ned(
    lat0_deg: float, lon0_deg: float, alt0_amsl_m: float, lat_deg: float, lon_deg: float, alt_amsl_m: float
) -> tuple[float, float, float]:
    """(north m, east m, down m) of a point relative to the reference (inverse of ned_to_global)."""
    north_m = math.radians(lat_deg - lat0_deg) * EARTH_RADIUS_M
    east_m = math.radians(lon_deg - lon0_deg) * EARTH_RADIUS_M * math.cos(math.radians(lat0_deg))
    return north_m, east_m, alt0_amsl_m - alt_amsl_m


def deg_to_e7(deg: float) -> int:
    """Degrees to MAVLink degE7 integer."""
    return int(round(deg * 1e7))


def e7_to_deg(value_e7: int) -> float:
    """MAVLink degE7 integer to degrees."""
    return value_e7 * 1e-7
