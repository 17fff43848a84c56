"""End-to-end: the scenarios that start their own stack, the real simulator and flight controller.

(a) arming waits for the estimate: a real-time stack, armed at the first heartbeat through a
client and the ``gcs`` CLI, denied with a reason, then accepted; both processes end with the
stack.  The flight demo (``flight-demo``) starts its own stack and flies its square.

Both act in wall time on purpose (a stack at speed 1, a user's program at full speed), so neither
is flown in simulated time (issue 33); what they assert does not depend on the machine's load (each
test says why).  Wall-clock values are only "give up waiting" timeouts.  The scenarios on one shared
max-speed stack are in tests/test_e2e_flight.py.

Instances: free ones, leased as each test starts (the ``free_instance`` fixture of tests/conftest.py;
tests/instances.py says which ports an instance uses).
"""

from __future__ import annotations

import signal
import subprocess
import sys
from pathlib import Path

import pytest

from gcs.client import VehicleClient, mavlink
from gcs.launcher import Stack, demo
from gcs.sim_client import SimClient
from mavsim_core import ports

ROOT = Path(__file__).resolve().parent.parent

from e2e_flight_helpers import WAIT_S, arm  # tests/e2e_flight_helpers.py

pytestmark = pytest.mark.e2e


# --------------------------------------------------------------------------- (a) arming waits for the estimate


def test_arming_denied_until_estimate_ready_then_accepted(free_instance):
    """Real time, armed at the first heartbeat: denied with a reason; once ready, accepted.

    The stack starts held at t = 0.1 s (``SIM_HOLD_MS``): the estimator cannot become ready, however long
    the client and the CLI take to start on a busy machine (a flake hunt saw the CLI's arm arrive after the
    estimate was ready at speed 1 alone), so both early attempts are refused in every run.  The hold is
    then lifted and the stack runs in real time; the one figure, the simulated time the estimator needed,
    is counted on the simulator's clock.
    """
    inst = free_instance()
    held = ["--param", "SIM_HOLD_MS=100"]  # held until both early attempts are refused
    stack = Stack(instance=inst, speed=1, extra_sitl_args=held)  # a real-time stack, started and stopped
    with stack, SimClient(ports.sim_component_port(inst)) as truth:
        # The CLI on the ground-station port, started at once: it arms at its first heartbeat too.
        cli = subprocess.Popen(
            [
                sys.executable,
                "-m",
                "gcs",
                "--url",
                stack.gcs_url,
                "--timeout",
                "30",
                "arm",
            ],
            cwd=ROOT,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
        )
        try:
            with VehicleClient(stack.api_url, timeout_s=WAIT_S, idle=stack.check_alive) as c:
                early = c.arm(timeout_s=10)
                assert early.result == mavlink.MAV_RESULT_DENIED, early.describe()
                assert early.reason is not None and early.reason.startswith("Arming denied: ")
                assert "not ready" in early.reason
                assert any(
                    st.severity <= mavlink.MAV_SEVERITY_CRITICAL and st.text == early.reason for st in c.statustexts
                )
                assert not c.armed()

                out, err = cli.communicate(timeout=WAIT_S)
                assert cli.returncode == 1, out + err
                assert "arm refused: DENIED" in err and "Arming denied: " in err

                truth.set("SIM_HOLD_MS", 0, timeout_s=WAIT_S)  # lift the hold: the stack runs in real time from here
                c.wait_until(c.prearm_ok, WAIT_S, "the pre-arm checks to pass")
                assert c.sim_time_s() > 1.0  # the estimator needed simulated time
                arm(c)
                assert "Armed" in [st.text for st in c.statustexts]
                c.disarm(timeout_s=10).check()
                c.wait_armed(False, WAIT_S)
        finally:
            if cli.poll() is None:
                cli.kill()
                cli.communicate()
        procs = list(stack.procs.values())
        assert all(p.poll() is None for p in procs)
        sitl_log = stack.log_path("sitl").read_text()
        autopilot_log = stack.log_path("autopilot").read_text()
    assert all(p.poll() is not None for p in procs)  # both children end with the stack
    assert "speed 1x" in sitl_log and "flight controller connected" in sitl_log
    assert "[autopilot] connected to the simulator" in autopilot_log


# --------------------------------------------------------------------------- the flight demo


def test_flight_demo_flies_its_square(capsys, tmp_path, monkeypatch, free_instance):
    monkeypatch.chdir(tmp_path)  # --log-dir relative to where the user is, not to the installed package
    sigterm = signal.getsignal(signal.SIGTERM)  # demo.main installs its own SIGTERM handler
    try:
        rc = demo.main(
            ["--instance", str(free_instance()), "--ready-timeout", str(WAIT_S), "--step-timeout", str(WAIT_S)]
            + ["--log-dir", "demo"]
        )
    finally:
        signal.signal(signal.SIGTERM, sigterm)
    out = capsys.readouterr()
    assert rc == 0, out.err + out.out[-3000:]
    assert "flight demo: OK" in out.out
    assert list((tmp_path / "demo").glob("*.ulg")) and list((tmp_path / "demo").glob("*.truth.npy"))
    assert f"gcs plot {tmp_path / 'demo'}" in out.out  # the next command, with where the logs went
    for expected in (
        "armed",
        "taking off to 5 m",
        "held 10 s",
        "at corner 4 (start)",
        "disarmed",
        "flight time",
        "max altitude",
        "landing error",
        "real-time factor",
    ):
        assert expected in out.out
    # The demo acts in wall time, yet its landing error does not depend on when its commands arrive: it
    # lands only once it has arrived (within ARRIVAL_RADIUS_M 0.5 m of its start, slower than 0.5 m/s),
    # holding the point until the land command comes, and comes straight down.
    landing_error = float(out.out.split("landing error")[1].split()[0])
    assert landing_error < 1.0
