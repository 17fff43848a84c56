"""Flat-earth conversion between NED offsets and latitude/longitude/altitude.

Good to centimetres over the few hundred metres a demo flies:
``dlat = north / R`` and ``dlon = east / (R cos lat0)`` radians with
R = 6378137 m (WGS-84 equatorial radius); altitude is AMSL metres, so
``alt = alt0 - down``.
"""

from __future__ import annotations

from mavsim_core.geodesy import geodetic_to_ned, ned_to_geodetic


def ned_to_global(
    lat0_deg: float, lon0_deg: float, alt0_amsl_m: float, north_m: float, east_m: float, down_m: float
) -> tuple[float, float, float]:
    """(lat deg, lon deg, alt AMSL m) of a point ``north/east/down`` metres from the reference.

    The same mapping the flight controller uses (:mod:`autopilot.geodesy`), so targets agree.
    """
    return ned_to_geodetic((north_m, east_m, down_m), lat0_deg, lon0_deg, alt0_amsl_m)


def global_to_ned(
    lat0_deg: float, lon0_deg: float, alt0_amsl_m: float, lat_deg: float, lon_deg: float, alt_amsl_m: float
) -> tuple[float, float, float]:
    """(north m, east m, down m) of a point relative to the reference (inverse of ned_to_global)."""
    n, e, d = geodetic_to_ned(lat_deg, lon_deg, alt_amsl_m, lat0_deg, lon0_deg, alt0_amsl_m)
    return float(n), float(e), float(d)


def deg_to_e7(deg: float) -> int:
    """Degrees to MAVLink degE7 integer."""
    return int(round(deg * 1e7))


def e7_to_deg(value_e7: int) -> float:
    """MAVLink degE7 integer to degrees."""
    return value_e7 * 1e-7
