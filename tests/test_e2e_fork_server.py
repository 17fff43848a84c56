"""The fork server (gcs/launcher/fork_server.py): a stack whose two processes are forked from a process that has
imported them already is the same stack as one whose processes started on their own.

- the same seed gives the same flight controller, to the bit: its attitude estimate (ATTITUDE, from the simulated
  gyro's seeded noise) at every simulated time both streamed, on the ground at full speed, whatever the wall clock
  did;
- the processes are the server's children, and they end as ``subprocess.Popen``'s do (a signal's end is minus
  the signal, the simulator's SIGTERM 143);
- the server's end ends its children; a command it does not run (another module) is left to a process of its own;
- a server started by a thread outlives the thread (tests/test_e2e_reproducible.py flies two stacks from threads).
"""

from __future__ import annotations

import os
import signal
import sys
import threading
import time

import pytest
from pymavlink import mavutil

from gcs.launcher import Stack, fork_server
from gcs.launcher.stack import PROJECT_ROOT

pytestmark = pytest.mark.e2e
SIM_S = 4.0  # simulated seconds of estimates compared


def parent_pid(pid: int) -> int:
    with open(f"/proc/{pid}/stat") as f:
        return int(f.read().rsplit(")", 1)[1].split()[1])


def estimates(stack: Stack, seconds: float) -> dict[int, tuple[float, float, float]]:
    """ATTITUDE of the API link by its time_boot_ms, until ``seconds`` of simulated time."""
    conn = mavutil.mavlink_connection(stack.api_url, dialect="common")
    out: dict[int, tuple[float, float, float]] = {}
    deadline = time.monotonic() + 60.0  # a safety net
    try:
        while time.monotonic() < deadline:
            m = conn.recv_match(type="ATTITUDE", blocking=True, timeout=5)
            if m is None:
                continue
            out[m.time_boot_ms] = (m.roll, m.pitch, m.yaw)
            if m.time_boot_ms >= seconds * 1000:
                return out
    finally:
        conn.close()
    raise AssertionError(f"no estimate past {seconds} s")


def test_a_forked_stack_is_the_same_stack(free_instance, monkeypatch):
    inst = free_instance()
    monkeypatch.setattr(fork_server, "_here", False)  # (the suite forks its stacks: tests/conftest.py)
    monkeypatch.delenv(fork_server.ENV, raising=False)
    with Stack(instance=inst, speed="max", seed=11, flight_logs=False) as plain:
        assert {parent_pid(p.pid) for p in plain.procs.values()} == {os.getpid()}
        own = estimates(plain, SIM_S)
    monkeypatch.setattr(fork_server, "_here", True)
    with Stack(instance=inst, speed="max", seed=11, flight_logs=False) as forked:
        server = fork_server.current()  # (the one the stack started)
        assert server is not None
        assert {parent_pid(p.pid) for p in forked.procs.values()} == {server.proc.pid}
        theirs = estimates(forked, SIM_S)
        assert forked.kill_autopilot(signal.SIGKILL) == -signal.SIGKILL
        codes = forked.stop()
    assert codes == {"autopilot": -signal.SIGKILL, "sitl": 143}
    common = sorted(set(own) & set(theirs))
    assert len(common) > 10, (len(own), len(theirs))
    assert [own[t] for t in common] == [theirs[t] for t in common]


def test_the_servers_end_ends_its_children_and_other_commands_are_not_its(free_instance, tmp_path):
    inst = free_instance()
    server = fork_server.ForkServer(root=PROJECT_ROOT)
    try:
        stack = Stack(instance=inst, speed=1, flight_logs=False)
        cmd = stack.sitl_command()
        assert server.spawn([sys.executable, "-m", "gcs", "--help"], tmp_path, {}, tmp_path / "gcs.log") is None
        child = server.spawn(cmd, PROJECT_ROOT, dict(os.environ), tmp_path / "sitl.log")
        assert child is not None and child.poll() is None
        assert parent_pid(child.pid) == server.proc.pid
    finally:
        server.close()
    assert child.wait(timeout=30) in (143, -signal.SIGTERM), (tmp_path / "sitl.log").read_text()[-2000:]


def test_a_server_started_from_a_thread_outlives_it(free_instance, monkeypatch):
    inst = free_instance()
    monkeypatch.setattr(fork_server, "_here", True)
    monkeypatch.setattr(fork_server, "_shared", None)  # a server of this test's own, started in the thread
    started: list[int] = []

    def fly() -> None:
        with Stack(instance=inst, speed="max", flight_logs=False) as stack:
            estimates(stack, 1.0)
            server = fork_server.current()
            assert server is not None
            started.append(server.proc.pid)

    thread = threading.Thread(target=fly)
    thread.start()
    thread.join(120)
    assert started, "the thread's stack did not fly"
    time.sleep(1.0)  # (the parent-death signal, had it been set, comes at once)
    server = fork_server.current()
    try:
        assert server is not None and server.proc.poll() is None and server.proc.pid == started[0]
        with Stack(instance=inst, speed="max", flight_logs=False) as stack:
            assert {parent_pid(p.pid) for p in stack.procs.values()} == {started[0]}
            estimates(stack, 1.0)
    finally:
        if server is not None:
            server.close()
