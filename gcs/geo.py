"""What the ground station needs on top of :mod:`mavsim_core.geodesy`.

The maths is the shared core's (the flat-earth mapping the flight controller
uses, so targets and positions agree); here are only the ground station's
argument order (reference first, as a home position is known first) and the
MAVLink degE7 integers.  Degrees, metres; altitudes AMSL; ``down = alt0 - alt``.
"""

from __future__ import annotations

from mavsim_core.geodesy import geodetic_to_ned, ned_to_geodetic

DEG_E7 = 1e7  # MAVLink latitude/longitude integers: degrees * 1e7


def ned_to_global(
    lat0_deg: float, lon0_deg: float, alt0_amsl_m: float, north_m: float, east_m: float, down_m: float
) -> tuple[float, float, float]:
    """(lat deg, lon deg, alt AMSL m) of a point ``north/east/down`` metres from the reference."""
    return ned_to_geodetic((north_m, east_m, down_m), lat0_deg, lon0_deg, alt0_amsl_m)


def global_to_ned(
    lat0_deg: float, lon0_deg: float, alt0_amsl_m: float, lat_deg: float, lon_deg: float, alt_amsl_m: float
) -> tuple[float, float, float]:
    """(north m, east m, down m) of a point relative to the reference (inverse of ned_to_global)."""
    n, e, d = geodetic_to_ned(lat_deg, lon_deg, alt_amsl_m, lat0_deg, lon0_deg, alt0_amsl_m)
    return float(n), float(e), float(d)


def deg_to_e7(deg: float) -> int:
    """Degrees to MAVLink degE7 integer."""
    return int(round(deg * DEG_E7))


def e7_to_deg(value_e7: int) -> float:
    """MAVLink degE7 integer to degrees."""
    return value_e7 * 1e-7
