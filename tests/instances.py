"""The instance numbers of every test that binds ports: one table, checked collision-free.

Instance I (PX4's ``-i``) uses the ports of :mod:`mavsim_core.ports`: TCP 4560+I (simulator link),
UDP 18570+I and 14640+I (the flight controller's sockets), and, bound by its clients, UDP 14540+I
(API), 14740+I (the simulator's component) and 14840+I (the stack's own ground-station port: tests
never bind the shared 14550, where a person's QGroundControl may listen).  No two instances 0-99
share a port, so any distinct numbers will do; the suite runs files in parallel (pytest-xdist,
``--dist loadfile``) and a file's tests share a worker, so a file may reuse its own numbers in turn
but never another file's.  The table keeps clear of people's instances (0-9: ``flight-demo``,
``gcs``), of 10 (its API port is the shared 14550) and of the benchmarks' defaults (benchmarks/*.py).
``tests/test_instances.py`` checks all of it.
"""

from __future__ import annotations

import fcntl
import os
import socket
from dataclasses import dataclass
from itertools import combinations
from pathlib import Path

from mavsim_core import ports as port_scheme

PEOPLE = tuple(range(10))  # what someone runs by hand while the suite runs
# landing_benchmark 11-19 (one per job), flight_benchmark 20, vehicle_benchmark 21+ (one per vehicle),
# estimator 25, mission 26, command latency 27, log download 28, flood 29
BENCHMARKS = (*range(11, 20), 20, 21, 22, 25, 26, 27, 28, 29)

INSTANCES: dict[str, dict[str, int]] = {
    "test_e2e_estimation": {"quad_x": 30},
    "test_e2e_flight_own_stacks": {"realtime": 31, "demo": 32},
    "test_e2e_flight": {"shared": 33},
    "test_e2e_mavsdk": {"stack": 34},
    "test_e2e_vehicles": {"firefly": 35, "windy": 36},
    "test_e2e_live_tuning": {"stack": 37},
    "test_e2e_params": {"stack": 38},
    "test_flight_log_plots": {"e2e": 39},
    "test_setpoint_streams": {"link": 40},
    "test_sitl_cli": {"sitl": 41},
    "test_gcs_cli": {"nobody": 42, "demo": 43},
    "test_mavlink_commands": {"link": 44},  # "nobody": a ground-station port nothing sends to
    "test_e2e_precland": {"static": 45, "moving": 46, "loss": 47},
    "test_e2e_ugv": {"stack": 48},
    "test_e2e_missions": {"stack": 49},
    "test_e2e_mission_clients": {"stack": 50},
    # GcsLink on real UDP sockets (no stack running); a file may reuse its own numbers in turn
    "test_gcs_link_telemetry": {f"link{k}": 51 + k for k in range(6)},
    "test_gcs_link_params": {f"link{k}": 57 + k for k in range(4)},
    "test_gcs_link_commands": {f"link{k}": 61 + k for k in range(6)},
    "test_gcs_link_missions": {"link": 67},
    "test_e2e_offboard": {"stack": 68},
    "test_e2e_manual_control": {"stack": 69},
    "test_e2e_failsafes": {f"stack{k}": 70 + k for k in range(3)},
    "test_e2e_commands": {"stack": 73},
    "test_gcs_link_control": {"link": 74},
    "test_e2e_logs": {"stack": 75},
    "test_e2e_mavproxy": {"stack": 76},
    "test_e2e_identity": {"stack": 77},
    "test_e2e_failure_injection": {f"stack{k}": 78 + k for k in range(4)},
    "test_gcs_link_signing": {"link": 82},
    "test_e2e_signing": {"stack": 83},
    "test_e2e_follow_me": {f"stack{k}": 84 + k for k in range(2)},
    "test_gcs_link_files": {"link": 86},
    "test_gcs_link_telemetry_more": {"link": 87},
    "test_e2e_multi_vehicle": {f"vehicle{k}": 88 + k for k in range(3)},
    "test_e2e_link_abuse": {"stack": 94},
    "test_e2e_command_validation": {"stack": 93},
    "test_e2e_fuzz": {"stack": 96},
    "test_e2e_sim_link_loss": {"sim_restart": 91, "fc_restart": 92},
    "test_e2e_param_persistence": {"stack": 98},
    "test_e2e_gcs_lossy": {"stack": 99},
    "test_e2e_failure_detection": {"stack": 97},
}


def instance(test_file: str, role: str) -> int:
    """The instance number of ``role`` in ``test_file`` (its module name, e.g. ``"test_e2e_flight"``)."""
    return INSTANCES[test_file][role]


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


def all_instances() -> list[tuple[str, str, int]]:
    """(test file, role, instance) of every entry of the table."""
    return [(f, role, i) for f, roles in INSTANCES.items() for role, i in roles.items()]


def collisions(numbers: list[int]) -> list[tuple[int, int, set[tuple[str, int]]]]:
    """Pairs of (distinct positions in) ``numbers`` that share a port, with the ports shared."""
    return [(a, b, ports(a) & ports(b)) for a, b in combinations(numbers, 2) if ports(a) & ports(b)]


# ---------------------------------------------------------------------------------------------
# Free instances, handed out at run time (the ``free_instance`` fixture in conftest.py)

POOL = range(30, port_scheme.MAX_INSTANCE + 1)  # clear of people's 0-9, of 10 and of the benchmarks' 11-29
LOCK_DIR = Path(os.environ.get("TMPDIR", "/tmp")) / "mavsim-flight-test-instances"


@dataclass
class Lease:
    """Instance ``number``, held (an exclusive ``flock`` on its lock file) until :meth:`release` or the process ends."""

    number: int
    _fd: int

    def release(self) -> None:
        if self._fd >= 0:
            os.close(self._fd)  # closing drops the lock
            self._fd = -1


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


def lease() -> Lease:
    """A free instance of :data:`POOL`: no test of any pytest run on this machine holds it and its ports are free.

    The lock files live in :data:`LOCK_DIR`, shared by every pytest-xdist worker and every concurrent run;
    a lock dies with its process, so a killed run leaves nothing held.
    """
    LOCK_DIR.mkdir(parents=True, exist_ok=True)
    for i in POOL:
        fd = os.open(LOCK_DIR / f"instance-{i:02d}.lock", os.O_RDWR | os.O_CREAT, 0o666)
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except OSError:
            os.close(fd)
            continue
        if ports_free(i):
            return Lease(i, fd)
        os.close(fd)
    raise RuntimeError(
        f"no free test instance in {POOL.start}-{POOL.stop - 1}: every one is held or its ports are taken"
    )
