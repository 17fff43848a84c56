"""End-to-end: precision landing on the ground vehicle's ArUco deck, through MAVLink (issue 13).

The real ``sitl`` (UGV, downward camera rendered by MuJoCo, the vision companion sending
LANDING_TARGET after its 50 ms latency) and ``autopilot`` (AUTO.PRECLAND) processes; the test is a
ground station: it arms, takes off, flies to the meeting point and sends MAV_CMD_NAV_LAND with
param 2 (precision), as :mod:`gcs.launcher.landing_run` does for ``flight-demo --scenario
ugv-landing``.  It scores with the simulator's truth (the multicopter's and the UGV's, UDP
14740+I), never the flight controller's own belief.  One stack per landing (each its own UGV and seed).

Flown in simulated time (issue 33): the simulator starts held and every command is sent between two
steps, by :func:`gcs.launcher.landing_run.fly_landing` (``LandingSetup.deterministic``) or by hand through
:class:`e2e_flight_helpers.SteppedFlight`, so every figure (a touchdown error, the UGV's speed) and every
phase is the same in every run; wall-clock values are only "give up waiting" timeouts.
"""

from __future__ import annotations

import math

import pytest

from gcs.client import VehicleClient, mavlink
from gcs.launcher import Stack
from gcs.launcher.landing_run import PREP_ALT_M, LandingSetup, fly_landing
from gcs.launcher.sim_stepper import SimStepper
from gcs.sim_client import SimClient
from mavsim_core import ports
from sitl.ugv_paths import Pose2

from e2e_flight_helpers import SteppedFlight, record_figure, texts_since  # tests/e2e_flight_helpers.py

pytestmark = pytest.mark.e2e
WAIT_S = 180.0


def _fly(setup: LandingSetup, inst: int):
    """Fly one landing on its own stack; the result (``gcs.launcher.landing_run.LandingResult``)."""
    with (
        Stack(
            instance=inst,
            speed="max",
            vehicle=setup.vehicle,
            seed=setup.seed,
            extra_sitl_args=setup.sim_args(),
            flight_logs=False,
        ) as stack,
        SimClient(ports.sim_component_port(inst)) as truth,
        VehicleClient(stack.api_url, timeout_s=WAIT_S, idle=stack.check_alive) as client,
    ):
        return fly_landing(client, truth, setup, timeout_s=WAIT_S)


def test_precision_landing_on_the_static_pad(free_instance):
    """The UGV parked; the multicopter waits 0.5 m off it and lands on the marker within 5 cm."""
    setup = LandingSetup(path="static", speed_m_s=0.0, ugv_start=Pose2(3.0, 1.0, 0.5), meet_offset_m=(0.4, -0.3))
    r = _fly(setup, free_instance())
    assert r.success, r.reason
    record_figure("precland_static_touchdown_error_m", r.touchdown_error_m, 0.05, unit="m")
    assert any("docking" in p for p in r.phases) and any("done" in p for p in r.phases)


def test_target_lost_then_search_then_ordinary_landing(free_instance, tmp_path):
    """The camera fails while tracking: PLD_BTOUT later a search, PLD_MAX_SRCH searches of PLD_SRCH_TOUT,
    then (opportunistic, NAV_LAND param 2 = 1) an ordinary landing; every phase is a STATUSTEXT."""
    inst = free_instance()
    setup = LandingSetup(path="static", speed_m_s=0.0, ugv_start=Pose2(3.0, 0.0, 0.0), meet_offset_m=(0.0, 0.0))
    params = tmp_path / "precland.params"  # short time-outs, from the start (as a parameter file)
    params.write_text("PLD_BTOUT 1.0\nPLD_SRCH_TOUT 2.0\nPLD_MAX_SRCH 1\n")
    with (
        SimClient(ports.sim_component_port(inst)) as truth,
        Stack(
            instance=inst,
            speed="max",
            seed=5,
            extra_sitl_args=setup.sim_args(),  # held from the start (deterministic): flown by hand through holds
            extra_autopilot_args=["--params", str(params)],
            flight_logs=False,
        ) as stack,
        VehicleClient(stack.api_url, timeout_s=WAIT_S, idle=stack.check_alive) as client,
    ):
        stepper = SimStepper(client, truth, timeout_s=60.0)
        stepper.start()
        f = SteppedFlight(client, truth, stepper)
        f.ready()
        n = len(client.statustexts)
        client.arm(timeout_s=10).check()
        client.takeoff(client.home().alt_amsl_m + PREP_ALT_M, timeout_s=10).check()
        f.until(lambda: client.takeoff_done(PREP_ALT_M), 60.0, "take-off")
        client.goto_ned(2.5, 0.3, -PREP_ALT_M, timeout_s=10).check()  # 0.5 m short of the pad: in view
        f.until(lambda: client.arrived(2.5, 0.3, 0.3, 0.3), 60.0, "the meeting point")
        client.command_long(
            mavlink.MAV_CMD_NAV_LAND, 0, 1, 0, math.nan, math.nan, math.nan, math.nan, timeout_s=10
        ).check()

        def seen(fragment: str, max_s: float) -> float:
            """Until a STATUSTEXT containing ``fragment`` has come; the simulated time then, s."""
            f.until(lambda: any(fragment in t for t in texts_since(client, n)), max_s, repr(fragment))
            return f.now_s

        seen("Precland: tracking", 60.0)
        t_fail = f.set_sim("SIM_CAM_FAIL", 1)
        t_search = seen("Precland: search", 10.0)
        t_fallback = seen("Precland: fallback", 30.0)
        f.until(client.landed_and_disarmed, 60.0, "the ordinary landing", every_s=0.25)
        texts = texts_since(client, n)
        phases = [t for t in texts if t.startswith(("Precland", "Precision landing"))]
        print(f"camera failed at {t_fail:.1f} s: search {t_search - t_fail:.1f} s later, fallback "
              f"{t_fallback - t_fail:.1f} s later; {phases}")  # fmt: skip
        assert f.truth_now().pos_ned_m[2] > -0.5  # on the ground or the deck, not holding in the air
        assert not any("Precision landing failed" in t for t in texts)  # opportunistic: no failure
