"""End-to-end: failures the flight controller must find by itself (issue 18, findings 8 and 9).

Real ``sitl`` and ``autopilot`` processes (``--speed max``), a pymavlink ground station
(:class:`gcs.client.VehicleClient`) and the simulator's own component
(:class:`gcs.sim_client.SimClient`: the truth and the ``SIM_*`` fault parameters).  The flight
controller is told nothing of the faults: it must see them in its sensors.  One stack, one flight
after another in this order (a quadcopter that lost a motor ends upside down, so that flight is last):

1. the GPS height jumps (``SIM_GPS_GLITCH_D``): the GPS is blamed, not the barometer, nothing moves;
2. the barometer freezes (``SIM_BARO_STUCK``): found stale, the GPS height holds the altitude;
3. the barometer drifts (``SIM_BARO_DRIFT``) in a hover: the estimator finds it inconsistent with the
   GPS height (EKF2_BARO_GATE), says so, clears the SYS_STATUS barometer bit and flies on the GPS
   height, so the true altitude stays near the one held; the barometer is healthy again once it
   agrees again;
4. a motor stops (``SIM_ENGINE_FAIL``) in a hover: the failure detector reports it within two seconds,
   HEARTBEAT says EMERGENCY, and the vehicle is disarmed once it lies on the ground (FS_CRASH_CHECK).
   With the designed gains quad_x comes down upright (the mixer gives up thrust to stay level), so
   the thrust-loss check finds it (descending at full throttle, level, for 1 s) and names motor 1;
   a vehicle that flips is found by the attitude checks (FD_FAIL_R/FD_FAIL_P, unit-tested in
   tests/test_failure_detector.py) and disarmed by the same crash check.

Durations are simulated seconds; wall-clock timeouts are safety nets only.
"""

from __future__ import annotations

import pytest

from gcs.client import VehicleClient, mavlink
from gcs.launcher import Stack
from gcs.sim_client import SimClient
from mavsim_core import ports

from e2e_flight_helpers import Recorder, horizontal, texts_since, wait_text

pytestmark = pytest.mark.e2e
WAIT_S = 120.0
ALT_M = 5.0
BARO_BIT = mavlink.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
DRIFT_M_S = 0.3  # the barometer's altitude drifts up this fast: 6 m in 20 s (the audit saw 10-12 m)
DRIFT_S = 20.0


@pytest.fixture(scope="module")
def vehicle(inst):
    with (
        Stack(instance=inst, speed="max") as stack,
        SimClient(ports.sim_component_port(inst)) as truth,
        VehicleClient(stack.gcs_url, timeout_s=WAIT_S, idle=stack.check_alive) as client,
    ):
        truth.wait_connected()
        yield client, truth


def take_off(client: VehicleClient, truth: SimClient):
    """Arm, take off to ALT_M (unless already holding there), settle 2 s; the truth sample of the hover point."""
    if not (client.armed() and client.mode_name() == "LOITER"):
        client.wait_until(client.prearm_ok, WAIT_S, "ready to arm")
        client.arm().check()
        client.takeoff(client.wait_home().alt_amsl_m + ALT_M).check()
    client.wait_until(lambda: client.takeoff_done(ALT_M), WAIT_S, "take-off")
    client.wait_sim_time(2.0)
    return truth.latest()


def baro_healthy(client: VehicleClient) -> bool:
    return bool(client.latest("SYS_STATUS").onboard_control_sensors_health & BARO_BIT)


def drift(client: VehicleClient, truth: SimClient, rate_m_s: float) -> float:
    """Set the barometer's drift rate; the vehicle time it took effect (s)."""
    truth.set("SIM_BARO_DRIFT", rate_m_s)
    return client.sim_time_s()


def test_a_gps_height_glitch_is_blamed_on_the_gps_not_the_barometer(vehicle):
    """The GPS height jumps 8 m (SIM_GPS_GLITCH_D) while its velocity does not: the GPS is at fault, the
    barometer stays the height reference and the vehicle does not move."""
    client, truth = vehicle
    hold = take_off(client, truth)
    n = len(client.statustexts)
    truth.set("SIM_GPS_GLITCH_D", 8.0)
    try:
        wait_text(client, n, "GPS height inconsistent with the barometer")
        client.wait_sim_time(3.0)
        assert baro_healthy(client)
    finally:
        truth.set("SIM_GPS_GLITCH_D", 0.0)
    wait_text(client, n, "GPS height consistent again")
    moved = max(abs(s.pos_ned_m[2] - hold.pos_ned_m[2]) for s in truth.since(hold.time_ms))
    assert moved < 0.5, f"moved {moved:.1f} m vertically ({texts_since(client, n)})"
    assert not any("Barometer" in t for t in texts_since(client, n))


def test_a_stuck_barometer_is_found_and_the_height_held_on_gps(vehicle):
    """A frozen barometer (SIM_BARO_STUCK) fails its stale-data check within a second; the GPS height
    then holds the vehicle's altitude for as long as it lasts."""
    client, truth = vehicle
    hold = take_off(client, truth)
    n = len(client.statustexts)
    truth.set("SIM_BARO_STUCK", 1)
    try:
        wait_text(client, n, "Barometer failed: stale data")
        client.wait_sim_time(8.0)
        moved = max(abs(s.pos_ned_m[2] - hold.pos_ned_m[2]) for s in truth.since(hold.time_ms))
        assert moved < 0.5, f"moved {moved:.1f} m vertically on the GPS height ({texts_since(client, n)})"
        assert not baro_healthy(client)
    finally:
        truth.set("SIM_BARO_STUCK", 0)
    wait_text(client, n, "Barometer healthy again")


