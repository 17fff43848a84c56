"""End-to-end: the failsafes against the real stack (data link, sticks, battery, estimator faults).

Real ``sitl`` and ``autopilot`` processes (``--speed max``), a pymavlink ground station on the API
port (:class:`gcs.client.VehicleClient`, which sends a GCS HEARTBEAT every second while it listens:
stopping them is the data link loss), MANUAL_CONTROL sent from the test on the wall clock, and
:class:`gcs.sim_client.SimClient` for ground truth and the ``SIM_*`` parameters (the battery drain
SIM_BAT_DRAIN / SIM_BAT_MIN_PCT and the sensor faults).  A user's checks: the STATUSTEXTs, the mode,
the HEARTBEAT's system_status, and where the vehicle truly went.  Three stacks, one per group (links,
battery, estimator faults); the fault group shares one stack and resets between faults (land, disarm,
clear, take off).  Durations are simulated seconds; wall-clock timeouts are safety nets only.
"""

from __future__ import annotations

import math
import time

import pytest

from gcs.client import VehicleClient, mavlink
from gcs.launcher import Stack
from gcs.sim_client import SimClient
from mavsim_core import ports

from e2e_flight_helpers import Recorder, texts_since, wait_text

pytestmark = pytest.mark.e2e
WAIT_S = 120.0
ALT_M = 4.0
NO_FLY_AWAY_M = 10.0


def start(vehicle: str = "quad_x"):
    """A module fixture: (client, truth) of a fresh stack on a free instance."""

    @pytest.fixture(scope="module")
    def fixture(free_instance):
        i = free_instance()
        with (
            Stack(instance=i, vehicle=vehicle, speed="max") as stack,
            SimClient(ports.sim_component_port(i)) as truth,
            VehicleClient(stack.api_url, timeout_s=WAIT_S, idle=stack.check_alive) as client,
        ):
            truth.wait_connected()
            yield client, truth

    return fixture


links = start()
battery = start()
faults = start()


def take_off(client: VehicleClient) -> None:
    client.wait_until(client.prearm_ok, WAIT_S, "ready to arm")
    client.arm().check()
    client.takeoff(client.wait_home().alt_amsl_m + ALT_M).check()
    client.wait_until(lambda: client.takeoff_done(ALT_M), WAIT_S, "take-off")
    client.wait_sim_time(1.0)


def system_states(rec: Recorder) -> set[int]:
    return {m.system_status for m in rec.of("HEARTBEAT")}


def wait_landed(client: VehicleClient) -> None:
    client.wait_until(client.landed_and_disarmed, WAIT_S, "landed and disarmed")


def stream_sticks(client: VehicleClient, wall_s: float, throttle: int = 500) -> None:
    """MANUAL_CONTROL with centred sticks at 20 Hz (wall clock) for ``wall_s`` seconds, as a joystick."""
    end = time.monotonic() + wall_s
    while time.monotonic() < end:
        client.conn.mav.manual_control_send(client.target_system, 0, 0, throttle, 0, 0)
        client.pump(0.05)


# --------------------------------------------------------------------------- data link and sticks


def test_data_link_loss_returns_and_lands_and_the_regain_is_reported(links):
    client, truth = links
    client.param_set("NAV_DLL_ACT", 2)  # Return
    client.param_set("COM_DL_LOSS_T", 5)
    take_off(client)
    n = len(client.statustexts)
    with Recorder(client, ("HEARTBEAT",)) as rec:
        client.heartbeat_period_s = math.inf  # the ground station falls silent (it still listens)
        wait_text(client, n, "Data link lost: returning")
        client.wait_until(lambda: client.mode_name() == "RTL", WAIT_S, "mode RTL")
        client.wait_until(lambda: mavlink.MAV_STATE_CRITICAL in system_states(rec), WAIT_S, "MAV_STATE_CRITICAL")
        client.heartbeat_period_s = 1.0
        wait_text(client, n, "Data link regained")
        wait_landed(client)
    assert sum("Data link lost" in t for t in texts_since(client, n)) == 1
    assert client.mode_name() == "RTL"  # regaining the link does not undo the failsafe (the pilot may)


def test_manual_control_loss_lands(links):
    client, truth = links
    client.param_set("NAV_RCL_ACT", 3)  # Land
    take_off(client)
    stream_sticks(client, 0.5)
    client.set_mode("POSCTL").check()
    stream_sticks(client, 1.0)
    n = len(client.statustexts)
    assert client.mode_name() == "POSCTL"
    point = truth.latest()
    # the sticks stop: COM_RC_LOSS_T (0.5 s) on both clocks
    wait_text(client, n, "Manual control lost: landing")
    assert client.mode_name() in ("LAND", "POSCTL")  # the mode change follows in the next HEARTBEAT
    client.wait_until(lambda: client.mode_name() == "LAND", WAIT_S, "mode LAND")
    wait_landed(client)
    end = truth.latest().pos_ned_m
    assert math.hypot(end[0] - point.pos_ned_m[0], end[1] - point.pos_ned_m[1]) < 3.0, "landed where it was"


