"""Three instances side by side on one ground-station port, as PX4 SITL's multi-vehicle scheme.

Each instance N sends its ground-station link to the same UDP port (PX4: 14550; here the first
instance's own port, so no test binds a port a person's QGroundControl may hold) with system id
1+N.  One MAVSDK 4 listening there sees the three system ids and flies each to its own height;
the simulators' truth shows every vehicle at the height its own system was told, so no command
reached the wrong vehicle.  Then ``gcs -i N land`` on the same shared port lands each one.
"""

from __future__ import annotations

import asyncio
import subprocess
import sys
from contextlib import ExitStack
from pathlib import Path

import pytest

mavsdk = pytest.importorskip("mavsdk", reason="MAVSDK is in the test extras: pip install '.[test]'")
from mavsdk.asyncio import ComponentType, Configuration, Mavsdk  # noqa: E402
from mavsdk.asyncio.plugins.action import ActionAsync  # noqa: E402
from mavsdk.asyncio.plugins.telemetry import TelemetryAsync  # noqa: E402

from gcs.launcher import Stack
from gcs.sim_client import SimClient
from mavsim_core import ports

from e2e_flight_helpers import until, wait_armable  # tests/e2e_flight_helpers.py
from instances import instance  # tests/instances.py: every test's instance numbers

pytestmark = pytest.mark.e2e
INSTANCES = [instance("test_e2e_multi_vehicle", f"vehicle{k}") for k in range(3)]
SHARED_GCS_PORT = ports.own_gcs_port(INSTANCES[0])  # every instance's ground-station link goes here
ALTITUDES_M = {n: 3.0 + k for k, n in enumerate(INSTANCES)}  # a different height per vehicle
ROOT = Path(__file__).resolve().parents[1]


@pytest.fixture(scope="module")
def fleet():
    """The three stacks and their truth listeners: {instance: (stack, truth)}."""
    with ExitStack() as es:
        out = {}
        for n in INSTANCES:
            truth = es.enter_context(SimClient(ports.sim_component_port(n)))
            stack = es.enter_context(Stack(instance=n, speed="max", gcs_port=SHARED_GCS_PORT, flight_logs=False))
            out[n] = (stack, truth)
        yield out


async def _fly_all() -> list[int]:
    """One MAVSDK on the shared port: wait for the three autopilots, take each off to its height."""
    async with Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION)) as sdk:
        await sdk.add_any_connection(f"udpin://0.0.0.0:{SHARED_GCS_PORT}")
        wanted = {ports.system_id(n) for n in INSTANCES}

        async def autopilots():
            return {await s.get_system_id(): s for s in await sdk.get_systems() if await s.has_autopilot()}

        async def all_seen():
            return wanted <= set(await autopilots())

        await until(all_seen, 90, f"MAVSDK sees system ids {sorted(wanted)}")
        systems = await autopilots()
        for n in INSTANCES:
            system = systems[ports.system_id(n)]
            tel, action = TelemetryAsync(system), ActionAsync(system)

            await wait_armable(tel, 90, f"system {ports.system_id(n)} ready to arm")
            await action.set_takeoff_altitude(ALTITUDES_M[n])
            await action.arm()
            await action.takeoff()
        for n in INSTANCES:
            tel = TelemetryAsync(systems[ports.system_id(n)])

            async def up(tel=tel, alt=ALTITUDES_M[n]):
                return (await tel.position()).relative_altitude_m > alt - 0.3

            await until(up, 90, f"system {ports.system_id(n)} at {ALTITUDES_M[n]} m")
        return sorted(systems)


def test_one_mavsdk_on_the_shared_port_flies_three_vehicles_and_gcs_lands_each(fleet):
    seen = asyncio.run(_fly_all())
    assert seen == [ports.system_id(n) for n in INSTANCES] == [n + 1 for n in INSTANCES]
    for n, (_, truth) in fleet.items():
        height = -truth.latest().pos_ned_m[2]
        assert abs(height - ALTITUDES_M[n]) < 0.5, (n, height)  # each at its own system's height
    # gcs on the same shared port, one vehicle at a time by its instance (system id 1+N)
    for k, n in enumerate(INSTANCES):
        proc = subprocess.run(
            [sys.executable, "-m", "gcs", "--url", f"udpin:0.0.0.0:{SHARED_GCS_PORT}", "-i", str(n), "land"],
            cwd=ROOT,
            capture_output=True,
            text=True,
            timeout=300,
        )
        assert proc.returncode == 0, proc.stdout + proc.stderr
        assert -fleet[n][1].latest().pos_ned_m[2] < 0.3  # this one is down
        for other in INSTANCES[k + 1 :]:  # the others still in the air
            assert -fleet[other][1].latest().pos_ned_m[2] > ALTITUDES_M[other] - 0.5, other
