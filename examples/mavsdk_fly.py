"""Fly with MAVSDK 4 (the pinned mavsdk 4.1): arm, take off to 4 m, land. Argument: the link."""

import asyncio
import sys

from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
from mavsdk.asyncio.plugins.action import ActionAsync
from mavsdk.asyncio.plugins.telemetry import TelemetryAsync


async def fly(url: str) -> None:
    async with Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION)) as sdk:
        await sdk.add_any_connection(url)
        if (system := await sdk.first_autopilot(timeout_s=30.0)) is None:
            sys.exit(f"no autopilot heard on {url}")
        print(f"connected: autopilot {(await system.autopilot_type()).name}", flush=True)  # PX4
        action, telemetry = ActionAsync(system), TelemetryAsync(system)
        while not (health := await telemetry.health()).is_armable or not health.is_home_position_ok:
            await asyncio.sleep(0.2)  # until the pre-arm checks pass and home is set
        await action.set_takeoff_altitude(4.0)  # PX4's MIS_TAKEOFF_ALT
        await action.arm()
        await action.takeoff()
        while (await telemetry.position()).relative_altitude_m < 3.6:
            await asyncio.sleep(0.2)
        print(f"at {(await telemetry.position()).relative_altitude_m:.2f} m above home; landing", flush=True)
        await action.land()
        while await telemetry.armed():  # the vehicle disarms itself once landed
            await asyncio.sleep(0.2)
        print("landed and disarmed", flush=True)


asyncio.run(fly(sys.argv[1] if len(sys.argv) > 1 else "udpin://0.0.0.0:14540"))  # instance 0's API link
