"""The simulator link lost and regained, the flight controller restarted in the air, the simulator's port
squatted: what a field test does to the link between the two processes (issue 18, findings 1, 2 and 7).

* The simulator is killed (SIGKILL) while the vehicle hovers and started again with the same command
  line: while it is gone the ground station (pymavlink on the stack's ground-station port) keeps getting
  HEARTBEATs at 1 Hz of wall-clock time, in MAV_STATE_CRITICAL, and a CRITICAL STATUSTEXT "Simulator
  link lost"; once the simulator is back its clock has restarted, so the flight controller resets its
  estimator and controllers, is disarmed and says so; the restarted simulator's truth shows the vehicle
  never leaves the ground (no fly-away), and the vehicle can be armed again.
* The simulator's TCP port and its ``SIM_*``/truth socket listen on 127.0.0.1 only (not reachable on this
  machine's other address).
* A silent TCP client connects to the simulator's port before a restarted flight controller does: the
  simulator drops it after its handshake timeout and serves the flight controller, so the simulation
  runs on (truth time advances) and the vehicle becomes armable again.
* The flight controller is restarted (SIGTERM, a new process) while the vehicle hovers: it comes up
  disarmed, the vehicle falls, the flight controller says it started while moving and sets home only
  once the vehicle is at rest on the ground (its relative altitude there is about 0).

Ground truth comes from the simulator's truth port (gcs.sim_client.SimClient); durations the vehicle
must hold are simulated seconds; wall-clock waits are safety nets, except the heartbeat rate while the
simulator is gone, which is a wall-clock rate by design.
"""

from __future__ import annotations

import math
import socket
import threading
import time

import pytest
from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink

from gcs.launcher import Stack
from gcs.sim_client import SimClient
from mavsim_core import ports

from e2e_flight_helpers import CLIENT_SPEED  # tests/e2e_flight_helpers.py

pytestmark = pytest.mark.e2e
WAIT_S = 120.0  # wall-clock safety net of each wait (a loaded 2-core machine)
ALT_M = 2.5  # MIS_TAKEOFF_ALT's default: NAV_TAKEOFF without an altitude
FALL_ALT_M = 5.0  # the flight-controller restart: a fall of about a second
SIM_GONE_S = 4.0  # wall seconds the simulator stays dead


class GcsWatch:
    """A ground station on the stack's ground-station port (pymavlink): records, with their wall-clock
    arrival, the flight controller's HEARTBEATs and STATUSTEXTs; sends commands and waits for their ACK."""

    def __init__(self, url: str, sysid: int) -> None:
        self.sysid = sysid
        self.conn = mavutil.mavlink_connection(url, source_system=255, source_component=190, dialect="common")
        self.heartbeats: list[tuple[float, object]] = []
        self.texts: list[tuple[float, int, str]] = []
        self.latest: dict[str, object] = {}
        self.acks: list[object] = []
        self.lock = threading.Lock()
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._run, name="gcs-watch", daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            try:
                msg = self.conn.recv_match(blocking=True, timeout=0.2)
            except (OSError, mavlink.MAVError):
                continue
            if msg is None or msg.get_srcSystem() != self.sysid or msg.get_srcComponent() != 1:
                continue
            now, kind = time.monotonic(), msg.get_type()
            with self.lock:
                self.latest[kind] = msg
                if kind == "HEARTBEAT":
                    self.heartbeats.append((now, msg))
                elif kind == "STATUSTEXT":
                    self.texts.append((now, msg.severity, msg.text))
                elif kind == "COMMAND_ACK":
                    self.acks.append(msg)

    def close(self) -> None:
        self._stop.set()
        self.thread.join(timeout=2)
        self.conn.close()

    def get(self, kind: str):
        with self.lock:
            return self.latest.get(kind)

    def armed(self) -> bool:
        hb = self.get("HEARTBEAT")
        return hb is not None and bool(hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)

    def text_index(self) -> int:
        with self.lock:
            return len(self.texts)

    def texts_since(self, index: int) -> list[tuple[float, int, str]]:
        with self.lock:
            return list(self.texts[index:])

    def heartbeats_between(self, t0: float, t1: float) -> list:
        with self.lock:
            return [m for t, m in self.heartbeats if t0 <= t <= t1]

    def command(self, command: int, *params: float, timeout_s: float = 3.0) -> int | None:
        """COMMAND_LONG to the flight controller; its MAV_RESULT, or None without an answer."""
        with self.lock:
            self.acks.clear()
        p = list(params) + [0.0] * (7 - len(params))
        self.conn.mav.command_long_send(self.sysid, 1, command, 0, *p)
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            with self.lock:
                for ack in self.acks:
                    if ack.command == command:
                        return ack.result
            time.sleep(0.02)
        return None

    def wait(self, predicate, what: str, timeout_s: float = WAIT_S) -> None:
        deadline = time.monotonic() + timeout_s
        while not predicate():
            if time.monotonic() > deadline:
                raise AssertionError(f"timed out waiting for {what}")
            time.sleep(0.05)

    def wait_text(self, index: int, fragment: str, timeout_s: float = WAIT_S) -> tuple[float, int, str]:
        self.wait(lambda: any(fragment in t for _, _, t in self.texts_since(index)), repr(fragment), timeout_s)
        return next(x for x in self.texts_since(index) if fragment in x[2])

    def arm_when_ready(self) -> None:
        """Arm as soon as the pre-arm checks pass (the estimator converged, home set)."""
        self.wait(lambda: self.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0) == 0, "arming accepted")
        self.wait(self.armed, "HEARTBEAT armed")


