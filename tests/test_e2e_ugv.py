"""End-to-end: the ground vehicle in the simulator, driven and set as a user would (issue 13, item 1).

The real ``sitl`` (with ``SIM_UGV_EN=1``) and ``autopilot`` in lockstep; ``gcs ugv`` run as a
command (keys piped to ``gcs ugv drive``), and the UGV's truth read from the simulator's port
(component 52).  ``gcs ugv`` and :class:`SimClient` bind the same UDP port, so they take turns.

The stack runs free, in wall time (not through the simulator's holds, issue 33): the test's point is
``gcs ugv`` run as a command, a client acting in wall time (``drive --duration`` counts wall seconds), and
a stepper would need the simulator's port that ``gcs ugv`` binds.  Nothing asserted depends on the
machine's load (see each check).
"""

from __future__ import annotations

import math
import subprocess
import sys
import time

import pytest

from gcs.launcher import Stack
from gcs.sim_client import SimClient, SimParamError
from mavsim_core import ports

from e2e_flight_helpers import CLIENT_SPEED  # tests/e2e_flight_helpers.py

pytestmark = pytest.mark.e2e


def _gcs(inst: int, *args: str, stdin: str | None = None) -> subprocess.CompletedProcess:
    """``python -m gcs --instance INST ARGS`` (the simulator's component of instance ``inst``)."""
    cmd = [sys.executable, "-m", "gcs", "--instance", str(inst), *args]
    return subprocess.run(cmd, input=stdin, capture_output=True, text=True, timeout=120)


def _ugv(inst: int, seconds_of_sim: float = 0.0):
    """The UGV's truth after ``seconds_of_sim`` more simulated seconds (and its truth before)."""
    with SimClient(ports.sim_component_port(inst)) as sim:
        sim.wait_connected(30)
        deadline = time.monotonic() + 30
        while (first := sim.ugv_latest()) is None and time.monotonic() < deadline:
            time.sleep(0.05)
        assert first is not None, "no UGV truth on component 52"
        while sim.ugv_latest().time_ms < first.time_ms + 1000 * seconds_of_sim:
            time.sleep(0.05)
        return first, sim.ugv_latest()


def test_ugv_is_driven_by_keys_set_by_parameters_and_refuses_a_restart_parameter(inst):
    args = ["--param", "SIM_UGV_EN=1", "--param", "SIM_UGV_X=3", "--param", "SIM_UGV_PATH=0", "--param", "SIM_VID_EN=0"]
    with Stack(instance=inst, speed=CLIENT_SPEED, extra_sitl_args=args, flight_logs=False):
        parked, _ = _ugv(inst)
        assert parked.pos_ned_m[0] == pytest.approx(3.0, abs=0.05) and abs(parked.pos_ned_m[1]) < 0.05
        assert parked.pos_ned_m[2] == pytest.approx(-0.3, abs=0.05)  # the deck's top, 0.3 m up

        drive = _gcs(inst, "ugv", "drive", "--duration", "3", stdin="ww")  # half throttle ahead (north)
        assert drive.returncode == 0, drive.stderr
        _, moved = _ugv(inst)
        # Drove north, straight.  Load-independent: 1 m at half throttle (1.5 m/s) is under a second of
        # driving, and each of the ~30 MANUAL_CONTROL of the 3 wall seconds drives it for min(0.5 s, the
        # simulated time to the next one): enough unless the simulation ran at less than half real time.
        assert moved.pos_ned_m[0] > 4.0 and abs(moved.pos_ned_m[1]) < 0.5

        out = _gcs(inst, "ugv", "set", "--path", "circle", "--speed", "1.5", "--radius", "3")
        assert out.returncode == 0, out.stderr
        assert "SIM_UGV_PATH = 2" in out.stdout and "SIM_UGV_SPD = 1.5" in out.stdout
        a, b = _ugv(inst, seconds_of_sim=8.0)  # 8 simulated seconds after the set: when it came does not matter
        assert math.hypot(*b.vel_ned_m_s[:2]) == pytest.approx(1.5, abs=0.2)  # at the set speed
        assert abs(b.yaw_rad - a.yaw_rad) > 0.1  # and turning

        with SimClient(ports.sim_component_port(inst)) as sim:
            sim.wait_connected(30)
            with pytest.raises(SimParamError, match="restart"):
                sim.set("SIM_UGV_EN", 0)
        status = _gcs(inst, "ugv", "status")
        assert status.returncode == 0 and "UGV deck" in status.stdout and "path 2" in status.stdout
