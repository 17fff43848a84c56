"""End-to-end: MAVLink 2 message signing on the real flight controller, set up and used by real clients.

One max-speed stack (module scope, a free instance) started with ``--state-dir``.
In order (the tests of this file share the vehicle's key):

1. ``gcs signing setup PASSPHRASE`` gives the vehicle its key (kept in the state directory, mode
   0600); a pymavlink client without the key still sees the telemetry but its ARM has no effect and
   no answer, and the vehicle says it refused something;
2. ``gcs --signing-key PASSPHRASE`` sets a parameter, arms, takes off and lands, while the
   unsigned client's forced DISARM in the air has no effect;
3. the key survives a restart of the flight controller: unsigned ``gcs arm`` times out, signed works;
4. ``gcs signing disable`` turns it off; MAVProxy's ``signing setup`` gives a key that the same
   passphrase in ``gcs --signing-key`` works with, and MAVProxy's ``signing remove`` ends it
   (MAVProxy in a virtual environment of its own, tests/mavproxy_env.py).

The unsigned observer (a VehicleClient on the stack's own ground-station port, where the vehicle
sends whatever happens) and the intruder (raw pymavlink, a peer of the vehicle's ground-station
socket from before the key was set) never have the key.  Wall-clock values are only "give up
waiting" timeouts.
"""

from __future__ import annotations

import hashlib
import os
import stat
import subprocess
import sys
import time
from pathlib import Path

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402

from gcs.client import VehicleClient, mavlink  # noqa: E402
from gcs.launcher import Stack  # noqa: E402
from gcs.signing_cli import has_signature  # noqa: E402
from mavsim_core import ports  # noqa: E402

from e2e_flight_helpers import CLIENT_SPEED  # tests/e2e_flight_helpers.py
from e2e_params_clients import MavproxySession  # tests/e2e_params_clients.py (MAVProxy: tests/mavproxy_env.py)

pytestmark = pytest.mark.e2e
ROOT = Path(__file__).resolve().parent.parent
PASSPHRASE = "e2e signing passphrase"
MAVPROXY_PASSPHRASE = "mavproxy-passphrase"
WAIT_S = 60.0
INTRUDER_SYSID = 42


@pytest.fixture(scope="module")
def state_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("fc-state")


@pytest.fixture(scope="module")
def stack(inst, state_dir):
    with Stack(
        instance=inst,
        speed=CLIENT_SPEED,
        extra_sitl_args=["--truth-port", "0"],
        extra_autopilot_args=["--state-dir", str(state_dir)],
        flight_logs=False,
    ) as s:
        yield s


@pytest.fixture(scope="module")
def observer(stack):
    """An unsigned VehicleClient on the stack's own ground-station port (the vehicle's default destination)."""
    with VehicleClient(stack.gcs_url, timeout_s=WAIT_S, idle=stack.check_alive, target_system=stack.sysid) as c:
        yield c


@pytest.fixture(scope="module")
def intruder(stack, observer):
    """Raw pymavlink without the key, made a peer of the vehicle before it had one (so it hears the answers)."""
    conn = mavutil.mavlink_connection(fc_gcs_url(stack), source_system=INTRUDER_SYSID, source_component=190)
    conn.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, mavlink.MAV_STATE_ACTIVE)
    assert conn.recv_match(type="HEARTBEAT", blocking=True, timeout=WAIT_S) is not None
    yield conn
    conn.close()


def fc_gcs_url(stack: Stack) -> str:
    """The flight controller's ground-station socket (18570 + instance), as a ``udpout`` url.

    A client that only sends there becomes a destination only through a message the vehicle accepts; one
    on ``stack.api_url`` (where the API endpoint sends by default) hears the vehicle even when it is refused."""
    return f"udpout:127.0.0.1:{ports.gcs_local_port(stack.instance)}"


def key_file(state_dir: Path, stack: Stack) -> Path:
    return state_dir / f"quad_x-{stack.instance}.signing"


def run_gcs(stack: Stack, observer: VehicleClient, *args: str, url: str | None = None, timeout_s: float = 180.0):
    """``python -m gcs --url URL ARGS`` (URL: :func:`fc_gcs_url` unless given; a CompletedProcess); the
    observer keeps reading meanwhile."""
    cmd = [sys.executable, "-m", "gcs", "--url", url or fc_gcs_url(stack), *args]
    env = {k: v for k, v in os.environ.items() if k != "GCS_SIGNING_KEY"}
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    try:
        observer.wait_until(lambda: proc.poll() is not None, timeout_s, f"{' '.join(args)} to finish")
        out, err = proc.communicate()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    return subprocess.CompletedProcess(cmd, proc.returncode, out, err)


def intruder_command(intruder, observer: VehicleClient, param1: float, param2: float = 0.0) -> list:
    """COMPONENT_ARM_DISARM from the intruder; the COMMAND_ACKs addressed to it while 3 s of vehicle time passed
    (it hears the vehicle meanwhile: it is one of its peers, so it also hears the answers to the signed ground
    station's commands, queued in its socket since it last read: those are drained first and not counted)."""
    stale = []
    while (m := intruder.recv_match(blocking=False)) is not None:
        stale.append(m)
    heard = []
    intruder.mav.command_long_send(
        observer.target_system, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, param1, param2, 0, 0, 0, 0, 0
    )
    end = observer.sim_time_s() + 3.0
    while observer.sim_time_s() < end:
        observer.pump(0.05)
        while (m := intruder.recv_match(blocking=False)) is not None:
            heard.append(m)
    # (the queued heartbeats count: after the drain, 3 s of vehicle time brought none in some runs)
    assert any(m.get_type() == "HEARTBEAT" for m in stale + heard), "the intruder no longer hears the vehicle"
    return [m for m in heard if m.get_type() == "COMMAND_ACK" and m.target_system in (0, INTRUDER_SYSID)]