def truth_height_m(truth: SimClient) -> float:
    s = truth.latest()
    return -s.pos_ned_m[2] if s is not None else 0.0


def take_off(gcs: GcsWatch, truth: SimClient, alt_m: float) -> None:
    """Arm, NAV_TAKEOFF ``alt_m`` above home, until the truth hovers there."""
    gcs.arm_when_ready()
    gcs.wait(lambda: gcs.command(mavlink.MAV_CMD_GET_HOME_POSITION) == 0, "GET_HOME_POSITION accepted")
    gcs.wait(lambda: gcs.get("HOME_POSITION") is not None, "HOME_POSITION")
    home = gcs.get("HOME_POSITION")
    amsl = home.altitude * 1e-3 + alt_m
    assert gcs.command(mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, math.nan, math.nan, math.nan, amsl) == 0
    gcs.wait(lambda: truth_height_m(truth) > alt_m - 0.4, f"hover at {alt_m} m (truth)")


def sim_sleep(truth: SimClient, seconds: float) -> None:
    """Wait ``seconds`` of simulated time (the truth clock; from its first sample if none came yet)."""
    deadline = time.monotonic() + WAIT_S
    while truth.latest() is None:
        assert time.monotonic() < deadline, "no truth from the simulator"
        time.sleep(0.01)
    start = truth.caught_up()  # from now, not from where the reader had got on a loaded machine
    while truth.latest().time_ms < start + seconds * 1000:
        assert time.monotonic() < deadline, f"{seconds} simulated seconds did not pass"
        time.sleep(0.01)


# First in the file: it flies its own stack, and the module's stack (below) would idle at CLIENT_SPEED through it.
def test_flight_controller_restarted_in_the_air_sets_home_only_at_rest(free_instance):
    with Stack(instance=free_instance(), speed=CLIENT_SPEED, flight_logs=False) as stack:
        gcs = GcsWatch(stack.gcs_url, stack.sysid)
        truth = SimClient(ports.sim_component_port(stack.instance))
        try:
            take_off(gcs, truth, FALL_ALT_M)
            index = gcs.text_index()
            stack.restart_autopilot()
            started = gcs.wait_text(index, "Moving while disarmed")
            assert started[1] <= mavlink.MAV_SEVERITY_WARNING, started
            gcs.wait(lambda: truth_height_m(truth) < 0.3, "the vehicle on the ground (truth)")
            sim_sleep(truth, 3.0)
            assert not gcs.armed()
            gcs.wait_text(index, "Home set")
            gcs.wait(lambda: gcs.get("GLOBAL_POSITION_INT") is not None, "GLOBAL_POSITION_INT")
            sim_sleep(truth, 1.0)
            rel = gcs.get("GLOBAL_POSITION_INT").relative_alt * 1e-3
            assert abs(rel) < 0.5, f"on the ground {rel:.2f} m above home: home was set while falling"
        finally:
            truth.close()
            gcs.close()


@pytest.fixture(scope="module")
def sim_restart_stack(inst):
    with Stack(instance=inst, speed=CLIENT_SPEED, flight_logs=False) as stack:
        gcs = GcsWatch(stack.gcs_url, stack.sysid)
        try:
            yield stack, gcs
        finally:
            gcs.close()


