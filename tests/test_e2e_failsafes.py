"""End-to-end: the failsafes against the real stack (data link, sticks, battery; the estimator's: see below).

Real ``sitl`` and ``autopilot`` processes (``--speed max``), a pymavlink ground station
(:class:`gcs.client.VehicleClient`, which sends a GCS HEARTBEAT every wall second while it listens:
stopping them is the data link loss), MANUAL_CONTROL sent from the test as a joystick, and
:class:`gcs.sim_client.SimClient` for ground truth and the ``SIM_*`` parameters (the battery drain
SIM_BAT_DRAIN / SIM_BAT_MIN_PCT and the sensor faults).  A user's checks: the STATUSTEXTs, the mode,
the HEARTBEAT's system_status, and where the vehicle truly went.

One stack, flown in simulated time (``stepped_flight_fixture``, tests/e2e_flight_helpers.py): every
command, stick and fault comes between two steps, and the flight controller ages the test's inputs on
simulated time alone (``autopilot --input-clock sim``; the default, both clocks, is unit-tested in
tests/test_failsafes.py), so every figure, the moment of a loss too, is the same in every run; wall-clock
timeouts are safety nets only.  The stepper sends the ground station's HEARTBEAT once a simulated second
(``gcs/launcher/sim_stepper.py``); an infinite ``heartbeat_period_s`` silences it.  One flight after
another, each landed and disarmed before the next take-off; the battery last (the pack stays drained).
"""

from __future__ import annotations

import math

import pytest

from gcs.client import mavlink

from e2e_flight_helpers import Recorder, SteppedFlight, horizontal, record_figure, stepped_flight_fixture, texts_since

pytestmark = pytest.mark.e2e
ALT_M = 4.0
DL_LOSS_T = 5  # COM_DL_LOSS_T, s (its minimum)
RC_LOSS_T = 0.5  # COM_RC_LOSS_T, s (PX4's default)

flight = stepped_flight_fixture()  # one stack, flown in simulated time


def system_states(rec: Recorder) -> set[int]:
    return {m.system_status for m in rec.of("HEARTBEAT")}


def text_seen(f: SteppedFlight, index: int, fragment: str, max_s: float) -> None:
    """Until a STATUSTEXT containing ``fragment`` has come (after the first ``index``), within ``max_s``."""
    f.until(lambda: any(fragment in t for t in texts_since(f.client, index)), max_s, repr(fragment))


def landed(f: SteppedFlight, max_s: float = 60.0) -> None:
    f.until(f.client.landed_and_disarmed, max_s, "landed and disarmed", every_s=0.5)


def sticks(f: SteppedFlight, sim_s: float, throttle: int = 500) -> None:
    """Centred sticks (MANUAL_CONTROL) every 0.05 s of simulated time for ``sim_s`` seconds, as a joystick."""
    for _ in range(round(sim_s / 0.05)):
        f.client.conn.mav.manual_control_send(f.client.target_system, 0, 0, throttle, 0, 0)
        f.wait(0.05)


# --------------------------------------------------------------------------- data link and sticks


def test_data_link_loss_returns_and_lands_and_the_regain_is_reported(flight):
    f = flight
    client = f.client
    client.param_set("NAV_DLL_ACT", 2)  # Return
    client.param_set("COM_DL_LOSS_T", DL_LOSS_T)
    try:
        f.take_off(ALT_M, settle_s=1.0)
        n = len(client.statustexts)
        with Recorder(client, ("HEARTBEAT",)) as rec:
            client.heartbeat_period_s = math.inf  # the ground station falls silent (it still listens) ...
            client.send_heartbeat()  # ... after this one
            t_silent = f.now_s
            text_seen(f, n, "Data link lost: returning", DL_LOSS_T + 1.0)
            lost_after = f.now_s - t_silent
            assert lost_after > DL_LOSS_T, f"lost after {lost_after:.1f} s of silence"
            record_figure("data_link_loss_after_s", lost_after, DL_LOSS_T + 0.5, unit="s")
            f.until(lambda: client.mode_name() == "RTL", 1.0, "mode RTL")
            f.until(lambda: mavlink.MAV_STATE_CRITICAL in system_states(rec), 2.0, "MAV_STATE_CRITICAL")
            client.heartbeat_period_s = 1.0
            client.send_heartbeat()
            text_seen(f, n, "Data link regained", 1.0)
            landed(f)
        assert sum("Data link lost" in t for t in texts_since(client, n)) == 1
        assert client.mode_name() == "RTL"  # regaining the link does not undo the failsafe (the pilot may)
    finally:
        client.heartbeat_period_s = 1.0
        client.param_set("NAV_DLL_ACT", 0)  # PX4's default, report only, for the other flights (the module docstring)


