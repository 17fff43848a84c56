"""End-to-end: the estimators in the loop, against ground truth, with GPS faults.

Real ``sitl`` and ``autopilot`` processes (``--speed max``, the simulator's default
sensor errors), a client on the ground-station port and :class:`gcs.sim_client.SimClient`
for ground truth and the ``SIM_*`` failures.  Its instance is a free one (the ``inst``
fixture of conftest.py).  Flown in simulated time (``stepped_flight_fixture``,
tests/e2e_flight_helpers.py): every fault is set between two steps, so every figure is the
same in every run; wall-clock timeouts are safety nets only.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gcs.client import mavlink
from mavsim_core import quaternion as quat

from e2e_flight_helpers import SteppedFlight, horizontal, record_figure, stepped_flight_fixture

pytestmark = pytest.mark.e2e
ALT_M = 5.0
SETTLE_S = 3.0  # simulated seconds in the hover before each test's measurements

flight = stepped_flight_fixture()  # one stack, flown in simulated time


def texts(f: SteppedFlight, fragment: str) -> int:
    """How many STATUSTEXTs so far contain ``fragment``."""
    return sum(fragment in st.text for st in f.client.statustexts)


def test_estimates_stay_close_to_ground_truth_in_flight(flight):
    """EKF attitude and velocity against the simulator's truth while the vehicle flies a 6 m leg."""
    f = flight
    client = f.client
    client.command_long(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_ATTITUDE, 20_000).check()
    f.take_off(ALT_M, settle_s=SETTLE_S)
    msgs = []

    def keep(msg):
        if msg.get_type() in ("ATTITUDE", "LOCAL_POSITION_NED"):
            msgs.append(msg)

    client.add_listener(keep)
    try:
        client.goto_ned(6.0, 0.0, -ALT_M).check()  # m NED from home
        f.until(lambda: client.arrived(6.0, 0.0, 0.5, 0.5), 30.0, "the 6 m leg")
        client.goto_ned(0.0, 0.0, -ALT_M).check()
        f.until(lambda: client.arrived(0.0, 0.0, 0.5, 0.5), 30.0, "back")
    finally:
        client.remove_listener(keep)
    # paired once held: every truth state up to the hold has arrived by then
    d_att, d_yaw, d_vel = [], [], []
    for msg in msgs:
        st = f.truth.state_at(msg.time_boot_ms, within_ms=12)
        if st is None:
            continue
        dt = (msg.time_boot_ms - st.time_usec / 1000.0) / 1000.0
        if msg.get_type() == "ATTITUDE":
            q = quat.integrate(
                np.array(st.attitude_quaternion, dtype=float), np.array([st.rollspeed, st.pitchspeed, st.yawspeed]), dt
            )
            r, p, y = quat.to_euler(q)
            d_att.extend([quat.wrap_pi(msg.roll - r), quat.wrap_pi(msg.pitch - p)])
            d_yaw.append(quat.wrap_pi(msg.yaw - y))
        else:
            d_vel.append(np.array([msg.vx, msg.vy, msg.vz]) - np.array([st.vx, st.vy, st.vz]) / 100.0)
    # Enough pairs for an RMS (in a stepped flight every message pairs: the truth up to the hold has arrived)
    print(f"{len(d_att) // 2} ATTITUDE and {len(d_vel)} LOCAL_POSITION_NED paired with the truth")
    assert len(d_att) > 200 and len(d_vel) >= 10
    rp = math.degrees(math.sqrt(np.mean(np.square(d_att))))
    yaw = math.degrees(math.sqrt(np.mean(np.square(d_yaw))))
    vel = math.sqrt(np.mean(np.sum(np.square(d_vel), axis=1)))
    record_figure("estimate_roll_pitch_rms_deg", rp, 1.0, unit="deg")
    record_figure("estimate_yaw_rms_deg", yaw, 3.0, unit="deg")
    record_figure("estimate_velocity_rms_m_s", vel, 0.2, unit="m/s")
    status = client.latest("ESTIMATOR_STATUS")
    assert status is not None, "no ESTIMATOR_STATUS streamed"
    want = (
        mavlink.ESTIMATOR_ATTITUDE
        | mavlink.ESTIMATOR_VELOCITY_HORIZ
        | mavlink.ESTIMATOR_POS_HORIZ_ABS
        | mavlink.ESTIMATOR_POS_VERT_ABS
    )
    assert status.flags & want == want
    assert status.pos_horiz_ratio < 1.0 and status.vel_ratio < 1.0


def test_gps_glitches_do_not_move_the_vehicle(flight):
    """30 m GPS jumps through SIM_GPS_GLITCH_N: a short one is rejected; one that persists makes
    the filter reset to GPS, the setpoint moves with the reset, so the vehicle stays within 1 m."""
    f = flight
    client = f.client
    point = f.take_off(ALT_M, settle_s=SETTLE_S)
    f.set_sim("SIM_GPS_GLITCH_N", 30.0)
    f.until(lambda: client.latest("ESTIMATOR_STATUS").flags & mavlink.ESTIMATOR_GPS_GLITCH, 10.0, "the GPS_GLITCH flag")
    assert texts(f, "GPS position rejected")
    f.wait(3.0)
    f.set_sim("SIM_GPS_GLITCH_N", 0.0)  # short glitch: over before the reset time
    f.wait(5.0)
    assert not texts(f, "reset")

    f.set_sim("SIM_GPS_GLITCH_N", 30.0)  # persistent: the filter believes GPS after 7 s
    f.until(lambda: texts(f, "position reset to GPS") >= 1, 15.0, "the reset to GPS", every_s=0.5)
    f.wait(5.0)
    f.set_sim("SIM_GPS_GLITCH_N", 0.0)  # and back
    f.until(lambda: texts(f, "position reset to GPS") >= 2, 15.0, "the reset back", every_s=0.5)
    f.wait(3.0)
    worst = max(horizontal(s.pos_ned_m, point.pos_ned_m) for s in f.truth_since(point.time_ms))
    record_figure("gps_glitches_30m_drift_m", worst, 1.0, unit="m")


def test_gps_loss_in_flight_ends_in_a_landing_not_a_fly_away(flight):
    """GPS lost in a hover: the failsafe lands where the vehicle was (no fly-away), and the estimate is
    regained once GPS is back.  (tests/test_e2e_failsafes.py flew the same twice more; issue 33 kept this.)"""
    f = flight
    client = f.client
    point = f.take_off(ALT_M, settle_s=SETTLE_S)
    f.set_sim("SIM_GPS_DISABLE", 1)
    try:
        f.until(lambda: not client.armed(), 60.0, "landed and disarmed without GPS", every_s=0.25)
        assert texts(f, "Position estimate lost: landing")
        end = f.truth_now()
        assert end.pos_ned_m[2] > -0.3, "not on the ground"
        record_figure("gps_loss_landing_drift_m", horizontal(end.pos_ned_m, point.pos_ned_m), 3.0, unit="m")
    finally:
        f.set_sim("SIM_GPS_DISABLE", 0)
    f.until(lambda: texts(f, "Position estimate regained"), 10.0, "Position estimate regained", every_s=0.25)
