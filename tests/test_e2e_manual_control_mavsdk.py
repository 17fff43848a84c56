"""MAVSDK's ManualControl plugin flies the real stack: POSCTL and ALTCTL from sticks streamed in wall time.

``start_position_control``, ``start_altitude_control`` and ``set_manual_control_input`` at 25 Hz of wall
time, as a MAVSDK joystick application sends them, on a stack at full speed: the sticks reach the vehicle when
the wall clock says, so only what a held stick brings about at last is asserted (the figures of the same
flights, flown in simulated time, are tests/test_e2e_manual_control.py's).
"""

from __future__ import annotations

import asyncio
import math

import pytest

mavsdk = pytest.importorskip("mavsdk", reason="MAVSDK is in the test extras: pip install '.[test]'")
from mavsdk.asyncio.plugins.action import ActionAsync  # noqa: E402
from mavsdk.asyncio.plugins.manual_control import ManualControlAsync  # noqa: E402
from mavsdk.asyncio.plugins.telemetry import TelemetryAsync  # noqa: E402
from mavsdk.plugins.telemetry import FlightMode  # noqa: E402
from mavsdk_session import ground_station  # noqa: E402

from e2e_flight_helpers import sim_sleep, truth_and_stack_fixtures, until  # noqa: E402  # tests/e2e_flight_helpers.py
from test_e2e_manual_control import CENTRED, MPC_VEL_MANUAL, ONSET_M_S, _fwd_side  # noqa: E402

pytestmark = pytest.mark.e2e
# The sticks come from another process; on a loaded 2-core machine it can be starved for longer than PX4's
# 0.5 s, a (correct) RC-loss failsafe that is not what this test flies (RC loss: test_e2e_failsafes.py).
truth, stack = truth_and_stack_fixtures(params={"COM_RC_LOSS_T": 3.0})
WAIT_S = 120.0  # wall-clock safety net of each wait


STICK_PERIOD_S = 0.04  # MAVSDK sticks at 25 Hz (wall clock)


class Sticks:
    """Send ``value`` (x pitch, y roll, z throttle 0..1, r yaw) through MAVSDK continuously."""

    def __init__(self, system) -> None:
        self.mc = ManualControlAsync(system)
        self.value = CENTRED
        self._task: asyncio.Task | None = None

    async def _run(self) -> None:
        while True:
            await self.mc.set_manual_control_input(*self.value)
            await asyncio.sleep(STICK_PERIOD_S)

    async def start(self) -> None:
        await self.mc.set_manual_control_input(*self.value)  # MAVSDK switches modes only once it has input
        self._task = asyncio.ensure_future(self._run())

    async def move(self, value: tuple[float, float, float, float]) -> None:
        """Move the sticks to ``value``: sent now (not at the stream's next wall-clock tick), then streamed."""
        self.value = value
        await self.mc.set_manual_control_input(*value)

    async def stop(self) -> None:
        if self._task is not None:
            self._task.cancel()
            try:
                await self._task
            except asyncio.CancelledError:
                pass


async def _session(port: int, body):
    async with ground_station() as sdk:  # tests/mavsdk_session.py: plugins released first
        await sdk.add_any_connection(f"udpin://0.0.0.0:{port}")
        system = await sdk.first_autopilot(timeout_s=30.0)
        assert system is not None, "MAVSDK found no autopilot"
        tel, action = TelemetryAsync(system), ActionAsync(system)

        async def ready():
            h = await tel.health()
            return h.is_global_position_ok and h.is_home_position_ok and h.is_armable and not await tel.armed()

        await until(ready, WAIT_S, "health: position, home, armable, disarmed")
        sticks = Sticks(system)
        await sticks.start()
        try:
            result = await body(system, tel, action, sticks)
            await action.land()

            async def disarmed():
                return not await tel.armed()

            await until(disarmed, WAIT_S, "disarmed after the landing")  # sticks keep coming: no RC loss
            return result
        finally:
            await sticks.stop()


async def _mode(tel, mode) -> None:
    async def in_mode():
        return await tel.flight_mode() == mode

    await until(in_mode, WAIT_S, f"flight mode {mode}")


async def _altitude_above(tel, alt_m: float) -> None:
    async def high():
        return (await tel.position()).relative_altitude_m > alt_m

    await until(high, WAIT_S, f"relative altitude above {alt_m:g} m")


def test_mavsdk_manual_control_flies_posctl_and_altctl(stack, truth):
    """MAVSDK's ManualControl plugin (``start_position_control``, ``start_altitude_control``,
    ``set_manual_control_input`` streamed at 25 Hz of wall time) flies the stack.  The sticks reach the vehicle
    when the wall clock says (one message per ~0.8 simulated seconds on a quiet machine, many more on a loaded
    one), so only what a held stick brings about at last is asserted, each within a wall-clock safety net:
    POSCTL with the throttle up takes off; full forward reaches 0.8 MPC_VEL_MANUAL forward; centred sticks
    stop it; ALTCTL's forward stick accelerates it forward and the back stick stops it.  The figures of the
    same flights are the stepped tests' above."""

    def fwd_speed(yaw: float) -> float:
        return _fwd_side(truth.latest().vel_ned_m_s, yaw)[0]

    async def speed_until(predicate, what: str) -> None:
        async def ok():
            return predicate()

        await until(ok, WAIT_S, what, period_s=0.005)

    async def body(system, tel, action, sticks):
        await sticks.mc.start_position_control()  # disarmed: accepted, acts once armed
        await _mode(tel, FlightMode.POSCTL)
        await sticks.move((0.0, 0.0, 0.8, 0.0))  # throttle up: climb from the ground
        await action.arm()
        await _altitude_above(tel, 4.0)
        await sticks.move(CENTRED)
        await sim_sleep(truth, 2.0)
        w, x, y, z = truth.latest_state.attitude_quaternion
        yaw = math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
        await sticks.move((1.0, 0.0, 0.5, 0.0))  # full forward
        await speed_until(lambda: fwd_speed(yaw) > 0.8 * MPC_VEL_MANUAL, "POSCTL: forward at the stick's speed")
        await sticks.move(CENTRED)
        await speed_until(lambda: math.hypot(*truth.latest().vel_ned_m_s[:2]) < 0.1, "POSCTL: stopped, centred")

        await sticks.mc.start_altitude_control()
        await _mode(tel, FlightMode.ALTCTL)
        v0 = fwd_speed(yaw)
        await sticks.move((0.4, 0.0, 0.5, 0.0))  # forward
        await speed_until(lambda: fwd_speed(yaw) > v0 + ONSET_M_S, "ALTCTL: accelerated forward")
        await sticks.move((-0.4, 0.0, 0.5, 0.0))  # back
        await speed_until(lambda: fwd_speed(yaw) < ONSET_M_S, "ALTCTL: stopped by the back stick")
        await sticks.move(CENTRED)

    asyncio.run(_session(stack.api_port, body))
    stack.check_alive()  # both processes still up