def test_manual_control_loss_lands(flight):
    f = flight
    client = f.client
    client.param_set("NAV_RCL_ACT", 3)  # Land
    f.take_off(ALT_M, settle_s=1.0)
    sticks(f, 0.5)
    client.set_mode("POSCTL").check()
    sticks(f, 1.0)
    n = len(client.statustexts)
    assert client.mode_name() == "POSCTL"
    point = f.truth_now()
    # the sticks stop: lost after COM_RC_LOSS_T of simulated time
    text_seen(f, n, "Manual control lost: landing", RC_LOSS_T + 1.0)
    assert client.mode_name() in ("LAND", "POSCTL")  # the mode change follows in the next HEARTBEAT
    f.until(lambda: client.mode_name() == "LAND", 1.0, "mode LAND")
    landed(f)
    record_figure("rc_loss_landed_from_point_m", horizontal(f.truth_now().pos_ned_m, point.pos_ned_m), 3.0, unit="m")


# --------------------------------------------------------------------------- estimator faults
# The estimator's failsafes in flight (GPS lost: land; GPS glitches: no fly-away) are flown in
# tests/test_e2e_estimation.py, the magnetometer and barometer faults in tests/test_e2e_failure_injection.py and
# tests/test_e2e_failure_detection.py (issue 33: this file flew GPS loss and a GPS glitch a second time).


# --------------------------------------------------------------------------- battery (last: the pack stays drained)


def test_battery_low_warns_critical_returns_emergency_lands(flight):
    f = flight
    client = f.client
    client.param_set("COM_LOW_BAT_ACT", 3)  # return at critical, land at emergency
    f.take_off(ALT_M, settle_s=1.0)
    n = len(client.statustexts)
    with Recorder(client, ("HEARTBEAT",)) as rec:
        f.set_sim("SIM_BAT_MIN_PCT", 12.0)  # low (BAT_LOW_THR 15 %), above critical (7 %)
        f.set_sim("SIM_BAT_DRAIN", 20.0)  # the full pack in 20 simulated seconds
        text_seen(f, n, "Low battery", 30.0)
        f.wait(2.0)
        assert client.mode_name() == "LOITER" and client.armed()
        f.set_sim("SIM_BAT_MIN_PCT", 6.0)  # critical
        text_seen(f, n, "Critical battery", 10.0)
        f.until(lambda: client.mode_name() == "RTL", 1.0, "mode RTL")
        f.until(lambda: mavlink.MAV_STATE_CRITICAL in system_states(rec), 2.0, "MAV_STATE_CRITICAL")
        f.set_sim("SIM_BAT_MIN_PCT", 3.0)  # emergency (BAT_EMERGEN_THR 5 %)
        text_seen(f, n, "Emergency battery", 10.0)
        f.until(lambda: client.mode_name() == "LAND", 1.0, "mode LAND")
        f.until(lambda: mavlink.MAV_STATE_EMERGENCY in system_states(rec), 2.0, "MAV_STATE_EMERGENCY")
        landed(f)
    texts = texts_since(client, n)
    assert any(t.startswith("Low battery") and t.endswith("return advised") for t in texts)
    assert any(t.startswith("Critical battery") and t.endswith(": returning") for t in texts)
    assert any(t.startswith("Emergency battery") and t.endswith(": landing") for t in texts)
    assert sum(t.startswith("Critical battery") for t in texts) == 1
    assert client.battery()[1] is not None and client.battery()[1] <= 5
