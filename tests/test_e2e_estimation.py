"""End-to-end: the estimators in the loop, against ground truth, with GPS faults.

Real ``sitl`` and ``autopilot`` processes (``--speed max``, the simulator's default
sensor errors), a client on the API port and :class:`gcs.sim_client.SimClient`
for ground truth and the ``SIM_*`` failures.  Durations are simulated seconds.
Its instance is a free one (the ``inst`` fixture of conftest.py).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gcs.client import VehicleClient, mavlink
from gcs.launcher import Stack
from gcs.sim_client import SimClient
from mavsim_core import ports
from mavsim_core import quaternion as quat

pytestmark = pytest.mark.e2e
WAIT_S = 120.0
ALT_M = 5.0


def take_off(client: VehicleClient, truth: SimClient) -> None:
    client.wait_until(client.prearm_ok, WAIT_S, "ready to arm")
    truth.wait_connected()
    client.arm().check()
    client.takeoff(client.wait_home().alt_amsl_m + ALT_M).check()
    client.wait_until(lambda: client.takeoff_done(ALT_M), WAIT_S, "take-off")
    client.wait_sim_time(3.0)


def horizontal_from(truth: SimClient, point) -> float:
    p = truth.latest().pos_ned_m
    return math.hypot(p[0] - point[0], p[1] - point[1])


@pytest.fixture(scope="module")
def flying(inst):
    with (
        Stack(instance=inst, vehicle="quad_x") as stack,
        SimClient(ports.sim_component_port(inst)) as truth,
        VehicleClient(stack.api_url, timeout_s=WAIT_S, idle=stack.check_alive) as client,
    ):
        client.command_long(mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_ATTITUDE, 20_000).check()
        take_off(client, truth)
        yield client, truth


def test_estimates_stay_close_to_ground_truth_in_flight(flying):
    """EKF attitude and velocity against the simulator's truth while the vehicle flies a 6 m leg."""
    client, truth = flying
    d_att, d_yaw, d_vel = [], [], []

    def compare(msg):
        kind = msg.get_type()
        if kind not in ("ATTITUDE", "LOCAL_POSITION_NED"):
            return
        st = truth.state_at(msg.time_boot_ms, within_ms=12)
        if st is None:
            return
        dt = (msg.time_boot_ms - st.time_usec / 1000.0) / 1000.0
        if kind == "ATTITUDE":
            q = quat.integrate(
                np.array(st.attitude_quaternion, dtype=float), np.array([st.rollspeed, st.pitchspeed, st.yawspeed]), dt
            )
            r, p, y = quat.to_euler(q)
            d_att.extend([quat.wrap_pi(msg.roll - r), quat.wrap_pi(msg.pitch - p)])
            d_yaw.append(quat.wrap_pi(msg.yaw - y))
        else:
            d_vel.append(np.array([msg.vx, msg.vy, msg.vz]) - np.array([st.vx, st.vy, st.vz]) / 100.0)

    client.add_listener(compare)
    try:
        client.goto_ned(6.0, 0.0, -ALT_M).check()  # m NED from home
        client.wait_until(lambda: client.arrived(6.0, 0.0, 0.5, 0.5), WAIT_S, "the 6 m leg")
        client.goto_ned(0.0, 0.0, -ALT_M).check()
        client.wait_until(lambda: client.arrived(0.0, 0.0, 0.5, 0.5), WAIT_S, "back")
    finally:
        client.remove_listener(compare)
    # Enough pairs for an RMS; on a loaded machine the truth's UDP stream drops samples (20 of the 12 m of
    # flight once in CI: LOCAL_POSITION_NED is slower than ATTITUDE), so the velocity floor is low.
    assert len(d_att) > 200 and len(d_vel) >= 10
    rp = math.degrees(math.sqrt(np.mean(np.square(d_att))))
    yaw = math.degrees(math.sqrt(np.mean(np.square(d_yaw))))
    vel = math.sqrt(np.mean(np.sum(np.square(d_vel), axis=1)))
    assert rp < 1.0, f"roll/pitch RMS error {rp:.2f} deg"
    assert yaw < 3.0, f"yaw RMS error {yaw:.2f} deg"
    assert vel < 0.2, f"velocity RMS error {vel:.3f} m/s"
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


def test_gps_glitches_do_not_move_the_vehicle(flying):
    """30 m GPS jumps through SIM_GPS_GLITCH_N: a short one is rejected; one that persists makes
    the filter reset to GPS, the setpoint moves with the reset, so the vehicle stays within 1 m."""
    client, truth = flying
    client.wait_sim_time(3.0)
    point = truth.latest().pos_ned_m
    worst = 0.0

    def track(_msg):
        nonlocal worst
        worst = max(worst, horizontal_from(truth, point))

    client.add_listener(track)
    try:
        truth.set("SIM_GPS_GLITCH_N", 30.0)
        client.wait_until(
            lambda: client.latest("ESTIMATOR_STATUS").flags & mavlink.ESTIMATOR_GPS_GLITCH,
            WAIT_S,
            "the GPS_GLITCH flag",
        )
        assert any("GPS position rejected" in st.text for st in client.statustexts)
        client.wait_sim_time(3.0)
        truth.set("SIM_GPS_GLITCH_N", 0.0)  # short glitch: over before the reset time
        client.wait_sim_time(5.0)
        assert not any("reset" in st.text for st in client.statustexts)

        truth.set("SIM_GPS_GLITCH_N", 30.0)  # persistent: the filter believes GPS after 7 s
        client.wait_until(
            lambda: any("position reset to GPS" in st.text for st in client.statustexts), WAIT_S, "the reset to GPS"
        )
        client.wait_sim_time(5.0)
        truth.set("SIM_GPS_GLITCH_N", 0.0)  # and back
        client.wait_until(
            lambda: sum("position reset to GPS" in st.text for st in client.statustexts) >= 2, WAIT_S, "the reset back"
        )
        client.wait_sim_time(3.0)
    finally:
        client.remove_listener(track)
    assert worst < 1.0, f"the vehicle moved {worst:.2f} m during the glitches"


def test_gps_loss_in_flight_ends_in_a_landing_not_a_fly_away(flying):
    client, truth = flying
    point = truth.latest().pos_ned_m
    truth.set("SIM_GPS_DISABLE", 1)
    client.wait_until(lambda: not client.armed(), WAIT_S, "landed and disarmed without GPS")
    assert any("Position estimate lost: landing" in st.text for st in client.statustexts)
    drift = horizontal_from(truth, point)
    assert truth.latest().pos_ned_m[2] > -0.3, "not on the ground"
    assert drift < 3.0, f"drifted {drift:.1f} m while landing without GPS"
    truth.set("SIM_GPS_DISABLE", 0)
