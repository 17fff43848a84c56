"""End-to-end: ``gcs autotune`` on the real stack (quad_x, ``--speed max``, a free instance).

The ``gcs`` CLI runs in this process (``gcs.__main__.main``) against the flight controller's ground-station
socket; a :class:`VehicleClient` beside it flies the vehicle and keeps every STATUSTEXT with its simulated
time; the simulator's truth (:class:`SimClient`) says where the vehicle really was.

1. On the ground ``gcs autotune`` is refused: exit 1, the vehicle's reason (DENIED: not flying).
2. Hovering in Hold: ``gcs autotune --accept`` runs roll, pitch, yaw, prints the table and applies.  The
   vehicle's report lines (one per axis) give an identified effectiveness near 1 and a motor lag near the
   vehicle file's (12.5 ms up, 25 ms down), and the proposal keeps the design's 45 deg of phase margin and 6 dB
   of gain margin; every MC_*RATE_P/I/D read back equals the proposal; and over the whole run the truth
   stays within 0.5 m of where it started and within 5 deg of level.
3. A second run is aborted by a mode change (Land) halfway through roll: the vehicle says so and every
   gain stays what the first run applied.
4.-5. On a stack of its own at 5x real time: Ctrl-C, and MC_AT_APPLY 2 (the last test's docstring).
"""

from __future__ import annotations

import math
import signal
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import pytest

from autopilot.tuning.autotune import FAILED_HOLD_S
from gcs.__main__ import main as gcs_main
from gcs.autotune_cli import START, send
from gcs.client import VehicleClient, mavlink
from gcs.launcher import Stack
from gcs.sim_client import SimClient
from mavsim_core import ports
from mavsim_core.autotune_report import parse_axis_line

from e2e_flight_helpers import sigint_default  # tests/e2e_flight_helpers.py

pytestmark = pytest.mark.e2e
WAIT_S = 60.0  # wall seconds for one exchange on a busy machine (a safety net, not a figure)
ALT_M = 4.0
GAINS = [f"MC_{a}RATE_{k}" for a in ("ROLL", "PITCH", "YAW") for k in "PID"]


def texts_after(client: VehicleClient, first: int) -> list:
    return client.statustexts[first:]


def time_of(client: VehicleClient, first: int, start: str) -> float:
    """Simulated time (s) of the first STATUSTEXT after ``first`` that starts with ``start``."""
    return next(t.sim_time_s for t in texts_after(client, first) if t.text.startswith(start))


def truth_excursion(truth: SimClient, t0_s: float, t1_s: float) -> tuple[float, float]:
    """(largest distance from the start position in m, largest tilt in deg) of the truth in [t0, t1]."""
    with truth.lock:
        pos = [p.pos_ned_m for ms, p in sorted(truth.positions.items()) if t0_s * 1e3 <= ms <= t1_s * 1e3]
        states = [s for ms, s in sorted(truth.states.items()) if t0_s * 1e3 <= ms <= t1_s * 1e3]
    assert len(pos) > 100 and len(states) > 100, "no truth over the run"
    p = np.array(pos)
    dist = float(np.max(np.linalg.norm(p - p[0], axis=1)))
    tilt = 0.0
    for s in states:
        w, x, y, z = s.attitude_quaternion
        tilt = max(tilt, math.degrees(math.acos(min(1.0, abs(1 - 2 * (x * x + y * y))))))
    return dist, tilt


def test_autotune_refused_on_the_ground_applied_in_the_air_and_aborted_by_a_mode_change(inst, capsys):
    url = f"udpout:127.0.0.1:{ports.gcs_local_port(inst)}"
    with (
        SimClient(ports.sim_component_port(inst)) as truth,
        Stack(instance=inst, speed="max", flight_logs=False) as stack,
        VehicleClient(url, timeout_s=WAIT_S, idle=stack.check_alive) as client,
    ):
        client.wait_until(client.prearm_ok, WAIT_S, "ready to arm")
        assert gcs_main(["--url", url, "autotune", "--accept"]) == 1
        assert "DENIED" in (err := capsys.readouterr().err) and "not flying" in err

        client.arm().check()
        client.takeoff(client.wait_home().alt_amsl_m + ALT_M).check()
        client.wait_until(lambda: client.takeoff_done(ALT_M) and client.mode_name() == "LOITER", WAIT_S, "hold")
        client.wait_sim_time(1.0)
        first = len(client.statustexts)
        with ThreadPoolExecutor(1) as pool:  # the CLI runs; this client keeps listening (and stays a peer)
            run = pool.submit(gcs_main, ["--url", url, "autotune", "--accept"])
            client.wait_until(run.done, 3 * WAIT_S, "gcs autotune")
        assert run.result() == 0
        out = capsys.readouterr().out
        print(out)
        assert "Autotune: yaw 60 %" in out and "P now>new" in out and "applied: MC_ROLLRATE_P" in out
        reports = {r.axis: r for r in (parse_axis_line(t.text) for t in texts_after(client, first)) if r}
        assert set(reports) == {"roll", "pitch", "yaw"}
        for r in reports.values():
            assert 0.7 < r.effectiveness < 1.3 and 0.008 < r.motor_tau_s < 0.03, r
            assert r.phase_margin_deg[1] >= 44.9 and r.gain_margin_db[1] >= 6.0, r
        applied = {n: float(client.param_get(n)) for n in GAINS}
        for name, value in applied.items():
            axis, k = name[3:].split("RATE_")[0].lower(), "PID".index(name[-1])
            assert value == pytest.approx(reports[axis].gains_new[k], rel=2e-3, abs=1e-3), name
        dist, tilt = truth_excursion(
            truth, time_of(client, first, "Autotune started"), time_of(client, first, "Autotune done")
        )
        print(f"autotune run: truth within {dist:.3f} m of its start, tilt at most {tilt:.2f} deg")
        assert dist < 0.5 and tilt < 5.0

        second = len(client.statustexts)
        assert send(client, START, WAIT_S).result == mavlink.MAV_RESULT_IN_PROGRESS
        client.wait_until(
            lambda: any(t.text == "Autotune: roll 30 %" for t in texts_after(client, second)), WAIT_S, "roll excited"
        )
        client.land().check()
        client.wait_until(
            lambda: any("Autotune aborted: mode changed to AUTO.LAND" in t.text for t in texts_after(client, second)),
            WAIT_S,
            "the abort",
        )
        client.wait_sim_time(2.0)  # (the excitation would have gone on into pitch by now)
        assert {n: float(client.param_get(n)) for n in GAINS} == applied
        later = [t.text for t in texts_after(client, second)]
        assert not any(parse_axis_line(t) or t.startswith("Autotune: pitch") for t in later), later


