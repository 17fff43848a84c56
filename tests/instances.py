"""Instance numbers for the tests that bind ports: leased at run time, never written down.

Instance I (PX4's ``-i``) uses the ports of :mod:`mavsim_core.ports`: TCP 4560+I (simulator link),
UDP 18570+I and 14640+I (the flight controller's sockets), and, bound by its clients, UDP 14540+I
(API), 14740+I (the simulator's component) and 14840+I (the stack's own ground-station port: tests
never bind the shared 14550, where a person's QGroundControl may listen).  No two instances 0-99
share a port (``tests/test_instances.py`` checks it), so any two distinct numbers can run side by side.

A test takes its numbers from the ``free_instance`` fixture (tests/conftest.py), which calls
:func:`lease`: the lowest number of :data:`POOL` that no other test holds (in this run, another
pytest-xdist worker or a concurrent run) and whose ports nothing on this machine binds (a person's
stack, a benchmark).  The pool keeps clear of people's instances (0-9: ``flight-demo``, ``gcs``), of 10
(its API port is the shared 14550) and of the benchmarks' defaults (11-29, benchmarks/*.py).

The lock on a number is a Linux abstract-namespace Unix socket bound to a name of its own: it lives
in the kernel only (no file anywhere), one process at a time can bind it, and it goes when the
process closes it or dies, so a killed run leaves nothing held.
"""

from __future__ import annotations

import socket
from collections.abc import Iterable
from dataclasses import dataclass
from itertools import combinations

from mavsim_core import ports as port_scheme

PEOPLE = range(10)  # what someone runs by hand while the suite runs
BENCHMARKS = range(11, 30)  # the benchmarks' default instances (landing 11-19, flight 20, vehicles 21+, ...)
POOL = range(30, port_scheme.MAX_INSTANCE + 1)  # what the tests lease from
LOCK_NAMESPACE = "mavsim-flight-test-instance"  # the abstract socket of instance I: "\0<namespace>-I"


def ports(i: int) -> set[tuple[str, int]]:
    """Every (protocol, port) that instance ``i`` binds, itself or through its clients in the tests."""
    return {
        ("tcp", port_scheme.sim_tcp_port(i)),
        ("udp", port_scheme.gcs_local_port(i)),
        ("udp", port_scheme.api_local_port(i)),
        ("udp", port_scheme.api_port(i)),
        ("udp", port_scheme.sim_component_port(i)),
        ("udp", port_scheme.own_gcs_port(i)),
    }


def collisions(numbers: list[int]) -> list[tuple[int, int, set[tuple[str, int]]]]:
    """Pairs of (distinct positions in) ``numbers`` that share a port, with the ports shared."""
    return [(a, b, ports(a) & ports(b)) for a, b in combinations(numbers, 2) if ports(a) & ports(b)]


def ports_free(i: int) -> bool:
    """True if nothing on this machine binds a port of instance ``i`` (a user's stack, another test run)."""
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
