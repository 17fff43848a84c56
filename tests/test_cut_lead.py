"""The precision landing's aim off the deck's centre (autopilot/navigation/cut_lead.py, PLD_CUT_LEAD).

With the motors cut at the first foot's touch, a tilted vehicle loses its thrust's horizontal push and ends
displaced against it (measured: 0.032 s^2 x the push); the landing aims that far the other way.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from autopilot.navigation.cut_lead import MAX_OFFSET_M, CutLead, thrust_horizontal_m_s2
from autopilot.navigation.precland import LandingTargetInput, PrecLandPhase, PrecLandTask
from autopilot.param_catalogue import default_store
from autopilot.topics import VehicleEstimate
from mavsim_core import quaternion as quat
from mavsim_core.constants import GRAVITY_M_S2

STEP_US = 20_000


def test_level_gives_no_push_and_a_tilt_pushes_where_it_leans():
    np.testing.assert_allclose(thrust_horizontal_m_s2(quat.from_euler(0.0, 0.0, 1.0)), [0.0, 0.0], atol=1e-12)
    g_tan20 = GRAVITY_M_S2 * math.tan(math.radians(20.0))
    nose_down = quat.from_euler(0.0, math.radians(-20.0), 0.0)  # facing north: pushed north
    np.testing.assert_allclose(thrust_horizontal_m_s2(nose_down), [g_tan20, 0.0], atol=1e-9)
    right_down = quat.from_euler(math.radians(20.0), 0.0, math.pi / 2)  # facing east, leaning right: south
    np.testing.assert_allclose(thrust_horizontal_m_s2(right_down), [-g_tan20, 0.0], atol=1e-9)


ZERO = np.zeros(3)


def test_the_wind_push_ramps_in_from_zero_to_the_lead_times_the_push_and_is_held_to_its_limit():
    """Leaning 10 deg forward without accelerating: a push against a wind from the north, ramped in."""
    lead, q = CutLead(), quat.from_euler(0.0, math.radians(-10.0), 0.0)
    push = GRAVITY_M_S2 * math.tan(math.radians(10.0))
    np.testing.assert_allclose(lead.offset_ned_m(0.032), 0.0)
    for k in range(5):  # 0.1 s: a fifth of the way at most
        lead.update(k * STEP_US, q, ZERO, ZERO)
    assert 0.0 < lead.offset_ned_m(0.032)[0] < 0.25 * 0.032 * push
    for k in range(5, 200):  # 4 s: there
        lead.update(k * STEP_US, q, ZERO, ZERO)
    np.testing.assert_allclose(lead.offset_ned_m(0.032), [0.032 * push, 0.0, 0.0], atol=1e-4)
    np.testing.assert_allclose(lead.offset_ned_m(0.0), 0.0)
    assert lead.offset_ned_m(0.1)[0] == pytest.approx(MAX_OFFSET_M)  # 0.17 m asked: held to 0.15
    lead.update(200 * STEP_US, np.full(4, math.nan), ZERO, ZERO)  # a NaN attitude changes nothing
    np.testing.assert_allclose(lead.offset_ned_m(0.032), [0.032 * push, 0.0, 0.0], atol=1e-4)
    lead.reset()
    np.testing.assert_allclose(lead.offset_ned_m(0.032), 0.0)


def test_the_vehicles_own_acceleration_is_no_push_and_the_decks_turn_counts_at_once():
    """Leaning 10 deg forward to accelerate north (a correction): no lead; a deck turning with 2 m/s^2 toward
    the east: 0.032 x 2 m east from the first step (the turn reverses within a quarter of a second on a figure-8)."""
    lead, q = CutLead(), quat.from_euler(0.0, math.radians(-10.0), 0.0)
    own = np.array([GRAVITY_M_S2 * math.tan(math.radians(10.0)), 0.0, 0.0])
    for k in range(100):
        lead.update(k * STEP_US, q, own, ZERO)
    np.testing.assert_allclose(lead.offset_ned_m(0.032), 0.0, atol=1e-9)
    level = quat.from_euler(0.0, 0.0, 0.0)
    lead.update(100 * STEP_US, level, ZERO, np.array([0.0, 2.0, 0.0]))
    np.testing.assert_allclose(lead.offset_ned_m(0.032), [0.0, 0.064, 0.0], atol=1e-9)
    lead.update(101 * STEP_US, level, ZERO, np.array([0.0, -2.0, 0.0]))
    np.testing.assert_allclose(lead.offset_ned_m(0.032), [0.0, -0.064, 0.0], atol=1e-9)


def _estimate(t_us: int, pos: np.ndarray, q: np.ndarray) -> VehicleEstimate:
    return VehicleEstimate(
        timestamp_us=t_us, q_wxyz=q, yaw_rad=0.0, rate_frd_rad_s=np.zeros(3), accel_ned_m_s2=np.zeros(3),
        pos_ned_m=pos.copy(), vel_ned_m_s=np.zeros(3), attitude_valid=True, position_valid=True,
        origin_lat_deg=47.0, origin_lon_deg=8.0, origin_alt_amsl_m=400.0,
    )  # fmt: skip


@pytest.mark.parametrize("lead_s2", [0.032, 0.0])
def test_a_vehicle_leaning_east_approaches_and_docks_east_of_the_decks_centre(lead_s2):
    """Held 12 deg right-side-down facing north (a deck turning right, or a wind from the east), the approach's and
    the docking's setpoint sit PLD_CUT_LEAD x g tan(12 deg) east of the deck's centre; PLD_CUT_LEAD 0: on it."""
    store = default_store()
    store.set("PLD_CUT_LEAD", lead_s2)
    task, t = PrecLandTask(0.0, store), 1_000_000
    target, pos = np.array([0.0, 0.0, 0.0]), np.array([0.0, 0.0, -1.2])
    q = quat.from_euler(math.radians(12.0), 0.0, 0.0)
    task.activate(_estimate(t, pos, q), t)
    phases, east = set(), []
    for _ in range(600):  # 12 s, the vehicle held 1.2 m over the deck's centre: the task's phases run on
        t += STEP_US
        sp = task.update(_estimate(t, pos, q), t, LandingTargetInput(t, target - pos, np.zeros(3)))
        phases.add(task.phase)
        if task.phase in (PrecLandPhase.APPROACHING, PrecLandPhase.DOCKING):
            east.append(float(sp.pos_ned_m[1]))
            pos = np.array([sp.pos_ned_m[0], sp.pos_ned_m[1], pos[2]])  # a vehicle that follows horizontally
    want = lead_s2 * GRAVITY_M_S2 * math.tan(math.radians(12.0))  # 6.7 cm
    assert PrecLandPhase.DOCKING in phases and east[-1] == pytest.approx(want, abs=0.002)
    assert abs(east[0]) < 0.01  # ramped in from the deck's centre