def test_a_drifting_barometer_is_found_and_the_height_held_on_gps(vehicle):
    """Issue 18 finding 9: the barometer reads higher and higher; before the fix the vehicle sank to the
    ground in silence.  Now it is failed once its disagreement with the GPS height passes EKF2_BARO_GATE
    (5 SD: about 1.3 m here), and the vehicle climbs back onto its hover point on the GPS height."""
    client, truth = vehicle
    hold = take_off(client, truth)
    n = len(client.statustexts)
    started = drift(client, truth, DRIFT_M_S)
    try:
        client.wait_sim_time(DRIFT_S)
        during = truth.since(hold.time_ms)
        sink = max(s.pos_ned_m[2] - hold.pos_ned_m[2] for s in during)  # m, + is below the hover point
        now = truth.latest().pos_ned_m[2] - hold.pos_ned_m[2]
        texts = texts_since(client, n)
        print(f"barometer drifting {DRIFT_M_S} m/s: {texts}; sank at most {sink:.2f} m, now {now:+.2f} m")
        assert any("Barometer failed: inconsistent with GPS height" in t for t in texts), texts
        assert not baro_healthy(client), "SYS_STATUS still says the barometer is healthy"
        assert sink < 1.5, f"sank {sink:.1f} m on a barometer {DRIFT_M_S * DRIFT_S:.0f} m wrong ({texts})"
        assert abs(now) < 0.5, f"{now:+.1f} m (down) from the hover point on the GPS height"
        assert client.mode_name() == "LOITER" and client.armed()
    finally:
        back = drift(client, truth, -2 * DRIFT_M_S)  # back twice as fast, half as long: the error undone
        client.wait_until(lambda: client.sim_time_s() >= back + (back - started) / 2, WAIT_S, "the drift undone")
        drift(client, truth, 0.0)
    wait_text(client, n, "Barometer healthy again")
    client.wait_until(lambda: baro_healthy(client), WAIT_S, "the barometer healthy in SYS_STATUS")
    client.land().check()
    client.wait_until(client.landed_and_disarmed, WAIT_S, "landed and disarmed")


def test_a_motor_lost_in_a_hover_is_reported_at_once_and_the_wreck_disarmed(vehicle):
    """PX4's defaults: CBRK_FLIGHTTERM 121212 (no flight termination), so the detector reports (CRITICAL
    STATUSTEXT, HEARTBEAT EMERGENCY) and the motors run on while the vehicle falls; on the ground, where
    the position controller would keep its motors at full thrust, it is disarmed (FS_CRASH_CHECK)."""
    client, truth = vehicle
    assert client.param_get("CBRK_FLIGHTTERM") == 121212
    hold = take_off(client, truth)
    n = len(client.statustexts)
    with Recorder(client, ("HEARTBEAT",)) as rec:
        t0 = client.sim_time_s()
        truth.set("SIM_ENGINE_FAIL", 1)
        try:
            client.wait_until(lambda: truth.latest().pos_ned_m[2] > -0.3, WAIT_S, "on the ground")
            t_ground = client.sim_time_s()
            client.wait_sim_time(5.0)
        finally:
            truth.set("SIM_ENGINE_FAIL", 0)
    texts = texts_since(client, n)
    found = [st for st in client.statustexts[n:] if st.text.startswith("Critical failure detected")]
    assert found, f"no failure reported ({texts})"
    disarmed = next((st for st in client.statustexts[n:] if st.text == "Disarmed (crash detected)"), None)
    print(
        f"motor 1 stopped at {t0:.2f} s: reported {found[0].sim_time_s - t0:.2f} s later, on the ground "
        f"{t_ground - t0:.2f} s later, disarmed {disarmed and disarmed.sim_time_s - t0:.2f} s later: {texts}"
    )
    assert found[0].severity == mavlink.MAV_SEVERITY_CRITICAL
    if "thrust loss" in found[0].text:  # (upright: the mixer's outputs name the motor; flipped: roll or pitch)
        assert "likely motor 1" in found[0].text, found[0].text
    assert found[0].sim_time_s - t0 < 2.0, f"found {found[0].sim_time_s - t0:.1f} s after the motor stopped"
    assert disarmed is not None and not client.armed(), f"still armed on the ground ({texts})"
    states = [m.system_status for m in rec.of("HEARTBEAT") if m.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED]
    assert mavlink.MAV_STATE_EMERGENCY in states, f"armed HEARTBEAT states: {sorted(set(states))}"
    assert client.latest("HEARTBEAT").system_status == mavlink.MAV_STATE_EMERGENCY  # disarmed by a failsafe
    fall = truth.since(hold.time_ms)
    assert max(horizontal(s.pos_ned_m, hold.pos_ned_m) for s in fall) < 5.0, "no fly-away"
