"""The instance numbers of every test that binds ports: one table, checked collision-free.

Instance I (PX4's ``-i``) uses these ports (gcs/launcher/stack.py, autopilot/__main__.py, sitl/__main__.py):

- TCP 4560+I: the simulator link (sitl listens, autopilot connects);
- UDP 14560+I: the simulator's own MAVLink component (truth, SIM_* parameters), bound by its client;
- UDP 14580+I and 18570+I: the flight controller's API and ground-station sockets;
- UDP 14540+I and 14550+I: where API clients (MAVSDK) and ground stations listen.

So instances I and J collide when |I - J| is 10, 20, 30 or 40 (14540+I = 14550+J, 14560+J or
14580+J, ...), or 0.  The suite runs files in parallel (pytest-xdist, ``--dist loadfile``), and
a file's tests share a worker, so a file may reuse its own numbers in turn but never another
file's.  The table also keeps clear of people's instances (0-9: ``flight-demo``, QGroundControl
on 14550) and of the benchmarks' defaults (benchmarks/*.py), so a suite run next to either
binds nothing they bind.

Numbers: units 0-9 of the decades 70, 120, 170, 220 and 270 (271-279: 270 is 40 from the mission
benchmark's 310).  Within one decade they differ by less
than 10; the decades are 50 apart, so numbers of neighbouring decades differ by 41-59 and others
by 91 or more; from people's 0-9 and the benchmarks' 20-25 they are 45 or more apart.  So no
pair differs by 10-40.  ``tests/test_instances.py`` checks all of it.  Instances above 99 are
as valid as any: ``--instance`` only offsets ports (the highest here, 18570+225, is far below
the OS's ephemeral range, where ``bind(("127.0.0.1", 0))`` ports of other tests come from).
"""

from __future__ import annotations

from itertools import combinations

PEOPLE = tuple(range(10))  # what someone runs by hand while the suite runs
# flight_benchmark 20, vehicle_benchmark 21+ (one per vehicle), estimator 25, mission 310, command latency 362
BENCHMARKS = (20, 21, 22, 25, 310, 362)

INSTANCES: dict[str, dict[str, int]] = {
    "test_e2e_estimation": {"quad_x": 70},
    "test_e2e_flight_own_stacks": {"realtime": 71, "demo": 73},
    "test_e2e_flight": {"shared": 72},
    "test_e2e_mavsdk": {"stack": 74},
    "test_e2e_vehicles": {"firefly": 75, "windy": 76},
    "test_e2e_live_tuning": {"stack": 77},
    "test_e2e_params": {"stack": 78},
    "test_flight_log_plots": {"e2e": 79},
    "test_setpoint_streams": {"link": 170},
    "test_sitl_cli": {"sitl": 171},
    "test_gcs_cli": {"nobody": 172, "demo": 173},
    "test_mavlink_commands": {"link": 174},  # "nobody": a ground-station port nothing sends to
    "test_e2e_precland": {"static": 175, "moving": 176, "loss": 177},
    "test_e2e_ugv": {"stack": 178},
    "test_e2e_missions": {"stack": 179},
    "test_e2e_mission_clients": {"stack": 226},
    # GcsLink on real UDP sockets (no stack running); a file may reuse its own numbers in turn
    "test_gcs_link_telemetry": {f"link{k}": 120 + k for k in range(6)},
    "test_gcs_link_params": {f"link{k}": 126 + k for k in range(4)},
    "test_gcs_link_commands": {f"link{k}": 220 + k for k in range(6)},
    "test_gcs_link_missions": {"link": 227},
    "test_e2e_offboard": {"stack": 228},
    "test_e2e_manual_control": {"stack": 229},
    "test_e2e_failsafes": {f"stack{k}": 271 + k for k in range(3)},
    "test_e2e_commands": {"stack": 274},
    "test_gcs_link_control": {"link": 275},
    # issue 17 (provisional numbers: the table is renumbered when the port scheme changes)
    "test_e2e_logs": {"stack": 276},
    "test_e2e_mavproxy": {"stack": 277},
    "test_e2e_identity": {"stack": 278},
    "test_e2e_failure_injection": {f"stack{k}": 320 + k for k in range(4)},
    "test_gcs_link_signing": {"link": 324},
    "test_e2e_signing": {"stack": 325},
    "test_e2e_follow_me": {f"stack{k}": 326 + k for k in range(2)},
    "test_gcs_link_files": {"link": 328},
    "test_gcs_link_telemetry_more": {"link": 329},
}


def instance(test_file: str, role: str) -> int:
    """The instance number of ``role`` in ``test_file`` (its module name, e.g. ``"test_e2e_flight"``)."""
    return INSTANCES[test_file][role]


def ports(i: int) -> set[tuple[str, int]]:
    """Every (protocol, port) that instance ``i`` binds, itself or through its clients."""
    return {
        ("tcp", 4560 + i),
        ("udp", 14540 + i),
        ("udp", 14550 + i),
        ("udp", 14560 + i),
        ("udp", 14580 + i),
        ("udp", 18570 + i),
    }


def all_instances() -> list[tuple[str, str, int]]:
    """(test file, role, instance) of every entry of the table."""
    return [(f, role, i) for f, roles in INSTANCES.items() for role, i in roles.items()]


def collisions(numbers: list[int]) -> list[tuple[int, int, set[tuple[str, int]]]]:
    """Pairs of (distinct positions in) ``numbers`` that share a port, with the ports shared."""
    return [(a, b, ports(a) & ports(b)) for a, b in combinations(numbers, 2) if ports(a) & ports(b)]
