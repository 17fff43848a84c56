"""Local NED (m) <-> latitude, longitude, altitude, on a local tangent plane.

The flat-earth mapping used by PX4 and ArduPilot for small areas:
dlat = north / R, dlon = east / (R cos lat0), with R = 6378137 m (WGS-84 equatorial
radius).  Over the few hundred metres a flight covers its error is millimetres, and
the flight controller uses the same mapping, so positions round-trip exactly.
"""

from __future__ import annotations

import math

import numpy as np

EARTH_RADIUS_M = 6378137.0


def ned_to_geodetic(pos_ned_m: np.ndarray, lat0_deg: float, lon0_deg: float, alt0_m: float) -> tuple[float, float, float]:
    """NED offset from a reference -> (lat deg, lon deg, alt m AMSL)."""
    lat = lat0_deg + math.degrees(pos_ned_m[0] / EARTH_RADIUS_M)
    lon = lon0_deg + math.degrees(pos_ned_m[1] / (EARTH_RADIUS_M * math.cos(math.radians(lat0_deg))))
    lon = (lon + 180.0) % 360.0 - 180.0
    return lat, lon, alt0_m - float(pos_ned_m[2])


def geodetic_to_ned(lat_deg: float, lon_deg: float, alt_m: float, lat0_deg: float, lon0_deg: float, alt0_m: float) -> np.ndarray:
    """(lat, lon, alt) -> NED offset (m) from the reference."""
    north = math.radians(lat_deg - lat0_deg) * EARTH_RADIUS_M
    dlon_deg = (lon_deg - lon0_deg + 180.0) % 360.0 - 180.0  # across the antimeridian too
    east = math.radians(dlon_deg) * EARTH_RADIUS_M * math.cos(math.radians(lat0_deg))
    return np.array([north, east, alt0_m - alt_m])
