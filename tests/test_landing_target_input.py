"""LANDING_TARGET in the flight controller (autopilot/landing_target_input.py): what counts, what is
refused (once per reason), and the attitude at capture."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink

from autopilot.landing_target_input import LandingTargetInput
from autopilot.param_catalogue import default_store
from autopilot.topics import VehicleEstimate
from mavsim_core import quaternion


def _estimate(t_us: int, pos=(0.0, 0.0, -3.0)) -> VehicleEstimate:
    return VehicleEstimate(
        timestamp_us=t_us,
        q_wxyz=np.array([1.0, 0.0, 0.0, 0.0]),
        rate_frd_rad_s=np.zeros(3),
        accel_ned_m_s2=np.zeros(3),
        pos_ned_m=np.array(pos),
        vel_ned_m_s=np.zeros(3),
        attitude_valid=True,
        position_valid=True,
        origin_lat_deg=47.0,
        origin_lon_deg=8.0,
        origin_alt_amsl_m=400.0,
    )


def _body_msg(x: float, y: float, z: float, t_us: int, frame: int = mavlink.MAV_FRAME_BODY_FRD):
    return mavlink.MAVLink_landing_target_message(
        t_us, 0, frame, 0.0, 0.0, math.hypot(x, y, z), 0.1, 0.1, x, y, z, [1, 0, 0, 0], 4, 1
    )


def _with_history(lt: LandingTargetInput, q=(1.0, 0.0, 0.0, 0.0), until_us: int = 500_000) -> None:
    for t in range(0, until_us + 1, 4000):
        lt.record_state(t, np.array(q), np.array([0.0, 0.0, -3.0]), 3.0)


def test_body_form_is_rotated_with_the_attitude_at_capture_not_at_receipt():
    lt = LandingTargetInput(default_store())
    yaw90 = quaternion.from_euler(0.0, 0.0, math.pi / 2)
    for t in range(0, 500_001, 4000):  # yaw 0 until 0.3 s, then 90 deg
        lt.record_state(t, np.array([1.0, 0, 0, 0]) if t < 300_000 else yaw90, np.array([0.0, 0.0, -3.0]), 3.0)
    lt.on_message(_body_msg(1.0, 0.0, 2.7, 250_000), 1, 500_000)  # captured at yaw 0: 1 m ahead = north
    target = lt.update(500_000, _estimate(500_000))
    assert target is not None
    assert target.rel_pos_ned_m[0] == pytest.approx(1.0, abs=0.05) and abs(target.rel_pos_ned_m[1]) < 0.05


@pytest.mark.parametrize(
    "msg, reason",
    [
        (_body_msg(math.nan, 0.0, 2.0, 100_000), "not finite"),
        (_body_msg(0.1, 0.0, 2.0, 100_000, frame=mavlink.MAV_FRAME_GLOBAL_INT), "unsupported"),
    ],
)
def test_bad_landing_target_changes_nothing_and_is_reported_once(msg, reason):
    lt = LandingTargetInput(default_store())
    _with_history(lt)
    for _ in range(5):
        lt.on_message(msg, 1, 400_000)
    assert lt.update(400_000, _estimate(400_000)) is None and not lt.estimate.valid
    events = lt.pop_events()
    assert len(events) == 1 and reason in events[0]
    lt.on_message(msg, 1, 420_000)
    assert lt.pop_events() == []  # the same reason is not repeated


def test_landing_target_from_another_system_is_ignored():
    lt = LandingTargetInput(default_store())
    _with_history(lt)
    lt.on_message(_body_msg(0.2, 0.1, 2.0, 400_000), 42, 400_000)
    assert lt.update(400_000, _estimate(400_000)) is None
    assert lt.ignored_other_system == 1 and lt.accepted == 0 and lt.pop_events() == []


def test_a_measurement_is_moved_on_to_now_from_where_the_vehicle_was_at_capture():
    """Captured 0.1 s ago from 0.1 m further south: the target is 0.1 m less north of the vehicle now."""
    lt = LandingTargetInput(default_store())
    for t in range(0, 500_001, 4000):
        lt.record_state(t, np.array([1.0, 0, 0, 0]), np.array([-0.1 if t <= 400_000 else 0.0, 0.0, -3.0]), 3.0)
    lt.on_message(_body_msg(0.5, 0.0, 2.7, 400_000), 1, 500_000)
    target = lt.update(500_000, _estimate(500_000))
    assert target is not None and target.rel_pos_ned_m[0] == pytest.approx(0.4, abs=0.02)


def test_a_swinging_vehicle_over_a_still_target_leaks_no_tilt_into_the_estimate():
    """Issue 21: the vehicle swings north and back (0.3 m, 2 rad/s, up to 7 deg of pitch) 0.9 m above a still
    target; exact body-FRD fixes captured at 20 Hz from the attitude of their capture arrive 50 ms later.  Each
    is rotated with the attitude at its capture and moved on to now, so the relative estimate follows the truth
    to millimetres; rotated with the attitude at receipt it would be off by ~0.9 m x the tilt change (~2 cm)."""
    store = default_store()
    for name, value in (("LTEST_MEAS_UNC", 0.0005), ("LTEST_VEL_UNC_IN", 4.0), ("LTEST_ACC_UNC", 5.0)):
        store.set(name, value)
    lt, height, pending, errors = LandingTargetInput(store), 0.9, [], []
    for t_us in range(0, 6_000_000, 4000):
        t = t_us * 1e-6
        pos = np.array([0.3 * math.sin(2.0 * t), 0.0, -height])
        vel, acc = np.array([0.6 * math.cos(2.0 * t), 0.0, 0.0]), np.array([-1.2 * math.sin(2.0 * t), 0.0, 0.0])
        q = quaternion.from_euler(0.0, -math.atan2(acc[0], 9.81), 0.0)  # accelerating north: nose down
        lt.record_state(t_us, q, pos, height)
        if t_us % 50_000 == 0:
            frd = quaternion.to_matrix(q).T @ -pos
            pending.append((t_us + 50_000, _body_msg(*frd.tolist(), t_us)))
        while pending and pending[0][0] <= t_us:
            lt.on_message(pending.pop(0)[1], 1, t_us)
        if t_us % 20_000 == 4000:
            est = replace(_estimate(t_us, tuple(pos)), q_wxyz=q, vel_ned_m_s=vel, accel_ned_m_s2=acc)
            lt.update(t_us, est)
            if t > 2.0:
                errors.append(lt.estimate.rel_pos_ned_m[:2] + pos[:2])
    assert len(errors) > 150 and float(np.abs(errors).max()) < 0.005


@pytest.mark.parametrize("model, within_m", [(1, 0.15), (0, None)])
def test_a_deck_on_a_2m_circle_at_2m_s_is_followed_by_the_turning_deck_model(model, within_m):
    """LANDING_TARGET at 20 Hz, 50 ms late, of a deck on a 2 m circle at 2 m/s below a vehicle hovering 3 m up:
    with PLD_DECK_MDL 1 (the default) the deck's velocity points along the circle (within 0.15 m/s) and its turn
    rate reaches the task; PLD_DECK_MDL 0 (the constant-velocity Kalman) lags the turn by more than 0.3 m/s."""
    params = default_store()
    params.set("PLD_DECK_MDL", model)
    target, err = _circle_followed(params)
    assert target.timestamp_us == 4_000_000
    if within_m is not None:
        assert err < within_m
        assert target.turn_rad_s == pytest.approx(1.0, abs=0.1)
    else:
        assert err > 0.3 and target.turn_rad_s is None


@pytest.mark.parametrize("heading", [1, 2, 0])
def test_pld_deck_hdg_0_keeps_a_marker_turned_on_its_deck_out_of_the_deck_model(heading):
    """A marker lying 20 deg off its ground vehicle's axes (LANDING_TARGET's orientation says so) on a 2 m circle at
    2 m/s: PLD_DECK_HDG 1 (its lag behind the axle learnt) and 2 (learnt from PLD_DECK_LAG 0) take its heading as the
    vehicle's and bend the deck's velocity toward it; with 0 (the default) the positions alone give the velocity
    along the circle (within 0.15 m/s)."""
    params = default_store()
    params.set("PLD_DECK_HDG", heading)
    _, err = _circle_followed(params, marker_turned_deg=20.0)
    if heading:
        assert err > 0.15
    else:
        assert err < 0.15


def test_pld_deck_hdg_2_starts_from_the_lag_pld_deck_lag_gives():
    """PLD_DECK_HDG 2: the deck model is built with PLD_DECK_LAG as the marker's lag (kept where no heading comes to
    learn it from); a changed PLD_DECK_LAG rebuilds it."""
    params = default_store()
    params.set("PLD_DECK_HDG", 2)
    params.set("PLD_DECK_LAG", 0.15)
    lt = LandingTargetInput(params)
    _circle_with(lt)
    assert lt.deck.lag_m == pytest.approx(0.15) and lt.deck.marker_lag_m == pytest.approx(0.15, abs=1e-3)
    params.set("PLD_DECK_LAG", -0.1)
    _circle_with(lt)
    assert lt.deck.marker_lag_m == pytest.approx(-0.1, abs=1e-3)


def _circle_followed(params, marker_turned_deg: float | None = None):
    """LANDING_TARGET at 20 Hz, 50 ms late, of a deck on a 2 m circle at 2 m/s (1 rad/s clockwise about (0, 2) m),
    a vehicle hovering 3 m up; with ``marker_turned_deg`` the target's orientation is the deck's heading plus that
    (else the zero rotation, no orientation).  The last target the task got and its velocity error after 4 s (m/s)."""
    return _circle_with(LandingTargetInput(params), marker_turned_deg)


def _circle_with(lt: LandingTargetInput, marker_turned_deg: float | None = None):
    """:func:`_circle_followed` with this landing-target input."""
    target = None
    for t in range(0, 4_000_001, 20_000):
        lt.record_state(t, np.array([1.0, 0.0, 0.0, 0.0]), np.array([0.0, 0.0, -3.0]), 3.0)
        if t % 50_000 == 0 and t >= 50_000:
            a = (t - 50_000) * 1e-6  # captured 50 ms ago; the deck's heading then is a
            msg = _body_msg(2.0 * math.sin(a), 2.0 * (1.0 - math.cos(a)), 3.0, t - 50_000)
            if marker_turned_deg is not None:
                msg.q = quaternion.from_euler(0.0, 0.0, a + math.radians(marker_turned_deg)).tolist()
            lt.on_message(msg, 1, t)
        target = lt.update(t, _estimate(t)) or target
    assert target is not None
    truth = np.array([2.0 * math.cos(4.0), 2.0 * math.sin(4.0)])
    return target, float(np.linalg.norm(target.vel_ned_m_s[:2] - truth))