def test_gcs_sets_a_key_and_an_unsigned_arm_has_no_effect(stack, state_dir, observer, intruder):
    p = run_gcs(stack, observer, "signing", "setup", PASSPHRASE)
    assert p.returncode == 0, p.stderr
    assert f"signing on for system {stack.sysid}" in p.stdout
    path = key_file(state_dir, stack)
    assert stat.S_IMODE(path.stat().st_mode) == 0o600
    assert f"key {hashlib.sha256(PASSPHRASE.encode()).hexdigest()}" in path.read_text()
    observer.wait_until(lambda: has_signature(observer.latest("HEARTBEAT")), 10, "a signed heartbeat")

    n_texts = len(observer.statustexts)
    assert intruder_command(intruder, observer, 1.0) == []  # ARM: no answer ...
    assert not observer.armed()  # ... and no effect
    observer.wait_until(
        lambda: any("MAVLink signing: refused" in t.text for t in observer.statustexts[n_texts:]), 30, "the warning"
    )


def test_signed_gcs_flies_while_the_unsigned_disarm_has_no_effect(stack, observer, intruder):
    key = ["--signing-key", PASSPHRASE]
    # Off (-1): the vehicle stays armed on the ground until the take-off's own process has started, however long that
    # takes (60 s was 12 wall seconds at 5x, and a flake hunt saw the arm time out before "takeoff" ran: "Takeoff
    # denied: vehicle not armed"); the auto-disarm has its own tests (test_e2e_command_validation.py).
    p = run_gcs(stack, observer, *key, "param", "set", "COM_DISARM_PRFLT", "-1")
    assert p.returncode == 0, p.stderr
    p = run_gcs(stack, observer, *key, "arm")
    assert p.returncode == 0 and "armed" in p.stdout, p.stderr
    p = run_gcs(stack, observer, *key, "takeoff", "3")
    assert p.returncode == 0, p.stderr
    observer.wait_until(lambda: (observer.relative_alt_m() or 0.0) > 2.5, 30, "the vehicle at 3 m")
    assert intruder_command(intruder, observer, 0.0, 21196.0) == []  # forced DISARM in the air: ignored
    assert observer.armed() and observer.relative_alt_m() > 2.5
    p = run_gcs(stack, observer, *key, "land")
    assert p.returncode == 0 and "landed and disarmed" in p.stdout, p.stderr


def test_the_key_survives_a_restart(stack, state_dir, observer):
    stack.restart_autopilot()
    observer.wait_until(lambda: "MAVLink signing ON: key loaded from" in stack.tail("autopilot", 40), WAIT_S, "start")
    # no key: it hears the vehicle, gets no answer
    p = run_gcs(stack, observer, "--timeout", "2", "arm", url=stack.api_url)
    assert p.returncode == 3 and "timed out after 2 s waiting for" in p.stderr, p.stdout + p.stderr
    assert "heartbeat" not in p.stderr
    assert not observer.armed()
    p = run_gcs(stack, observer, "--signing-key", PASSPHRASE, "arm")
    assert p.returncode == 0, p.stderr
    p = run_gcs(stack, observer, "--signing-key", PASSPHRASE, "disarm")
    assert p.returncode == 0, p.stderr
    p = run_gcs(
        stack, observer, "--timeout", "2", "--signing-key", "a wrong passphrase", "status", "--once", url=stack.api_url
    )
    assert (
        p.returncode == 3 and "messages refused as not signed with it: has the vehicle this --signing-key?" in p.stderr
    )
    p = run_gcs(stack, observer, "--timeout", "2", "--signing-key", "a wrong passphrase", "status", "--once")
    assert p.returncode == 3 and "nothing heard, none refused: has the vehicle this --signing-key?" in p.stderr


def test_gcs_disables_signing(stack, state_dir, observer):
    p = run_gcs(stack, observer, "signing", "disable", url=stack.api_url)  # without the key: refused here
    assert p.returncode == 1 and "give the current one with --signing-key" in p.stderr
    p = run_gcs(stack, observer, "--signing-key", PASSPHRASE, "signing", "disable")
    assert p.returncode == 0 and "signing off" in p.stdout, p.stderr
    assert not key_file(state_dir, stack).exists()
    observer.wait_until(lambda: not has_signature(observer.latest("HEARTBEAT")), 10, "an unsigned heartbeat")


def test_mavproxy_signing_setup_and_remove(stack, state_dir, observer):
    session = MavproxySession(fc_gcs_url(stack), modules="signing")
    try:
        session.expect(r"online system \d+")
        session.send(f"signing setup {MAVPROXY_PASSPHRASE}")
        session.expect("Setup signing key")
        key = hashlib.sha256(MAVPROXY_PASSPHRASE.encode()).hexdigest()
        deadline = time.monotonic() + WAIT_S
        while not (key_file(state_dir, stack).exists() and f"key {key}" in key_file(state_dir, stack).read_text()):
            assert time.monotonic() < deadline, "the vehicle did not keep MAVProxy's key"
            observer.pump(0.1)
        p = run_gcs(stack, observer, "--signing-key", MAVPROXY_PASSPHRASE, "param", "get", "MPC_XY_P")
        assert p.returncode == 0 and p.stdout.startswith("MPC_XY_P = "), p.stderr  # same passphrase, same key
        session.send("signing remove")
        session.expect("Removed signing")
        observer.wait_until(lambda: not key_file(state_dir, stack).exists(), 30, "the key file removed")
    finally:
        session.close()