def listening_tcp_hosts(port: int) -> set[str]:
    """The local IPv4 addresses a socket listens on at TCP ``port`` (Linux /proc/net/tcp)."""
    hosts = set()
    with open("/proc/net/tcp") as f:
        for line in f.readlines()[1:]:
            local, state = line.split()[1], line.split()[3]
            addr, hex_port = local.split(":")
            if state == "0A" and int(hex_port, 16) == port:
                hosts.add(socket.inet_ntoa(bytes.fromhex(addr)[::-1]))
    return hosts


def test_simulator_ports_are_loopback_only(sim_restart_stack):
    """What a user's `sitl` exposes by default: its TCP port and its SIM_* / truth socket, on 127.0.0.1 only."""
    stack, _ = sim_restart_stack
    assert listening_tcp_hosts(stack.sitl_port) == {"127.0.0.1"}
    assert "SIM_* parameters and ground truth: MAVLink sysid" in stack.tail("sitl", 50)
    assert "on UDP 127.0.0.1:" in stack.tail("sitl", 50)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as probe:
        try:
            probe.connect(("192.0.2.1", 9))  # (no packet sent) this machine's address toward another network
            other = probe.getsockname()[0]
        except OSError:
            other = None
    if other is not None and not other.startswith("127."):
        with socket.socket() as s:
            s.settimeout(2.0)
            assert s.connect_ex((other, stack.sitl_port)) != 0, f"the simulator's TCP port is reachable on {other}"


def test_simulator_killed_in_a_hover_and_restarted_no_fly_away(sim_restart_stack):
    stack, gcs = sim_restart_stack
    truth = SimClient(ports.sim_component_port(stack.instance))
    try:
        take_off(gcs, truth, ALT_M)
        sim_sleep(truth, 1.0)
    finally:
        truth.close()
    index = gcs.text_index()
    stack.kill_sitl()
    killed = time.monotonic()
    time.sleep(SIM_GONE_S)
    gone = gcs.heartbeats_between(killed + 1.0, time.monotonic())
    # The ground station still hears the vehicle at 1 Hz (wall clock), in MAV_STATE_CRITICAL.
    assert len(gone) >= SIM_GONE_S - 2, f"{len(gone)} HEARTBEATs in {SIM_GONE_S - 1:g} s without the simulator"
    assert all(hb.system_status == mavlink.MAV_STATE_CRITICAL for hb in gone), [hb.system_status for hb in gone]
    lost = [x for x in gcs.texts_since(index) if "Simulator link lost" in x[2]]
    assert lost and lost[0][1] == mavlink.MAV_SEVERITY_CRITICAL, gcs.texts_since(index)

    truth = SimClient(ports.sim_component_port(stack.instance))  # the restarted simulator's clock starts at 0
    try:
        stack.start_sitl()
        gcs.wait_text(index, "Simulator link regained")
        gcs.wait(lambda: not gcs.armed(), "HEARTBEAT disarmed after the simulator came back")
        truth.wait_connected(timeout_s=WAIT_S)
        sim_sleep(truth, 5.0)
        highest = max(-s.pos_ned_m[2] for s in truth.since(0))
        assert highest < 0.5, f"the vehicle climbed to {highest:.2f} m after the simulator restarted"
        texts = [t for _, _, t in gcs.texts_since(index)]
        assert any("Disarmed" in t for t in texts), texts
        # The flight controller is whole again: it arms (and disarms) on the restarted simulator.
        gcs.arm_when_ready()
        assert gcs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0.0) == 0
    finally:
        truth.close()


def test_a_silent_client_on_the_simulator_port_is_dropped(sim_restart_stack):
    """A local program connects to the simulator's port and stays silent; then the flight controller
    restarts: the simulator, accepting the next peer in its queue, gets the squatter first, drops it
    after its handshake timeout and serves the flight controller, so the simulation runs on."""
    stack, gcs = sim_restart_stack
    squatter = socket.create_connection(("127.0.0.1", stack.sitl_port), timeout=5)  # connects, never speaks
    truth = SimClient(ports.sim_component_port(stack.instance))
    try:
        truth.wait_connected(timeout_s=WAIT_S)
        stack.restart_autopilot()
        start = truth.caught_up()
        gcs.wait(lambda: truth.latest().time_ms > start + 2000, "the simulation to run on with the new FC")
        assert "dropped 127.0.0.1" in stack.tail("sitl", 200), stack.tail("sitl", 30)
        gcs.arm_when_ready()
        assert gcs.command(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0.0) == 0
    finally:
        squatter.close()
        truth.close()
