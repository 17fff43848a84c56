"""End-to-end: the ``gcs`` CLI over a link that loses half of the datagrams each way (issue 18, finding 11).

One max-speed stack (module scope, a free instance).  ``gcs`` runs as a subprocess and
talks to a UDP relay in this test (:class:`LossyRelay`) that forwards to the flight controller's
ground-station socket and back, dropping each datagram with a set probability, each way on its own.
An observer (:class:`VehicleClient`, no loss) listens where the flight controller sends its ground-station
link and checks the effect of each command the way a user would look at the vehicle.

* ``param set``, ``param get``, ``arm`` and ``takeoff`` at 50 % loss each way: exit 0 and the effect is there;
* an unknown parameter name: exit 1, "unknown parameter", not a timeout; a refused value: exit 1 and the reason;
* a vehicle that hears nothing (every datagram to it lost): exit 3, "no answer from the vehicle".

Exit codes of ``gcs``: 0 done, 1 refused or failed, 2 usage, 3 no answer.  Wall-clock values are only
"give up waiting" timeouts; how long each command took and how many datagrams the relay dropped is printed.
"""

from __future__ import annotations

import random
import select
import socket
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from gcs.client import VehicleClient, mavlink
from gcs.launcher import Stack
from mavsim_core import ports

from e2e_flight_helpers import CLIENT_SPEED, WAIT_S  # tests/e2e_flight_helpers.py

pytestmark = pytest.mark.e2e
ROOT = Path(__file__).resolve().parent.parent
LOSS = 0.5  # probability that a datagram is dropped, each way
PARAM_TIMEOUT_S = 20  # gcs --timeout for the parameter commands: 40 tries of 0.5 s at 25 % success each