PACED = 5.0  # this stack's speed (x real time): a Ctrl-C sent on a progress line lands well inside the run


def test_ctrl_c_aborts_the_run_on_the_vehicle_and_mc_at_apply_2_applies_at_once(free_instance):
    """4. ``gcs autotune`` as a user runs it (its own process) and stopped with Ctrl-C (SIGINT) during roll:
    it tells the vehicle to abort (the vehicle says so), exits 130, and no gain changes.
    5. With MC_AT_APPLY 2 (PX4's "apply at once in the air") the vehicle applies the proposal itself and
    ``gcs autotune`` reports it without asking; the gains read back are the report's."""
    inst = free_instance()
    url = f"udpout:127.0.0.1:{ports.gcs_local_port(inst)}"
    with (
        Stack(instance=inst, speed=PACED, flight_logs=False) as stack,
        VehicleClient(url, timeout_s=WAIT_S, idle=stack.check_alive) as client,
    ):
        client.wait_until(client.prearm_ok, WAIT_S, "ready to arm")
        client.arm().check()
        client.takeoff(client.wait_home().alt_amsl_m + ALT_M).check()
        client.wait_until(lambda: client.takeoff_done(ALT_M) and client.mode_name() == "LOITER", WAIT_S, "hold")
        before = {n: float(client.param_get(n)) for n in GAINS}

        first = len(client.statustexts)
        cli = subprocess.Popen(
            [sys.executable, "-m", "gcs", "--url", url, "autotune", "--accept"],
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            preexec_fn=sigint_default,  # (CI's background shell starts everything with SIGINT ignored)
        )
        try:
            # Ctrl-C at the command's first progress line, as a user presses it, read from its own output
            shown = []
            for line in cli.stdout:
                shown.append(line)
                if line.startswith("Autotune: roll"):
                    break
            cli.send_signal(signal.SIGINT)
            out, err = cli.communicate(timeout=WAIT_S)
            out = "".join(shown) + out
        finally:
            cli.kill()
        assert cli.returncode == 130, (out, err)
        assert "autotune aborted on the vehicle: gains unchanged" in err
        client.wait_until(
            lambda: any("Autotune aborted by the ground station" in t.text for t in texts_after(client, first)),
            WAIT_S,
            "the vehicle's abort",
        )
        assert not any(parse_axis_line(t.text) for t in texts_after(client, first))
        assert {n: float(client.param_get(n)) for n in GAINS} == before

        client.param_set("MC_AT_AXES", 1)  # roll only
        client.param_set("MC_AT_APPLY", 2)
        client.wait_sim_time(FAILED_HOLD_S)  # (a start sooner after the abort is answered FAILED, with the reason)
        second = len(client.statustexts)
        with ThreadPoolExecutor(1) as pool:  # (no --accept: nothing is asked); this client keeps listening
            run = pool.submit(gcs_main, ["--url", url, "autotune"])
            client.wait_until(run.done, 3 * WAIT_S, "gcs autotune")
        assert run.result() == 0
        client.wait_sim_time(0.5)  # (the last STATUSTEXTs reach this client too)
        reports = [r for r in (parse_axis_line(t.text) for t in texts_after(client, second)) if r]
        assert [r.axis for r in reports] == ["roll"]
        assert any(t.text.startswith("Autotune: new gains applied") for t in texts_after(client, second))
        roll = {k: float(client.param_get(f"MC_ROLLRATE_{k}")) for k in "PID"}
        for k, value in roll.items():
            assert value == pytest.approx(reports[0].gains_new["PID".index(k)], rel=2e-3, abs=1e-3), k
        assert roll != {k: before[f"MC_ROLLRATE_{k}"] for k in "PID"}
        assert {n: float(client.param_get(n)) for n in GAINS if not n.startswith("MC_ROLL")} == {
            n: v for n, v in before.items() if not n.startswith("MC_ROLL")
        }
