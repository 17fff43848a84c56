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

Flown in simulated time (``stepped_flight_fixture``): every fault is set between two steps and every
figure is the same in every run; wall-clock timeouts are safety nets only.
"""

from __future__ import annotations

import pytest

from gcs.client import mavlink

from e2e_flight_helpers import Recorder, SteppedFlight, horizontal, record_figure, stepped_flight_fixture, texts_since

pytestmark = pytest.mark.e2e
ALT_M = 5.0
BARO_BIT = mavlink.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
DRIFT_M_S = 0.3  # the barometer's altitude drifts up this fast: 6 m in 20 s (the audit saw 10-12 m)
DRIFT_S = 20.0

flight = stepped_flight_fixture()  # one stack, flown in simulated time (tests/e2e_flight_helpers.py)


def baro_healthy(f: SteppedFlight) -> bool:
    return bool(f.client.latest("SYS_STATUS").onboard_control_sensors_health & BARO_BIT)


def vertical_excursion(f: SteppedFlight, hold) -> float:
    """How far the true vehicle went up or down from the hover point since it, m."""
    return max(abs(s.pos_ned_m[2] - hold.pos_ned_m[2]) for s in f.truth_since(hold.time_ms))


def test_a_gps_height_glitch_is_blamed_on_the_gps_not_the_barometer(flight):
    """The GPS height jumps 8 m (SIM_GPS_GLITCH_D) while its velocity does not: the GPS is at fault, the
    barometer stays the height reference and the vehicle does not move."""
    f = flight
    hold = f.take_off(ALT_M)
    n = len(f.client.statustexts)
    f.set_sim("SIM_GPS_GLITCH_D", 8.0)
    try:
        f.text_seen(n, "GPS height inconsistent with the barometer", 10.0)
        f.wait(3.0)
        assert baro_healthy(f)
    finally:
        f.set_sim("SIM_GPS_GLITCH_D", 0.0)
    f.text_seen(n, "GPS height consistent again", 20.0)
    record_figure("gps_glitch_vertical_m", vertical_excursion(f, hold), 0.5, unit="m")
    assert not any("Barometer" in t for t in texts_since(f.client, n))


def test_a_stuck_barometer_is_found_and_the_height_held_on_gps(flight):
    """A frozen barometer (SIM_BARO_STUCK) fails its stale-data check within a second; the GPS height
    then holds the vehicle's altitude for as long as it lasts."""
    f = flight
    hold = f.take_off(ALT_M)
    n = len(f.client.statustexts)
    f.set_sim("SIM_BARO_STUCK", 1)
    try:
        f.text_seen(n, "Barometer failed: stale data", 2.0)
        f.wait(8.0)
        # 0.04-0.55 m over 26 seeds, then 0.89 m with E2E_SEED=43 (the seventh hunt): the GPS height was taken raw,
        # its offset from the barometer's moved the vehicle; in the barometer's frame since, 0.11-0.13 m (seeds
        # 5, 43, 111; autopilot/estimation/height_sources.py, docs/testing.md)
        record_figure("baro_stuck_vertical_m", vertical_excursion(f, hold), 0.7, unit="m")
        assert not baro_healthy(f)
    finally:
        f.set_sim("SIM_BARO_STUCK", 0)
    f.text_seen(n, "Barometer healthy again", 20.0)


def test_a_drifting_barometer_is_found_and_the_height_held_on_gps(flight):
    """Issue 18 finding 9: the barometer reads higher and higher; before the fix the vehicle sank to the
    ground in silence.  Now it is failed once its disagreement with the GPS height passes EKF2_BARO_GATE
    (5 SD: about 1.3 m here), and the vehicle climbs back onto its hover point on the GPS height."""
    f = flight
    hold = f.take_off(ALT_M)
    n = len(f.client.statustexts)
    f.set_sim("SIM_BARO_DRIFT", DRIFT_M_S)
    try:
        f.wait(DRIFT_S)
        sink = max(s.pos_ned_m[2] - hold.pos_ned_m[2] for s in f.truth_since(hold.time_ms))  # m, + is below
        now = f.truth_now().pos_ned_m[2] - hold.pos_ned_m[2]
        texts = texts_since(f.client, n)
        print(f"barometer drifting {DRIFT_M_S} m/s: {texts}; sank at most {sink:.2f} m, now {now:+.2f} m")
        assert any("Barometer failed: inconsistent with GPS height" in t for t in texts), texts
        assert not baro_healthy(f), "SYS_STATUS still says the barometer is healthy"
        # 1.15-1.73 m over 26 seeds (docs/testing.md): the gate (5 SD, ~1.3 m) and the climb back; the old
        # silent sink went to the ground (5 m).  The height held on GPS alone: 0.03-0.61 m over 35 seeds
        # (seeds 7 and 201-220 went past the first limit, 0.5 m: GPS height's own error, not a sink)
        record_figure("baro_drift_sink_m", sink, 2.2, unit="m")
        record_figure("baro_drift_offset_after_m", abs(now), 0.8, unit="m")
        assert f.client.mode_name() == "LOITER" and f.client.armed()
    finally:
        f.set_sim("SIM_BARO_DRIFT", -2 * DRIFT_M_S)  # back twice as fast, half as long: the error undone
        f.wait(DRIFT_S / 2)
        f.set_sim("SIM_BARO_DRIFT", 0.0)
    f.text_seen(n, "Barometer healthy again", 20.0)
    f.until(lambda: baro_healthy(f), 10.0, "the barometer healthy in SYS_STATUS")
    f.land()


def test_a_motor_lost_in_a_hover_is_reported_at_once_and_the_wreck_disarmed(flight):
    """PX4's defaults: CBRK_FLIGHTTERM 121212 (no flight termination), so the detector reports (CRITICAL
    STATUSTEXT, HEARTBEAT EMERGENCY) and the motors run on while the vehicle falls; on the ground, where
    the position controller would keep its motors at full thrust, it is disarmed (FS_CRASH_CHECK)."""
    f = flight
    client = f.client
    assert client.param_get("CBRK_FLIGHTTERM") == 121212
    hold = f.take_off(ALT_M)
    print(f"hovering at {hold.pos_ned_m[2]:+.2f} m (down, truth), {client.relative_alt_m():.2f} m up (estimate)")
    n = len(client.statustexts)
    with Recorder(client, ("HEARTBEAT",)) as rec:
        t0 = f.set_sim("SIM_ENGINE_FAIL", 1)
        try:
            f.until(lambda: f.truth_now().pos_ned_m[2] > -0.3, 20.0, "on the ground", every_s=0.05)
            t_ground = f.now_s
            f.wait(5.0)
        finally:
            f.set_sim("SIM_ENGINE_FAIL", 0)
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
    record_figure("motor_loss_found_after_s", found[0].sim_time_s - t0, 2.0, unit="s")
    assert disarmed is not None and not client.armed(), f"still armed on the ground ({texts})"
    states = [m.system_status for m in rec.of("HEARTBEAT") if m.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED]
    assert mavlink.MAV_STATE_EMERGENCY in states, f"armed HEARTBEAT states: {sorted(set(states))}"
    assert client.latest("HEARTBEAT").system_status == mavlink.MAV_STATE_EMERGENCY  # disarmed by a failsafe
    record_figure(
        "motor_loss_drift_m",
        max(horizontal(s.pos_ned_m, hold.pos_ned_m) for s in f.truth_since(hold.time_ms)),
        5.0,
        unit="m",
    )
