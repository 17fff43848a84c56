"""Geodesy (mavsim_core.geodesy): local NED <-> latitude, longitude, altitude.

No sockets, no processes, no clocks.  (From tests/test_units.py, split by subject.)
"""

from __future__ import annotations

import math

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
