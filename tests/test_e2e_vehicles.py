"""End-to-end: both vehicles of the source documents fly from their files, in wind, with failures.

The real ``sitl`` and ``autopilot`` processes (``gcs.launcher.Stack``, ``--speed max``),
a ground-station client on the API port, and :class:`gcs.sim_client.SimClient` on
the simulator's own port (ground truth, and the ``SIM_*`` parameters a user sets
from MAVProxy).  Durations are simulated seconds; wall-clock values are only
"give up waiting" timeouts.  Instances: free ones (``free_instance``, tests/conftest.py).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gcs.client import VehicleClient, mavlink
from gcs.launcher import Stack
from gcs.sim_client import SimClient
from mavsim_core import ports

pytestmark = pytest.mark.e2e
WAIT_S = 120.0
ALT_M = 5.0


def hold_errors(client: VehicleClient, truth: SimClient, point: np.ndarray, seconds: float) -> np.ndarray:
    """Truth minus ``point`` (NED, truth frame) over ``seconds`` of simulated time."""
    client.pump(0.05)
    t0 = truth.latest().time_ms
    client.wait_sim_time(seconds)
    samples = [s for s in truth.since(t0) if s.time_ms <= t0 + seconds * 1000]
    assert len(samples) > 40 * seconds  # truth at 50 Hz
    return np.array([np.array(s.pos_ned_m) - point for s in samples])


def rms(a) -> float:
    return float(np.sqrt(np.mean(np.square(a))))


def take_off(client: VehicleClient, truth: SimClient) -> np.ndarray:
    """Arm, take off to ALT_M, settle; return the truth point it should hold (NED)."""
    client.wait_until(client.prearm_ok, WAIT_S, "ready to arm")
    truth.wait_connected()
    start = np.array(truth.latest().pos_ned_m)
    client.arm().check()
    client.takeoff(client.wait_home().alt_amsl_m + ALT_M).check()
    client.wait_until(lambda: client.takeoff_done(ALT_M), WAIT_S, "take-off")
    client.wait_sim_time(3.0)
    return start + np.array([0.0, 0.0, -ALT_M])


def land(client: VehicleClient) -> None:
    client.land().check()
    client.wait_until(client.landed_and_disarmed, WAIT_S, "landed and disarmed")


@pytest.fixture(scope="module")
def firefly(free_instance):
    i = free_instance()
    with (
        Stack(instance=i, vehicle="firefly") as stack,
        SimClient(ports.sim_component_port(i)) as truth,
        VehicleClient(stack.api_url, timeout_s=WAIT_S, idle=stack.check_alive) as client,
    ):
        yield client, truth


def test_firefly_flies_from_its_file_holds_and_reports_its_battery(firefly):
    client, truth = firefly
    client.wait_heartbeat()
    hb = client.latest("HEARTBEAT")
    assert hb.type == mavlink.MAV_TYPE_HEXAROTOR and hb.autopilot == mavlink.MAV_AUTOPILOT_PX4
    client.wait_until(lambda: client.latest("SYS_STATUS") is not None, WAIT_S, "SYS_STATUS")
    v_rest = client.latest("SYS_STATUS").voltage_battery / 1000.0
    assert 11.0 < v_rest < 12.7  # the Firefly's 3S pack, nearly full

    point = take_off(client, truth)
    err = hold_errors(client, truth, point, 10.0)
    assert rms(np.hypot(err[:, 0], err[:, 1])) < 0.25
    assert rms(err[:, 2]) < 0.15

    sys_status = client.latest("SYS_STATUS")
    batt = client.latest("BATTERY_STATUS")
    assert sys_status.current_battery > 500  # cA: the six rotors draw more than 5 A in hover
    assert sys_status.voltage_battery / 1000.0 < v_rest  # it sags under load
    assert 0 < batt.battery_remaining <= 100 and batt.current_consumed > 0


def test_sim_wind_set_in_flight_makes_it_lean_into_the_wind_and_hold(firefly):
    """A SIM_* parameter set over the simulator's port acts in flight: 8 m/s from the West pushes
    East, so the vehicle (facing North) rolls left (negative roll) to hold its position."""
    client, truth = firefly
    point = np.array(truth.latest().pos_ned_m)
    rolls_calm = [m.roll for m in collect(client, "ATTITUDE", 2.0)]
    assert abs(np.mean(rolls_calm)) < math.radians(1.5)
    assert truth.set("SIM_WIND_DIR", 270.0) == 270.0
    assert truth.set("SIM_WIND_SPD", 8.0) == 8.0
    client.wait_sim_time(6.0)
    rolls_windy = [m.roll for m in collect(client, "ATTITUDE", 3.0)]
    assert np.mean(rolls_windy) < math.radians(-3.0)
    err = np.array(truth.latest().pos_ned_m) - point
    assert math.hypot(err[0], err[1]) < 1.0


def test_firefly_holds_position_in_5_m_s_wind_with_gusts(firefly):
    client, truth = firefly
    for name, value in {"SIM_WIND_SPD": 5.0, "SIM_WIND_TURB": 1.0, "SIM_GUST_SPD": 2.0, "SIM_GUST_INT": 5.0}.items():
        truth.set(name, value)
    point = np.array(truth.latest().pos_ned_m)
    client.wait_sim_time(8.0)
    err = hold_errors(client, truth, point, 20.0)
    assert rms(np.hypot(err[:, 0], err[:, 1])) < 0.5
    assert rms(err[:, 2]) < 0.3
    for name in ("SIM_WIND_SPD", "SIM_WIND_TURB", "SIM_GUST_SPD"):
        truth.set(name, 0.0)


def test_hexacopter_survives_a_motor_losing_most_of_its_thrust(firefly):
    """Motor 1 at 30 % thrust (SIM_ENGINE_MUL 0.3): survivable, the hexacopter keeps position and
    heading.  (A motor stopped outright costs the heading: see the next test.)"""
    client, truth = firefly
    point = np.array(truth.latest().pos_ned_m)
    yaw0 = client.latest("ATTITUDE").yaw
    truth.set("SIM_ENGINE_MUL", 0.3)
    truth.set("SIM_ENGINE_FAIL", 1)
    err = hold_errors(client, truth, point, 10.0)
    assert np.abs(np.hypot(err[:, 0], err[:, 1])).max() < 1.0
    assert np.abs(err[:, 2]).max() < 0.5
    assert abs(math.remainder(client.latest("ATTITUDE").yaw - yaw0, 2 * math.pi)) < math.radians(10)
    land(client)
    truth.set("SIM_ENGINE_FAIL", 0)


def collect(client: VehicleClient, kind: str, seconds: float) -> list:
    """Messages of one type received over ``seconds`` of simulated time."""
    out = []
    t0 = client.sim_time_s()
    while client.sim_time_s() - t0 < seconds:
        out += [m for m in client.pump(0.05) if m.get_type() == kind]
    assert out, f"no {kind}"
    return out


def test_quad_holds_position_in_the_windy_scenario(free_instance):
    """The [Q] quadcopter started with ``sitl --scenario windy`` (5 m/s from the West,
    1 m/s turbulence, 2 m/s gusts)."""
    i = free_instance()
    with (
        Stack(instance=i, vehicle="quad_x", extra_sitl_args=["--scenario", "windy"]) as stack,
        SimClient(ports.sim_component_port(i)) as truth,
        VehicleClient(stack.api_url, timeout_s=WAIT_S, idle=stack.check_alive) as client,
    ):
        point = take_off(client, truth)
        assert truth.get("SIM_WIND_SPD") == 5.0
        client.wait_sim_time(3.0)
        err = hold_errors(client, truth, point, 10.0)
        assert rms(np.hypot(err[:, 0], err[:, 1])) < 0.5
        assert rms(err[:, 2]) < 0.3
        land(client)