# --------------------------------------------------------------------------- battery


def test_battery_low_warns_critical_returns_emergency_lands(battery):
    client, truth = battery
    client.param_set("COM_LOW_BAT_ACT", 3)  # return at critical, land at emergency
    take_off(client)
    n = len(client.statustexts)
    with Recorder(client, ("HEARTBEAT",)) as rec:
        truth.set("SIM_BAT_MIN_PCT", 12.0)  # low (BAT_LOW_THR 15 %), above critical (7 %)
        truth.set("SIM_BAT_DRAIN", 20.0)  # the full pack in 20 simulated seconds
        wait_text(client, n, "Low battery")
        client.wait_sim_time(2.0)
        assert client.mode_name() == "LOITER" and client.armed()
        truth.set("SIM_BAT_MIN_PCT", 6.0)  # critical
        wait_text(client, n, "Critical battery")
        client.wait_until(lambda: client.mode_name() == "RTL", WAIT_S, "mode RTL")
        client.wait_until(lambda: mavlink.MAV_STATE_CRITICAL in system_states(rec), WAIT_S, "MAV_STATE_CRITICAL")
        truth.set("SIM_BAT_MIN_PCT", 3.0)  # emergency (BAT_EMERGEN_THR 5 %)
        wait_text(client, n, "Emergency battery")
        client.wait_until(lambda: client.mode_name() == "LAND", WAIT_S, "mode LAND")
        client.wait_until(lambda: mavlink.MAV_STATE_EMERGENCY in system_states(rec), WAIT_S, "MAV_STATE_EMERGENCY")
        wait_landed(client)
    texts = texts_since(client, n)
    assert any(t.startswith("Low battery") and t.endswith("return advised") for t in texts)
    assert any(t.startswith("Critical battery") and t.endswith(": returning") for t in texts)
    assert any(t.startswith("Emergency battery") and t.endswith(": landing") for t in texts)
    assert sum(t.startswith("Critical battery") for t in texts) == 1
    assert client.battery()[1] is not None and client.battery()[1] <= 5


# --------------------------------------------------------------------------- estimator faults


# (what is set, and back), held for a while: the vehicle must keep holding its point.  Magnetometer and
# barometer faults in flight: tests/test_e2e_failure_injection.py and tests/test_e2e_failure_detection.py.
FAULTS = [
    ({"SIM_GPS_GLITCH_N": 20.0, "SIM_GPS_GLITCH_E": 20.0}, {"SIM_GPS_GLITCH_N": 0.0, "SIM_GPS_GLITCH_E": 0.0}),
]
HOLD_S = 10.0  # simulated seconds each fault lasts


def worst_drift_m(truth: SimClient, since_ms: int, point) -> float:
    return max(math.hypot(s.pos_ned_m[0] - point[0], s.pos_ned_m[1] - point[1]) for s in truth.since(since_ms))


@pytest.mark.parametrize("fault, clear", FAULTS, ids=["gps_glitch"])
def test_no_fly_away_with_a_sensor_fault_in_flight(faults, fault, clear):
    client, truth = faults
    take_off(client)
    hold = truth.latest()
    n = len(client.statustexts)
    try:
        for name, value in fault.items():
            truth.set(name, value)
        client.wait_sim_time(HOLD_S)
    finally:
        for name, value in clear.items():
            truth.set(name, value)
    client.wait_sim_time(10.0)  # the estimator settles back (a GPS reset back after a glitch)
    drift = worst_drift_m(truth, hold.time_ms, hold.pos_ned_m)
    holding = client.armed() and client.mode_name() == "LOITER"
    landed = client.landed_and_disarmed()
    texts = texts_since(client, n)
    if not landed:
        client.land().check()
        wait_landed(client)
    assert drift < NO_FLY_AWAY_M, f"flew {drift:.1f} m from the held point ({texts})"
    assert holding or landed, f"neither holding nor landed: mode {client.mode_name()} ({texts})"


def test_gps_loss_in_flight_lands_without_a_fly_away(faults):
    client, truth = faults
    take_off(client)
    hold = truth.latest()
    n = len(client.statustexts)
    truth.set("SIM_GPS_DISABLE", 1)
    try:
        wait_text(client, n, "Position estimate lost: landing")
        wait_landed(client)
    finally:
        truth.set("SIM_GPS_DISABLE", 0)
    drift = worst_drift_m(truth, hold.time_ms, hold.pos_ned_m)
    assert drift < NO_FLY_AWAY_M, f"flew {drift:.1f} m from the held point"
    assert truth.latest().pos_ned_m[2] > -0.3, "not on the ground"
