"""Two instances side by side on one ground-station port, as PX4 SITL's multi-vehicle scheme.

Each instance N sends its ground-station link to the same UDP port (PX4: 14550; here the first
instance's own port, so no test binds a port a person's QGroundControl may hold) with system id
1+N.  One MAVSDK 4 listening there sees both system ids and flies each to its own height;
the simulators' truth shows every vehicle at the height its own system was told, so no command
reached the wrong vehicle.  Then ``gcs -i N land`` on the same shared port lands each one.
"""

from __future__ import annotations

import asyncio
import subprocess
import sys
import time
from contextlib import ExitStack
from pathlib import Path

import pytest

mavsdk = pytest.importorskip("mavsdk", reason="MAVSDK is in the test extras: pip install '.[test]'")
from mavsdk.asyncio.plugins.action import ActionAsync  # noqa: E402
from mavsdk.asyncio.plugins.telemetry import TelemetryAsync  # noqa: E402
from mavsdk_session import ground_station  # noqa: E402

from gcs.launcher import Stack
from gcs.sim_client import SimClient
from mavsim_core import ports

from e2e_flight_helpers import CLIENT_SPEED, until, wait_armable  # tests/e2e_flight_helpers.py

pytestmark = pytest.mark.e2e
ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def fleet(free_instance):
    """Two stacks on free instances and their truth listeners: {instance: (stack, truth)}, in start order.
    Every instance's ground-station link goes to the first one's own port."""
    numbers = sorted(free_instance() for _ in range(2))  # in order: the system ids MAVSDK lists are sorted
    shared_gcs_port = ports.own_gcs_port(numbers[0])
    with ExitStack() as es:
        out = {}
        for n in numbers:
            truth = es.enter_context(SimClient(ports.sim_component_port(n)))
            stack = es.enter_context(Stack(instance=n, speed=CLIENT_SPEED, gcs_port=shared_gcs_port, flight_logs=False))
            out[n] = (stack, truth)
        yield out


def altitudes_m(fleet) -> dict[int, float]:
    """A different height per vehicle: {instance: metres}."""
    return {n: 3.0 + k for k, n in enumerate(fleet)}


def shared_gcs_port(fleet) -> int:
    """The one ground-station port every instance of the fleet sends to."""
    return next(iter(fleet.values()))[0].gcs_port


async def _fly_all(fleet) -> list[int]:
    """One MAVSDK on the shared port: wait for both autopilots, take each off to its height."""
    numbers, heights = list(fleet), altitudes_m(fleet)
    async with ground_station() as sdk:  # tests/mavsdk_session.py: plugins released first
        await sdk.add_any_connection(f"udpin://0.0.0.0:{shared_gcs_port(fleet)}")
        wanted = {ports.system_id(n) for n in numbers}

        async def autopilots():
            return {await s.get_system_id(): s for s in await sdk.get_systems() if await s.has_autopilot()}

        async def all_seen():
            return wanted <= set(await autopilots())

        await until(all_seen, 90, f"MAVSDK sees system ids {sorted(wanted)}")
        systems = await autopilots()
        for n in numbers:
            system = systems[ports.system_id(n)]
            tel, action = TelemetryAsync(system), ActionAsync(system)

            await wait_armable(tel, 90, f"system {ports.system_id(n)} ready to arm")
            await action.set_takeoff_altitude(heights[n])
            await action.arm()
            await action.takeoff()
        for n in numbers:
            tel = TelemetryAsync(systems[ports.system_id(n)])

            async def up(tel=tel, alt=heights[n]):
                return (await tel.position()).relative_altitude_m > alt - 0.3

            await until(up, 90, f"system {ports.system_id(n)} at {heights[n]} m")
        return sorted(systems)


def test_one_mavsdk_on_the_shared_port_flies_two_vehicles_and_gcs_lands_each(fleet):
    numbers, heights = list(fleet), altitudes_m(fleet)
    seen = asyncio.run(_fly_all(fleet))
    assert seen == [ports.system_id(n) for n in numbers] == [n + 1 for n in numbers]
    for n, (_, truth) in fleet.items():
        height = -truth.now().pos_ned_m[2]
        assert abs(height - heights[n]) < 0.5, (n, height)  # each at its own system's height
    # gcs on the same shared port, one vehicle at a time by its instance (system id 1+N)
    for k, n in enumerate(numbers):
        proc = subprocess.run(
            [sys.executable, "-m", "gcs", "--url", f"udpin:0.0.0.0:{shared_gcs_port(fleet)}", "-i", str(n), "land"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert proc.returncode == 0, proc.stdout + proc.stderr
        # This one is down.  ``gcs land`` returns on the vehicle's own word (landed, disarmed); the truth of the
        # same moment may still be on its way (its UDP stream lagged 1 simulated second behind, 0.88 m up, beside a
        # second suite), so the truth is waited for, in wall time only as a safety net.
        truth = fleet[n][1]
        deadline = time.monotonic() + 60
        while -truth.latest().pos_ned_m[2] >= 0.3 and time.monotonic() < deadline:
            time.sleep(0.05)
        assert -truth.latest().pos_ned_m[2] < 0.3, n
        for other in numbers[k + 1 :]:  # the others still in the air
            assert -fleet[other][1].latest().pos_ned_m[2] > heights[other] - 0.5, other
