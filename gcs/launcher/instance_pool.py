"""Instance numbers leased at run time, so stacks started by programs never collide.

Instance I (PX4's ``-i``) uses the ports of :mod:`mavsim_core.ports`: TCP 4560+I (simulator link),
UDP 18570+I and 14640+I (the flight controller's sockets), and, bound by its clients, UDP 14540+I
(API), 14740+I (the simulator's component) and 14840+I (the stack's own ground-station port).  No two
instances 0-99 share a port (``tests/test_instances.py`` checks it), so any two distinct numbers can
run side by side.

:func:`lease` hands out the lowest number of a pool that no other process holds (another test, a
``campaign`` worker, a concurrent test run) and whose ports nothing on this machine binds (a person's
stack, a benchmark on its fixed instance).  The tests (``tests/instances.py``) and ``campaign`` runs
lease from the same :data:`POOL` (30-99) and the same locks, so a campaign, the test suite and a
person's ``flight-demo`` (0-9) can all run on one machine at once.  The pool keeps clear of people's
instances (0-9), of 10 (its API port is the shared 14550) and of the benchmarks' fixed defaults (11-29).

The lock on a number is a Linux abstract-namespace Unix socket bound to a name of its own: it lives
in the kernel only (no file anywhere), one process at a time can bind it, and it goes when the
process closes it or dies, so a killed run leaves nothing held.  It is per machine: on a Ray
cluster each node leases from its own numbers.
"""

from __future__ import annotations

import socket
from collections.abc import Iterable
from dataclasses import dataclass
from itertools import combinations

from mavsim_core import ports as port_scheme

PEOPLE = range(10)  # what someone runs by hand (flight-demo, gcs)
BENCHMARKS = range(11, 30)  # the benchmarks' fixed default instances (flight 20, vehicles 21+, ...)
POOL = range(30, port_scheme.MAX_INSTANCE + 1)  # what the tests and campaigns lease from
LOCK_NAMESPACE = "mavsim-flight-test-instance"  # the abstract socket of instance I: "\0<namespace>-I"


def ports(i: int) -> set[tuple[str, int]]:
    """Every (protocol, port) that instance ``i`` binds, itself or through its clients."""
    return {
        ("tcp", port_scheme.sim_tcp_port(i)),
        ("udp", port_scheme.gcs_local_port(i)),
        ("udp", port_scheme.api_local_port(i)),
        ("udp", port_scheme.api_port(i)),
        ("udp", port_scheme.sim_component_port(i)),
        ("udp", port_scheme.own_gcs_port(i)),
        ("udp", port_scheme.payload_local_port(i)),
        ("udp", port_scheme.camera_port(i)),
        ("udp", port_scheme.video_port(i)),
    }


def collisions(numbers: list[int]) -> list[tuple[int, int, set[tuple[str, int]]]]:
    """Pairs of (distinct positions in) ``numbers`` that share a port, with the ports shared."""
    return [(a, b, ports(a) & ports(b)) for a, b in combinations(numbers, 2) if ports(a) & ports(b)]


def ports_free(i: int) -> bool:
    """True if nothing on this machine binds a port of instance ``i`` (a user's stack, another run)."""
    for proto, port in ports(i):
        kind = socket.SOCK_STREAM if proto == "tcp" else socket.SOCK_DGRAM
        with socket.socket(socket.AF_INET, kind) as s:
            try:
                s.bind(("", port))  # the wildcard address collides with a bind on 127.0.0.1 too
            except OSError:
                return False
    return True


@dataclass
class Lease:
    """Instance ``number``, held (its lock socket bound) until :meth:`release` or the process ends."""

    number: int
    _lock: socket.socket | None

    def release(self) -> None:
        if self._lock is not None:
            self._lock.close()  # closing frees the name at once
            self._lock = None

    def __enter__(self) -> "Lease":
        return self

    def __exit__(self, *exc: object) -> None:
        self.release()


def _lock(i: int) -> socket.socket | None:
    """The lock of instance ``i`` bound by this process, or None if a process holds it already."""
    s = socket.socket(socket.AF_UNIX, socket.SOCK_DGRAM)  # not inherited by child processes (PEP 446)
    try:
        s.bind(f"\0{LOCK_NAMESPACE}-{i:02d}")
    except OSError:
        s.close()
        return None
    return s


def lease(pool: Iterable[int] = POOL) -> Lease:
    """The lowest number of ``pool`` that no process holds and whose ports are free, held until released.

    Keep the returned Lease: once it is garbage-collected its socket closes and the number is free again.
    RuntimeError if there is none (every one held or its ports taken).
    """
    numbers = list(pool)
    for i in numbers:
        lock = _lock(i)
        if lock is None:
            continue
        if ports_free(i):
            return Lease(i, lock)
        lock.close()
    span = f"{numbers[0]}-{numbers[-1]}" if numbers else "an empty pool"
    raise RuntimeError(f"no free test instance in {span}: every one is held or its ports are taken")
