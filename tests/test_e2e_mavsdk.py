"""MAVSDK (the 4.x native binding) flies the real stack with its Action plugin.

What a MAVSDK user does first: connect on udpin 14540, wait for health, set the
take-off altitude (a PX4 parameter), arm, take off, land.  This caught a real
bug once: MAVSDK sends NaN in COMPONENT_ARM_DISARM's unused param 2.
"""

from __future__ import annotations

import asyncio

import pytest

from gcs.launcher import Stack

mavsdk = pytest.importorskip("mavsdk", reason="MAVSDK is in the test extras: pip install '.[test]'")
from mavsdk.asyncio import ComponentType, Configuration, Mavsdk  # noqa: E402
from mavsdk.asyncio.plugins.action import ActionAsync  # noqa: E402
from mavsdk.asyncio.plugins.telemetry import TelemetryAsync  # noqa: E402
from mavsdk.autopilot import Autopilot  # noqa: E402

from mavsim_core import ports

from e2e_flight_helpers import until  # tests/e2e_flight_helpers.py
from instances import instance  # tests/instances.py: every test's instance numbers

pytestmark = pytest.mark.e2e
INSTANCE = instance("test_e2e_mavsdk", "stack")


async def _fly(port: int) -> dict:
    seen = {}
    async with Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION)) as sdk:
        await sdk.add_any_connection(f"udpin://0.0.0.0:{port}")
        system = await sdk.first_autopilot(timeout_s=30.0)
        assert system is not None, "MAVSDK found no autopilot"
        seen["autopilot"] = await system.autopilot_type()
        action, tel = ActionAsync(system), TelemetryAsync(system)

        async def healthy():
            h = await tel.health()
            return h.is_global_position_ok and h.is_home_position_ok and h.is_armable

        await until(healthy, 60, "health: global position, home, armable")
        await action.set_takeoff_altitude(4.0)
        seen["takeoff_alt"] = await action.get_takeoff_altitude()
        await action.arm()
        await action.takeoff()

        async def at_altitude():
            return (await tel.position()).relative_altitude_m > 3.6

        await until(at_altitude, 60, "relative altitude above 3.6 m")
        seen["altitude"] = (await tel.position()).relative_altitude_m
        await action.land()

        async def disarmed():
            return not await tel.armed()

        await until(disarmed, 90, "automatic disarm after landing")
        seen["final_altitude"] = (await tel.position()).relative_altitude_m
    return seen


def test_mavsdk_arms_takes_off_and_lands():
    with Stack(instance=INSTANCE, speed="max") as stack:
        seen = asyncio.run(_fly(ports.api_port(INSTANCE)))
        stack.check_alive()
    assert seen["autopilot"] == Autopilot.PX4  # MAVSDK treats it as PX4 (heartbeat identity)
    assert seen["takeoff_alt"] == pytest.approx(4.0)
    assert seen["altitude"] == pytest.approx(4.0, abs=0.5)
    assert abs(seen["final_altitude"]) < 0.5
