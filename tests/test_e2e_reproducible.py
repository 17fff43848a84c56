"""A landing flown through holds (``LandingSetup.deterministic``, gcs/launcher/sim_stepper.py) is reproducible.

The same precision landing on the UGV driving a 2 m circle at 2 m/s (a deck that turns at 1 rad/s), same seeds,
flown on two stacks at the same time (each its own simulator and flight controller, competing for this machine's
two cores, so their wall timings differ): every field of the result but the wall time is identical to the last
bit, and so is every ground-truth sample of the multicopter and of the UGV both received, touchdown included.
The landing itself is the suite's moving-deck precision landing (issues 13 and 34; test_e2e_precland.py has the
static pad and the lost target), with the gimbal and the nested pad: a pilot's landing (four feet on the turning
deck, level on it, 5 s later), within 10 cm of its centre, within 10 deg of square to it, the nested pad's inner
marker seen alone below the outer's range.
"""

from __future__ import annotations

import math
import re
import threading

import pytest

from gcs.client import VehicleClient
from gcs.launcher import Stack
from gcs.launcher.landing_run import START_HOLD_MS, LandingSetup, fly_landing
from gcs.sim_client import SimClient
from mavsim_core import ports
from sitl.ugv_paths import Pose2
from vision.pad import NESTED_PAD

from e2e_flight_helpers import record_figure, stepped_flight_fixture  # tests/e2e_flight_helpers.py

pytestmark = pytest.mark.e2e

WAIT_S = 240.0  # wall-clock safety net
SETUP = LandingSetup(path="circle", speed_m_s=2.0, radius_m=2.0, ugv_start=Pose2(4.0, -1.0, math.pi / 2), seed=3)
MARKER_USE = re.compile(r"id (\d+) in (\d+) frames \(([\d.]+)-([\d.]+) m, alone in (\d+)\)")


def _markers_used(sitl_log: str) -> dict[int, tuple[int, float, float, int]]:
    """The companion's camera line (sitl/companion.py): marker id -> (frames, nearest m, farthest m, frames alone)."""
    line = next(x for x in sitl_log.splitlines() if "markers used:" in x)
    return {int(i): (int(n), float(lo), float(hi), int(a)) for i, n, lo, hi, a in MARKER_USE.findall(line)}


def _fly(inst: int, out: dict) -> None:
    """One landing on its own stack (run in a thread, which owns the stack for its whole life)."""
    try:
        with (
            Stack(
                instance=inst, speed="max", seed=SETUP.seed, extra_sitl_args=SETUP.sim_args(), flight_logs=False
            ) as stack,
            SimClient(ports.sim_component_port(inst)) as truth,
            VehicleClient(stack.api_url, timeout_s=WAIT_S, idle=stack.check_alive) as client,
        ):
            result = fly_landing(client, truth, SETUP, timeout_s=WAIT_S)
            with truth.lock:
                positions, ugv = dict(truth.positions), dict(truth.ugv)
            last_hold_ms = truth.held_ms  # the last hold the simulator reported: the flight's end
        # the simulator has stopped: its companion's line is in its log
        markers = _markers_used(stack.log_path("sitl").read_text(errors="replace"))
        out[inst] = (result, positions, ugv, markers, last_hold_ms)
    except BaseException as exc:  # noqa: BLE001 - reported by the test
        out[inst] = exc


def test_the_same_landing_on_two_stacks_gives_identical_results(free_instance):
    a, b = free_instance(), free_instance()
    out: dict = {}
    threads = [threading.Thread(target=_fly, args=(inst, out)) for inst in (a, b)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(WAIT_S + 60)
    for inst in (a, b):
        assert not isinstance(out.get(inst), BaseException), out.get(inst)
    (ra, pos_a, ugv_a, markers, last_hold_ms), (rb, pos_b, ugv_b, _, _) = out[a], out[b]
    assert ra.success, ra.reason  # a pilot's landing: four feet on the deck, level on it 5 s later (deck_stance.py)
    assert ra.feet_on_deck == 4 and abs(ra.deck_level_err_cm) <= 2.0, (ra.feet_on_deck, ra.deck_level_err_cm)
    record_figure("precland_moving_square_off_deg", ra.square_off_deg, 10.0, unit="deg")  # PLD_DECK_YAW's heading
    outer, inner = markers[NESTED_PAD.markers[0].marker_id], markers[NESTED_PAD.markers[1].marker_id]
    print(f"markers used (frames, nearest m, farthest m, alone): outer {outer}, inner {inner}")
    assert inner[1] < outer[1] and inner[3] > 0, "the inner marker, alone, nearer than the outer one was seen"
    record_figure("precland_moving_touchdown_error_m", ra.touchdown_error_m, 0.10, unit="m")
    # it landed on a moving deck
    record_figure(
        "precland_moving_ugv_speed_at_touchdown_m_s", ra.ugv_speed_at_touchdown_m_s, 1.6, below=False, unit="m/s"
    )
    for name in ("success", "touchdown_error_m", "time_to_land_s", "ugv_speed_at_touchdown_m_s", "reason", "sim_s"):
        assert getattr(ra, name) == getattr(rb, name), name
    assert ra.phases == rb.phases
    end_ms = round(ra.sim_s * 1000) + START_HOLD_MS  # the last hold (touchdown + 5 s): the truth up to it came
    # the real-time factor's simulated seconds are the whole flight's, from the start hold (with the wait to be ready
    # to arm, whose wall time it counts too) to the last hold, not from the arming on
    assert end_ms == last_hold_ms
    for mine, theirs in ((pos_a, pos_b), (ugv_a, ugv_b)):
        common = set(mine) & set(theirs)
        assert len([t for t in common if t <= end_ms]) > 0.5 * end_ms / 20  # 50 Hz, UDP may drop a few
        assert all(mine[t] == theirs[t] for t in common)


flight = stepped_flight_fixture()  # a stack held from 0.1 s (tests/e2e_flight_helpers.py)


def test_a_held_vehicle_answers_the_parameter_protocol_and_stays_held(flight):
    """While the simulator holds, a ground station sets, reads and lists parameters as it would in flight (a
    stepped test changes a gain between two steps): the set is echoed, the read answered, the whole list sent,
    and the world has not moved a step meanwhile."""
    f = flight
    f.ready()
    held_ms = f.now_ms
    echoed = f.client.param_set("MIS_TAKEOFF_ALT", 3.5, timeout_s=10)
    assert echoed == pytest.approx(3.5)
    assert f.client.param_get("MIS_TAKEOFF_ALT", timeout_s=10) == pytest.approx(3.5)
    assert len(f.client.param_list(timeout_s=30)) > 100
    assert f.truth.held_ms == held_ms and f.truth.latest().time_ms == held_ms  # nothing stepped
    f.client.param_set("MIS_TAKEOFF_ALT", 2.5, timeout_s=10)
