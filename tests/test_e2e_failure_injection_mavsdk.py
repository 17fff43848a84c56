"""End-to-end: MAVSDK's Failure plugin injects a GPS loss into the real stack, as its upstream example does.

MAVSDK (it reads SYS_FAILURE_EN and refuses by itself while it is 0) is a client in wall time, on a
quadcopter running free: what is asserted does not depend on when its commands arrive (the results, the
texts, the GPS unhealthy until MAVSDK restores it).  The same flight's figures (no fly-away, where it
lands) are flown in simulated time by tests/test_e2e_failure_injection.py (the GPS off in LOITER).
"""

from __future__ import annotations

import asyncio

import pytest

from gcs.launcher import Stack
from gcs.sim_client import SimClient

from e2e_flight_helpers import sim_sleep, truth_and_stack_fixtures, until, wait_armable  # tests/e2e_flight_helpers.py

pytestmark = pytest.mark.e2e
WAIT_S = 120.0
ALT_M = 5.0

truth, stack = truth_and_stack_fixtures()


async def _mavsdk_gps_loss(stack: Stack, truth: SimClient) -> dict:
    from mavsdk.asyncio.plugins.action import ActionAsync
    from mavsdk.asyncio.plugins.failure import FailureAsync, FailureError, FailureResult, FailureType, FailureUnit
    from mavsdk.asyncio.plugins.param import ParamAsync
    from mavsdk.asyncio.plugins.telemetry import TelemetryAsync
    from mavsdk.plugins.telemetry import FlightMode
    from mavsdk_session import ground_station

    out: dict = {}
    async with ground_station() as sdk:  # tests/mavsdk_session.py: plugins released first
        await sdk.add_any_connection(f"udpin://0.0.0.0:{stack.api_port}")
        system = await sdk.first_autopilot(timeout_s=30.0)
        assert system is not None, "MAVSDK found no autopilot"
        tel, action, param = TelemetryAsync(system), ActionAsync(system), ParamAsync(system)
        texts: list[str] = []

        async def collect():
            async for st in tel.subscribe_status_text():
                texts.append(st.text)

        listener = asyncio.ensure_future(collect())
        # SYS_FAILURE_EN = 0: MAVSDK refuses by itself (DISABLED) once it has read the parameter, else the
        # vehicle does (DENIED)
        with pytest.raises(FailureError) as refused:
            await FailureAsync(system).inject(FailureUnit.SENSOR_GPS, FailureType.OFF, 0)
        out["disabled"] = refused.value.result
        await param.set_param_int("SYS_FAILURE_EN", 1)
        failure = FailureAsync(system)  # a plugin made now reads SYS_FAILURE_EN = 1 (the first keeps its 0)

        await wait_armable(tel, WAIT_S)
        await action.set_takeoff_altitude(ALT_M)
        await action.arm()
        await action.takeoff()

        async def holding():
            return (
                await tel.flight_mode() == FlightMode.HOLD and (await tel.position()).relative_altitude_m > ALT_M - 0.5
            )

        await until(holding, WAIT_S, "holding after the take-off")
        await sim_sleep(truth, 3.0)
        hold = truth.latest()
        out["inject"] = await failure.inject(FailureUnit.SENSOR_GPS, FailureType.OFF, 0)

        async def landing():
            return await tel.flight_mode() == FlightMode.LAND

        await until(landing, WAIT_S, "LAND after the GPS loss")
        await sim_sleep(truth, 2.5)  # descending without GPS
        out["descended"] = truth.latest().pos_ned_m[2] - hold.pos_ned_m[2]
        out["gps_ok_during"] = (await tel.health()).is_global_position_ok
        out["restore"] = await failure.inject(FailureUnit.SENSOR_GPS, FailureType.OK, 0)

        async def position_back():
            return (await tel.health()).is_global_position_ok

        await until(position_back, WAIT_S, "the position estimate back")

        async def landed_():
            return not await tel.armed()

        await until(landed_, WAIT_S, "landed and disarmed")
        out["texts"] = texts
        listener.cancel()
    out["success"] = FailureResult.SUCCESS
    out["refusals"] = (FailureResult.DISABLED, FailureResult.DENIED)
    return out


class TestMavsdk:
    """One stack running free: MAVSDK, a client in wall time, with a GPS loss."""

    def test_mavsdk_gps_loss_in_hold_lands_and_ok_restores_it(self, stack, truth):
        """COM_POSCTL_NAVL 0 and no pilot sticks: a position lost in HOLD lands on the height estimate (PX4's
        position-loss failsafe).  FAILURE_TYPE_OK brings the GPS back; the landing, a failsafe action, goes on.
        MAVSDK acts in wall time, so its commands arrive at simulated times that depend on the machine's load:
        the flight's figures (no fly-away, where it lands) are asserted in simulated time by
        TestQuadcopter.test_gps_off_in_loiter_lands_where_it_is_and_ok_restores_it.  What is asserted here does
        not depend on the load: the results, the texts, the GPS unhealthy until MAVSDK restores it, and the
        descent at least 2.5 s of simulated time after MAVSDK saw LAND (a later look only sees it lower)."""
        pytest.importorskip("mavsdk", reason="MAVSDK is in the test extras: pip install '.[test]'")
        out = asyncio.run(_mavsdk_gps_loss(stack, truth))
        texts = out["texts"]
        assert out["disabled"] in out["refusals"]
        assert out["inject"] == out["success"] and out["restore"] == out["success"]
        assert out["descended"] > 0.5, "not descending"
        assert not out["gps_ok_during"]
        assert "Failure injected: GPS off" in texts and "Failure cleared: GPS" in texts
        assert "Position estimate lost: landing" in texts and "Position estimate regained" in texts


# ------------------------------------------------------------------- the quadcopter, in simulated time
