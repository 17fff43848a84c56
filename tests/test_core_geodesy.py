"""Geodesy (mavsim_core.geodesy): local NED <-> latitude, longitude, altitude.

No sockets, no processes, no clocks.  (From tests/test_units.py, split by subject.)
"""

from __future__ import annotations

import math
import timeit

import numpy as np
import pytest

from mavsim_core.geodesy import geodetic_to_ned, ned_to_geodetic


def test_geodesy_round_trip():
    rng = np.random.default_rng(5)
    for lat0, lon0 in ((47.397742, 8.545594), (-33.9, 151.2), (0.0, 179.9999), (70.0, -179.9999)):
        for _ in range(30):
            ned = rng.uniform(-800, 800, 3)
            lat, lon, alt = ned_to_geodetic(ned, lat0, lon0, 488.0)
            assert -180 <= lon < 180
            assert geodetic_to_ned(lat, lon, alt, lat0, lon0, 488.0) == pytest.approx(ned, abs=1e-6)
    lat, lon, alt = ned_to_geodetic(np.array([111.0, 0.0, -5.0]), 47.0, 8.0, 500.0)
    assert (lat - 47.0) * math.pi / 180 * 6378137.0 == pytest.approx(111.0) and alt == 505.0


# --------------------------------------------------------------------------- against pymap3d (WGS-84)
# The figures quoted in mavsim_core/geodesy.py's docstring, as bounds: the flat-earth mapping on
# one radius against pymap3d's ellipsoid, over 1 km from the start point.

pymap3d = pytest.importorskip("pymap3d", reason="pymap3d is in the test extras: pip install '.[test]'")


def worst_disagreement_1km(lat0: float, lon0: float = 8.545594, alt0: float = 488.0) -> tuple[float, float]:
    """Largest (horizontal, vertical) difference in metres, ours minus pymap3d, at 1 km in every direction."""
    worst_h = worst_v = 0.0
    for az in np.radians(np.arange(0.0, 360.0, 5.0)):
        ned = np.array([1000.0 * math.cos(az), 1000.0 * math.sin(az), -20.0])
        lat, lon, alt = ned_to_geodetic(ned, lat0, lon0, alt0)
        d = np.array(pymap3d.geodetic2ned(lat, lon, alt, lat0, lon0, alt0)) - ned
        worst_h, worst_v = max(worst_h, math.hypot(d[0], d[1])), max(worst_v, abs(d[2]))
    return worst_h, worst_v


@pytest.mark.parametrize("lat0, horizontal_m", [(47.397742, 1.9), (60.0, 2.6), (0.0, 6.6), (-33.9, 3.5)])
def test_disagreement_with_the_ellipsoid_over_1_km(lat0, horizontal_m):
    h, v = worst_disagreement_1km(lat0)
    assert h == pytest.approx(horizontal_m, abs=0.1)  # a scale error of 0.2-0.7 %
    assert v == pytest.approx(1000.0**2 / (2 * 6378137.0), abs=0.005)  # the earth's curvature: 0.08 m


def test_agrees_with_pymap3d_within_3_cm_near_home():
    """Within 10 m of the start point (a hover) the scale error is under 3 cm."""
    lat0, lon0, alt0 = 47.397742, 8.545594, 488.0
    rng = np.random.default_rng(6)
    for ned in rng.uniform(-10.0, 10.0, (50, 3)):
        lat, lon, alt = ned_to_geodetic(ned, lat0, lon0, alt0)
        ref = pymap3d.ned2geodetic(*ned, lat0, lon0, alt0)
        assert np.array(pymap3d.geodetic2ned(lat, lon, alt, lat0, lon0, alt0)) == pytest.approx(ned, abs=0.03)
        assert geodetic_to_ned(*ref, lat0, lon0, alt0) == pytest.approx(ned, abs=0.03)


def test_cost_per_call_against_pymap3d():
    """Printed, not asserted against a fixed figure (the machine varies); ours must not be the slower."""
    lat0, lon0, alt0 = 47.397742, 8.545594, 488.0
    ned = np.array([700.0, -700.0, -20.0])
    lat, lon, alt = ned_to_geodetic(ned, lat0, lon0, alt0)
    n = 2000
    ours = timeit.timeit(lambda: geodetic_to_ned(lat, lon, alt, lat0, lon0, alt0), number=n) / n
    ref = timeit.timeit(lambda: pymap3d.geodetic2ned(lat, lon, alt, lat0, lon0, alt0), number=n) / n
    ours_inv = timeit.timeit(lambda: ned_to_geodetic(ned, lat0, lon0, alt0), number=n) / n
    ref_inv = timeit.timeit(lambda: pymap3d.ned2geodetic(*ned, lat0, lon0, alt0), number=n) / n
    print(
        f"\ngeodetic->NED: ours {ours * 1e6:.1f} us, pymap3d {ref * 1e6:.1f} us; "
        f"NED->geodetic: ours {ours_inv * 1e6:.1f} us, pymap3d {ref_inv * 1e6:.1f} us"
    )
    assert ours < ref and ours_inv < ref_inv