class LossyRelay:
    """UDP relay between ground stations and the flight controller's socket ``fc``: a datagram from the
    ground station is forwarded with probability ``1 - loss_up``, one from the flight controller with
    ``1 - loss_down`` (to the ground station heard last).  ``port``: where ground stations send."""

    def __init__(self, fc: tuple[str, int], loss: float, seed: int = 18) -> None:
        self.fc = fc
        self.loss_up = self.loss_down = loss
        self.rng = random.Random(seed)
        self.down = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)  # the ground stations' side
        self.down.bind(("127.0.0.1", 0))
        self.up = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)  # the flight controller's side
        self.up.bind(("127.0.0.1", 0))
        self.port = self.down.getsockname()[1]
        self.client: tuple[str, int] | None = None
        self.counts = {"up": 0, "up_dropped": 0, "down": 0, "down_dropped": 0}
        self._stop = False
        self._thread = threading.Thread(target=self._run, name="lossy-relay", daemon=True)
        self._thread.start()

    def introduce(self) -> None:
        """A GCS HEARTBEAT from the relay's own socket, never dropped: the flight controller streams to it."""
        mav = mavlink.MAVLink(None, srcSystem=254, srcComponent=190)
        hb = mav.heartbeat_encode(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        self.up.sendto(hb.pack(mav), self.fc)

    def _run(self) -> None:
        while not self._stop:
            readable, _, _ = select.select([self.down, self.up], [], [], 0.1)
            for sock in readable:
                try:
                    data, addr = sock.recvfrom(65535)
                except OSError:
                    continue
                if sock is self.down:
                    self.client = addr
                    self._forward("up", self.up, data, self.fc, self.loss_up)
                elif self.client is not None:
                    self._forward("down", self.down, data, self.client, self.loss_down)

    def _forward(self, way: str, sock: socket.socket, data: bytes, to: tuple[str, int], loss: float) -> None:
        self.counts[way] += 1
        if self.rng.random() < loss:
            self.counts[f"{way}_dropped"] += 1
            return
        try:
            sock.sendto(data, to)
        except OSError:
            pass

    def close(self) -> None:
        self._stop = True
        self._thread.join(timeout=2.0)
        self.down.close()
        self.up.close()


@pytest.fixture(scope="module")
def stack(inst, tmp_path_factory):
    startup = tmp_path_factory.mktemp("lossy") / "startup.params"
    # The simulation runs faster than real time: the vehicle must not disarm for want of a take-off
    # while the next gcs process starts.
    startup.write_text("COM_DISARM_PRFLT -1\n")
    with Stack(
        instance=inst,
        speed=CLIENT_SPEED,
        extra_sitl_args=["--truth-port", "0"],
        extra_autopilot_args=["--params", str(startup)],
        flight_logs=False,
    ) as s:
        yield s


@pytest.fixture(scope="module")
def observer(stack):
    with VehicleClient(stack.gcs_url, timeout_s=WAIT_S, target_system=stack.sysid, idle=stack.check_alive) as c:
        yield c


@pytest.fixture(scope="module")
def relay(stack, observer):
    r = LossyRelay(("127.0.0.1", ports.gcs_local_port(stack.instance)), LOSS)
    r.introduce()
    try:
        yield r
    finally:
        r.close()


def run_gcs(stack: Stack, observer: VehicleClient, relay: LossyRelay, *args: str) -> subprocess.CompletedProcess:
    """``python -m gcs --url udpout:<relay> -i INSTANCE ARGS`` (the observer keeps listening meanwhile);
    prints how long it took and what the relay dropped."""
    cmd = [sys.executable, "-m", "gcs", "--url", f"udpout:127.0.0.1:{relay.port}", "-i", str(stack.instance), *args]
    before = dict(relay.counts)
    start = time.monotonic()
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        observer.wait_until(lambda: proc.poll() is not None, 300, f"gcs {' '.join(args)} to finish")
        out, err = proc.communicate()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    delta = {k: relay.counts[k] - before[k] for k in before}
    print(
        f"\ngcs {' '.join(args)}: exit {proc.returncode} in {time.monotonic() - start:.1f} s; relay dropped "
        f"{delta['up_dropped']}/{delta['up']} datagrams to the vehicle, {delta['down_dropped']}/{delta['down']} back"
    )
    return subprocess.CompletedProcess(cmd, proc.returncode, out, err)


def test_a_vehicle_that_hears_nothing_is_no_answer(stack, observer, relay):
    relay.loss_up, relay.loss_down = 1.0, 0.0  # the vehicle is heard, nothing reaches it
    try:
        p = run_gcs(stack, observer, relay, "--timeout", "3", "arm")
    finally:
        relay.loss_up = relay.loss_down = LOSS
    assert p.returncode == 3, p.stdout + p.stderr
    assert "no answer from the vehicle" in p.stderr and "MAV_CMD_COMPONENT_ARM_DISARM" in p.stderr, p.stderr
    assert not observer.armed()


def test_param_set_and_get_through_the_loss(stack, observer, relay):
    p = run_gcs(stack, observer, relay, "--timeout", str(PARAM_TIMEOUT_S), "param", "set", "MPC_XY_P", "1.1")
    assert p.returncode == 0 and p.stdout.strip() == "MPC_XY_P = 1.1", p.stdout + p.stderr
    assert observer.param_get("MPC_XY_P") == pytest.approx(1.1)
    p = run_gcs(stack, observer, relay, "--timeout", str(PARAM_TIMEOUT_S), "param", "get", "MPC_XY_P")
    assert p.returncode == 0 and p.stdout.strip() == "MPC_XY_P = 1.1", p.stdout + p.stderr
    observer.param_set("MPC_XY_P", 0.95)


def test_unknown_name_and_refused_value_are_refusals_not_timeouts(stack, observer, relay):
    p = run_gcs(stack, observer, relay, "--timeout", str(PARAM_TIMEOUT_S), "param", "get", "NO_SUCH_PARAM")
    assert p.returncode == 1 and "unknown parameter NO_SUCH_PARAM" in p.stderr, p.stdout + p.stderr
    p = run_gcs(stack, observer, relay, "--timeout", str(PARAM_TIMEOUT_S), "param", "set", "MPC_XY_P", "7")
    assert p.returncode == 1 and "outside range" in p.stderr, p.stdout + p.stderr
    assert observer.param_get("MPC_XY_P") == pytest.approx(0.95)


def test_arm_and_takeoff_through_the_loss(stack, observer, relay):
    observer.wait_until(lambda: observer.prearm_ok() and observer.gps() is not None, WAIT_S, "ready to arm")
    observer.wait_home(WAIT_S)
    p = run_gcs(stack, observer, relay, "arm")
    assert p.returncode == 0 and "armed" in p.stdout, p.stdout + p.stderr
    observer.wait_armed(True, WAIT_S)
    p = run_gcs(stack, observer, relay, "takeoff", "2")
    assert p.returncode == 0 and "m above home (mode" in p.stdout, p.stdout + p.stderr
    observer.wait_until(lambda: observer.takeoff_done(2.0), WAIT_S, "the vehicle at 2 m")
    assert observer.armed() and observer.relative_alt_m() == pytest.approx(2.0, abs=0.5)
    observer.land(timeout_s=10).check()  # leave it on the ground
    observer.wait_until(observer.landed_and_disarmed, WAIT_S, "landed and disarmed")


def test_a_retransmitted_takeoff_gets_the_first_answer(stack, observer):
    """The vehicle side of the retries: a NAV_TAKEOFF sent again (confirmation 1) once the vehicle flies is
    acknowledged as the first was, not refused as "already flying"; sent anew (confirmation 0) it is refused."""
    observer.arm(timeout_s=10).check()
    observer.wait_armed(True, WAIT_S)
    alt_amsl = observer.wait_home(WAIT_S).alt_amsl_m + 2.0
    nan = float("nan")

    def takeoff(confirmation: int) -> int:
        observer.drain()
        observer.conn.mav.command_long_send(
            stack.sysid, 1, mavlink.MAV_CMD_NAV_TAKEOFF, confirmation, nan, 0, 0, nan, nan, nan, alt_amsl
        )
        ack = observer.recv("COMMAND_ACK", WAIT_S, lambda m: m.command == mavlink.MAV_CMD_NAV_TAKEOFF)
        assert ack is not None, "no COMMAND_ACK"
        return ack.result

    assert takeoff(0) == mavlink.MAV_RESULT_ACCEPTED
    observer.wait_until(lambda: observer.takeoff_done(2.0), WAIT_S, "the vehicle at 2 m")
    assert takeoff(1) == mavlink.MAV_RESULT_ACCEPTED  # the copy of the command carried out
    assert takeoff(0) == mavlink.MAV_RESULT_DENIED  # a new command: the vehicle is flying
    observer.land(timeout_s=10).check()
    observer.wait_until(observer.landed_and_disarmed, WAIT_S, "landed and disarmed")
