"""autopilot/navigation/touchdown.py: on the deck, level at a low thrust, then the cut once level (or at the time)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from autopilot.navigation.touchdown import LEVEL_TILT_RAD, MIN_S, THRUST_OF_HOVER, Touchdown
from autopilot.topics import VehicleEstimate
from mavsim_core import quaternion as quat

T0_US = 5_000_000


def estimate(roll_deg: float, pitch_deg: float, yaw_deg: float = 0.0) -> VehicleEstimate:
    r, p, y = (math.radians(a) for a in (roll_deg, pitch_deg, yaw_deg))
    return VehicleEstimate(
        timestamp_us=T0_US,
        q_wxyz=np.asarray(quat.from_euler(r, p, y), dtype=float),
        yaw_rad=y,
        roll_rad=r,
        pitch_rad=p,
        rate_frd_rad_s=np.zeros(3),
        accel_ned_m_s2=np.zeros(3),
        pos_ned_m=np.zeros(3),
        vel_ned_m_s=np.zeros(3),
        attitude_valid=True,
        position_valid=True,
        origin_lat_deg=47.0,
        origin_lon_deg=8.0,
        origin_alt_amsl_m=400.0,
    )


def test_the_setpoint_is_level_at_the_heading_turning_with_the_deck_pressed_on():
    sp = Touchdown(0.6, T0_US).setpoint(math.radians(40.0), -0.9, 0.45)
    np.testing.assert_allclose(sp.q_wxyz, quat.from_euler(0.0, 0.0, math.radians(40.0)), atol=1e-12)
    assert sp.body_rate_frd_rad_s is None and sp.yaw_rate_rad_s == -0.9
    assert sp.thrust_frac == pytest.approx(THRUST_OF_HOVER * 0.45) and sp.thrust_frac < 0.45  # less than the weight


def test_the_cut_waits_for_level_and_at_least_min_s_or_the_time():
    td = Touchdown(0.6, T0_US)
    level, tilted = estimate(0.5, 0.5), estimate(0.0, 9.0)
    assert quat.tilt_rad(level.roll_rad, level.pitch_rad) < LEVEL_TILT_RAD
    assert td.finished(level, T0_US, True) == ""  # level at the first contact may be a swing passing through
    assert td.finished(level, T0_US + int(MIN_S * 1e6) - 1, True) == ""
    assert td.finished(level, T0_US + int(MIN_S * 1e6), False) == ""  # level, but bounced off the deck
    assert td.finished(level, T0_US + int(MIN_S * 1e6), True) == "level on the deck after 0.15 s"
    assert td.finished(tilted, T0_US + 590_000, True) == ""
    assert td.finished(tilted, T0_US + 600_000, True) == "9 deg from level after 0.60 s"  # (a leg on the edge)
    assert td.finished(level, T0_US + 600_000, False) == "1 deg from level after 0.60 s"  # (the time is up)
