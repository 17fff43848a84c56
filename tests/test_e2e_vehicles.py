"""End-to-end: both vehicles of the source documents fly from their files, in wind, with failures.

The real ``sitl`` and ``autopilot`` processes (``gcs.launcher.Stack``, ``--speed max``),
a ground-station client (:class:`gcs.client.VehicleClient`), and :class:`gcs.sim_client.SimClient` on
the simulator's own port (ground truth, and the ``SIM_*`` parameters a user sets from MAVProxy).  One
stack per vehicle or scenario: the Firefly hexacopter (module scope, its tests in file order) and the
quadcopter started with ``sitl --scenario windy``.

Flown in simulated time (issue 33): the simulator starts held and the test moves the hold on
(:class:`e2e_flight_helpers.SteppedFlight`), every command and ``SIM_*`` parameter is sent between two
steps, so every figure (a hold error, a roll angle, a heading change) is the same in every run;
wall-clock values are only "give up waiting" timeouts.  Instances: free ones (``free_instance``,
tests/conftest.py).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from gcs.client import mavlink

from e2e_flight_helpers import (  # tests/e2e_flight_helpers.py
    Recorder,
    SteppedFlight,
    record_figure,
    stepped_flight,
)

pytestmark = pytest.mark.e2e
ALT_M = 5.0


def hold_errors(f: SteppedFlight, point: np.ndarray, seconds: float) -> np.ndarray:
    """Truth minus ``point`` (NED, truth frame) over the next ``seconds`` of simulated time."""
    t0 = f.now_ms
    f.wait(seconds)
    samples = f.truth_since(t0)
    assert len(samples) > 40 * seconds  # truth at 50 Hz
    return np.array([np.array(s.pos_ned_m) - point for s in samples])


def rms(a) -> float:
    return float(np.sqrt(np.mean(np.square(a))))


def take_off(f: SteppedFlight) -> np.ndarray:
    """Arm, take off to ALT_M, settle 3 s; return the truth point it should hold (NED): ALT_M above its start."""
    f.ready()
    start = np.array(f.truth_now().pos_ned_m)
    f.take_off(ALT_M, settle_s=3.0)
    return start + np.array([0.0, 0.0, -ALT_M])


def attitudes(f: SteppedFlight, seconds: float) -> list:
    """The ATTITUDE messages of the next ``seconds`` of simulated time."""
    with Recorder(f.client, ("ATTITUDE",)) as rec:
        f.wait(seconds)
    out = rec.of("ATTITUDE")
    assert out, "no ATTITUDE"
    return out


@pytest.fixture(scope="module")
def firefly(free_instance):
    with stepped_flight(free_instance(), "firefly") as f:
        yield f


def test_firefly_flies_from_its_file_holds_and_reports_its_battery(firefly):
    f = firefly
    client = f.client
    hb = client.latest("HEARTBEAT")
    assert hb.type == mavlink.MAV_TYPE_HEXAROTOR and hb.autopilot == mavlink.MAV_AUTOPILOT_PX4
    f.until(lambda: client.latest("SYS_STATUS") is not None, 10.0, "SYS_STATUS")
    v_rest = client.latest("SYS_STATUS").voltage_battery / 1000.0
    assert 11.0 < v_rest < 12.7  # the Firefly's 3S pack, nearly full

    point = take_off(f)
    err = hold_errors(f, point, 10.0)
    record_figure("firefly_hover_horizontal_rms_m", rms(np.hypot(err[:, 0], err[:, 1])), 0.25, unit="m")
    record_figure("firefly_hover_vertical_rms_m", rms(err[:, 2]), 0.15, unit="m")

    sys_status = client.latest("SYS_STATUS")
    batt = client.latest("BATTERY_STATUS")
    assert sys_status.current_battery > 500  # cA: the six rotors draw more than 5 A in hover
    assert sys_status.voltage_battery / 1000.0 < v_rest  # it sags under load
    assert 0 < batt.battery_remaining <= 100 and batt.current_consumed > 0


def test_sim_wind_set_in_flight_makes_it_lean_into_the_wind_and_hold(firefly):
    """A SIM_* parameter set over the simulator's port acts in flight: 8 m/s from the West pushes
    East, so the vehicle (facing North) rolls left (negative roll) to hold its position."""
    f = firefly
    point = np.array(f.truth_now().pos_ned_m)
    rolls_calm = [m.roll for m in attitudes(f, 2.0)]
    record_figure("firefly_calm_mean_roll_deg", abs(math.degrees(np.mean(rolls_calm))), 1.5, unit="deg")
    assert f.truth.set("SIM_WIND_DIR", 270.0) == 270.0
    assert f.truth.set("SIM_WIND_SPD", 8.0) == 8.0
    f.wait(6.0)
    rolls_windy = [m.roll for m in attitudes(f, 3.0)]
    record_figure("firefly_wind_8_m_s_mean_roll_deg", math.degrees(np.mean(rolls_windy)), -3.0, unit="deg")
    err = np.array(f.truth_now().pos_ned_m) - point
    record_figure("firefly_wind_8_m_s_offset_m", math.hypot(err[0], err[1]), 1.0, unit="m")


def test_firefly_holds_position_in_5_m_s_wind_with_gusts(firefly):
    f = firefly
    for name, value in {"SIM_WIND_SPD": 5.0, "SIM_WIND_TURB": 1.0, "SIM_GUST_SPD": 2.0, "SIM_GUST_INT": 5.0}.items():
        f.set_sim(name, value)
    point = np.array(f.truth_now().pos_ned_m)
    f.wait(8.0)
    err = hold_errors(f, point, 20.0)
    record_figure("firefly_gusts_horizontal_rms_m", rms(np.hypot(err[:, 0], err[:, 1])), 0.5, unit="m")
    record_figure("firefly_gusts_vertical_rms_m", rms(err[:, 2]), 0.3, unit="m")
    for name in ("SIM_WIND_SPD", "SIM_WIND_TURB", "SIM_GUST_SPD"):
        f.set_sim(name, 0.0)


def test_hexacopter_survives_a_motor_losing_most_of_its_thrust(firefly):
    """Motor 1 at 30 % thrust (SIM_ENGINE_MUL 0.3): survivable, the hexacopter keeps position and
    heading, and lands.  (A motor stopped outright costs the heading.)"""
    f = firefly
    point = np.array(f.truth_now().pos_ned_m)
    yaw0 = f.client.latest("ATTITUDE").yaw
    f.set_sim("SIM_ENGINE_MUL", 0.3)
    f.set_sim("SIM_ENGINE_FAIL", 1)
    err = hold_errors(f, point, 10.0)
    record_figure("firefly_weak_motor_max_horizontal_m", float(np.hypot(err[:, 0], err[:, 1]).max()), 1.0, unit="m")
    # 0.36-0.43 m over 7 seeds (docs/testing.md): limit 1.25 x the worst and more
    record_figure("firefly_weak_motor_max_vertical_m", float(np.abs(err[:, 2]).max()), 0.6, unit="m")
    yaw_change = abs(math.remainder(f.client.latest("ATTITUDE").yaw - yaw0, 2 * math.pi))
    record_figure("firefly_weak_motor_heading_change_deg", math.degrees(yaw_change), 10.0, unit="deg")
    f.land()
    f.set_sim("SIM_ENGINE_FAIL", 0)


def test_quad_holds_position_in_the_windy_scenario(free_instance):
    """The [Q] quadcopter started with ``sitl --scenario windy`` (5 m/s from the West,
    1 m/s turbulence, 2 m/s gusts)."""
    with stepped_flight(free_instance(), "quad_x", ("--scenario", "windy")) as f:
        point = take_off(f)
        assert f.truth.get("SIM_WIND_SPD") == 5.0
        f.wait(3.0)
        err = hold_errors(f, point, 10.0)
        record_figure("quad_windy_scenario_horizontal_rms_m", rms(np.hypot(err[:, 0], err[:, 1])), 0.5, unit="m")
        record_figure("quad_windy_scenario_vertical_rms_m", rms(err[:, 2]), 0.3, unit="m")
        f.land()
