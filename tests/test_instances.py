"""The port scheme (mavsim_core.ports) and the free instances the tests lease (tests/instances.py)."""

from __future__ import annotations

import os
import socket
import subprocess
import sys
import uuid
from pathlib import Path

import pytest

from gcs.launcher import instance_pool
from mavsim_core import ports as port_scheme

from instances import BENCHMARKS, PEOPLE, POOL, collisions, lease, ports

TESTS = Path(__file__).resolve().parent
EVERY_INSTANCE = range(port_scheme.MAX_INSTANCE + 1)


def test_ports_of_an_instance_follow_px4():
    """PX4 SITL instance 3: system id 4, TCP 4563, API link to 14543, ground-station link from 18573 to 14550,
    onboard payload link 14283 <-> camera 14033, video to 5603."""
    assert port_scheme.system_id(3) == 4
    assert port_scheme.sim_tcp_port(3) == 4563
    assert port_scheme.api_port(3) == 14543
    assert port_scheme.gcs_local_port(3) == 18573
    assert port_scheme.GCS_PORT == 14550
    assert port_scheme.payload_local_port(3) == 14283 and port_scheme.camera_port(3) == 14033
    assert port_scheme.video_port(3) == 5603
    assert ports(3) == {
        ("tcp", 4563), ("udp", 18573), ("udp", 14643), ("udp", 14543), ("udp", 14743), ("udp", 14843),
        ("udp", 14283), ("udp", 14033), ("udp", 5603),
    }  # fmt: skip


def test_no_two_instances_0_to_99_share_a_port():
    """Every pair of instances 0-99: nothing bound by one (itself or its clients) is bound by the other."""
    assert collisions(list(EVERY_INSTANCE)) == []


def test_only_instance_10_sends_its_api_link_to_the_shared_ground_station_port():
    """PX4's own overlap: 14540+10 = 14550.  No other port of any instance is 14550."""
    on_14550 = [i for i in EVERY_INSTANCE if ("udp", port_scheme.GCS_PORT) in ports(i)]
    assert on_14550 == [10]


def test_the_pool_keeps_clear_of_people_benchmarks_and_10():
    assert not set(POOL) & {*PEOPLE, *BENCHMARKS, 10}
    assert min(POOL) == 30 and max(POOL) == port_scheme.MAX_INSTANCE


def test_two_leases_differ():
    a, b = lease(), lease()
    try:
        assert a.number != b.number and {a.number, b.number} <= set(POOL)
    finally:
        a.release()
        b.release()


def test_a_lease_skips_an_instance_whose_port_is_taken():
    """A program (here this test) binds one port of a free instance: no lease hands that instance out."""
    held = lease()
    n = held.number
    taken = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    taken.bind(("127.0.0.1", port_scheme.own_gcs_port(n)))  # as a ground station listening there would
    held.release()
    other = None
    try:
        with pytest.raises(RuntimeError, match=f"no free test instance in {n}-{n}"):
            lease([n])
        other = lease()
        assert other.number != n
    finally:
        taken.close()
        if other is not None:
            other.release()


def test_a_released_lease_is_reused(private_locks):
    first = lease()
    n = first.number
    first.release()
    again = lease([n])
    try:
        assert again.number == n
    finally:
        again.release()


@pytest.fixture
def private_locks(monkeypatch) -> str:
    """Locks in a namespace of this test's own: another run's leases (a second suite on the machine) cannot
    take a number this test has just released before it looks again."""
    namespace = f"{instance_pool.LOCK_NAMESPACE}-test-{os.getpid()}-{uuid.uuid4().hex[:8]}"
    monkeypatch.setattr(instance_pool, "LOCK_NAMESPACE", namespace)
    return namespace


CHILD = """
import sys
sys.path.insert(0, sys.argv[1])
from gcs.launcher import instance_pool
instance_pool.LOCK_NAMESPACE = sys.argv[3]
from instances import lease
try:
    lease([int(sys.argv[2])])
    print("took it", flush=True)
except RuntimeError:
    print("held", flush=True)
held = lease()  # kept: a lease dropped is a lease released
print(held.number, flush=True)
sys.stdin.read()  # hold the lease until the parent closes stdin or kills this process
"""


def test_the_lock_is_per_process_and_dies_with_it(private_locks):
    """Another process cannot take an instance this one holds; what it holds is free once it is killed."""
    mine = lease()
    child = subprocess.Popen(
        [sys.executable, "-c", CHILD, str(TESTS), str(mine.number), private_locks],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
    )
    try:
        assert child.stdout.readline().strip() == "held"
        theirs = int(child.stdout.readline())
        assert theirs != mine.number
        with pytest.raises(RuntimeError):
            lease([theirs])  # the child holds it
    finally:
        child.kill()
        child.wait(timeout=30)
        mine.release()
    freed = instance_pool._lock(theirs)  # its lock (whether its ports are free is another test's)
    assert freed is not None, f"instance {theirs} still locked after its holder was killed"
    freed.close()
