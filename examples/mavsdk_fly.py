"""Fly the simulated vehicle with MAVSDK 4 (``pip install mavsdk``): arm, take off to 4 m, land.

Start the vehicle first (``flight-demo --wait``, or ``sitl --speed 1 &  autopilot``), then::

    python examples/mavsdk_fly.py                       # the API link of instance 0: UDP 14540
    python examples/mavsdk_fly.py udpin://0.0.0.0:14541 # instance 1

Prints what it sees; exits 0 once the vehicle has landed and disarmed.  MAVSDK before 4 (the gRPC
``mavsdk-grpc`` package) spells it ``System()`` / ``drone.connect(system_address=...)`` instead.
"""

from __future__ import annotations

import asyncio
import sys

from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
from mavsdk.asyncio.plugins.action import ActionAsync
from mavsdk.asyncio.plugins.telemetry import TelemetryAsync

TAKEOFF_ALT_M = 4.0


async def wait_for(what: str, check, timeout_s: float = 120.0) -> None:
    """Poll ``check()`` (async, -> bool) every 0.2 s until it is true, or fail after ``timeout_s``."""
    for _ in range(int(timeout_s / 0.2)):
        if await check():
            return
        await asyncio.sleep(0.2)
    raise TimeoutError(f"timed out waiting for {what}")


async def fly(url: str) -> None:
    config = Configuration.create_with_component_type(ComponentType.GROUND_STATION)
    async with Mavsdk(config) as sdk:
        await sdk.add_any_connection(url)
        system = await sdk.first_autopilot(timeout_s=30.0)
        if system is None:
            raise SystemExit(f"no autopilot heard on {url}")
        print(f"connected: autopilot {(await system.autopilot_type()).name}", flush=True)  # PX4
        action, telemetry = ActionAsync(system), TelemetryAsync(system)

        async def ready() -> bool:
            health = await telemetry.health()
            return health.is_global_position_ok and health.is_home_position_ok and health.is_armable

        await wait_for("a position estimate, a home position and arming checks passed", ready)
        print("ready to arm", flush=True)
        await action.set_takeoff_altitude(TAKEOFF_ALT_M)
        await action.arm()
        await action.takeoff()

        async def up() -> bool:
            return (await telemetry.position()).relative_altitude_m > TAKEOFF_ALT_M - 0.4

        await wait_for(f"{TAKEOFF_ALT_M:g} m", up)
        print(f"at {(await telemetry.position()).relative_altitude_m:.2f} m above home; landing", flush=True)
        await action.land()

        async def disarmed() -> bool:
            return not await telemetry.armed()

        await wait_for("the landing and the disarm", disarmed)
        print(f"landed and disarmed at {(await telemetry.position()).relative_altitude_m:.2f} m", flush=True)


if __name__ == "__main__":
    asyncio.run(fly(sys.argv[1] if len(sys.argv) > 1 else "udpin://0.0.0.0:14540"))
