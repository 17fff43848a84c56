"""A pilot's sticks fly the real stack: MAVSDK's ManualControl plugin in POSCTL and ALTCTL, and ``gcs fly``.

What a MAVSDK user with a joystick does: send MANUAL_CONTROL continuously (``set_manual_control_input``,
here at about 25 Hz: stopping is a manual-control loss), switch to position or altitude control and
steer.  In POSCTL full forward stick flies at MPC_VEL_MANUAL and centred sticks hold the position; in
ALTCTL forward stick tilts the vehicle and accelerates it forward and centred sticks hold the altitude;
``gcs fly`` with a key script holding ``w`` moves the vehicle forward.  Where the vehicle went is the
simulator's ground truth; durations are simulated seconds (truth time), wall clock only as a safety net.

The sticks stream at 25 Hz of wall time while the vehicle flies at up to ~20x real time: one message per
~0.8 simulated seconds on a quiet machine, many more on a loaded one.  The flight controller holds the latest
sticks (their loss is judged on both clocks, ``autopilot.topics.input_age_s``), so a sparse stream flies the
same; what the stream's density changes is WHEN (in simulated time) a stick move reaches the vehicle, and
when this test notices a mode change.  So a move is sent at once (:meth:`Sticks.move`), and what is measured
starts at a moment found in the truth (the response's onset), never at a wall-clock moment.
"""

from __future__ import annotations

import asyncio
import math
import subprocess
import sys

import pytest

mavsdk = pytest.importorskip("mavsdk", reason="MAVSDK is in the test extras: pip install '.[test]'")
from mavsdk.asyncio import ComponentType, Configuration, Mavsdk  # noqa: E402
from mavsdk.asyncio.plugins.action import ActionAsync  # noqa: E402
from mavsdk.asyncio.plugins.manual_control import ManualControlAsync  # noqa: E402
from mavsdk.asyncio.plugins.telemetry import TelemetryAsync  # noqa: E402
from mavsdk.plugins.telemetry import FlightMode  # noqa: E402

from e2e_flight_helpers import (
    sim_ms,
    sim_sleep,
    truth_and_stack_fixtures,
    truth_yaw,
    until,
)  # tests/e2e_flight_helpers.py

pytestmark = pytest.mark.e2e
# The sticks come from this test's process at 25 Hz of wall time; on a loaded 2-core machine it can be
# starved for longer than PX4's 0.5 s, a (correct) RC-loss failsafe that is not what these tests fly:
# RC loss has its own tests (test_e2e_failsafes.py).
truth, stack = truth_and_stack_fixtures(params={"COM_RC_LOSS_T": 3.0})
STICK_PERIOD_S = 0.04  # MAVSDK sticks at 25 Hz (wall clock)
MPC_VEL_MANUAL = 1.0  # the default full-stick speed, m/s
WAIT_S = 120.0  # wall-clock safety net of each wait


class Sticks:
    """Send ``value`` (x pitch, y roll, z throttle 0..1, r yaw) through MAVSDK continuously."""

    def __init__(self, system) -> None:
        self.mc = ManualControlAsync(system)
        self.value = (0.0, 0.0, 0.5, 0.0)
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


async def _session(stack, body):
    async with Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION)) as sdk:
        await sdk.add_any_connection(f"udpin://0.0.0.0:{stack.api_port}")
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
            await action.land()  # where it is: the next test takes off from there

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


def test_posctl_throttle_takes_off_full_stick_flies_mpc_vel_manual_centred_holds(stack, truth):
    async def body(system, tel, action, sticks):
        out = {}
        await sticks.mc.start_position_control()  # disarmed: accepted, acts once armed
        await _mode(tel, FlightMode.POSCTL)
        await sticks.move((0.0, 0.0, 0.8, 0.0))  # throttle up: climb from the ground
        await action.arm()
        await _altitude_above(tel, 4.0)
        await sticks.move((0.0, 0.0, 0.5, 0.0))
        await sim_sleep(truth, 3.0)
        await sticks.move((1.0, 0.0, 0.5, 0.0))  # full forward
        t_settled = await sim_sleep(truth, 5.0)
        t_end = await sim_sleep(truth, 5.0)
        out["speeds"] = [math.hypot(*s.vel_ned_m_s[:2]) for s in truth.since(t_settled) if s.time_ms <= t_end]
        await sticks.move((0.0, 0.0, 0.5, 0.0))  # centred: brake and hold
        t_hold = await sim_sleep(truth, 3.0)
        await sim_sleep(truth, 10.0)
        out["hold"] = [s.pos_ned_m for s in truth.since(t_hold)]
        return out

    out = asyncio.run(_session(stack, body))
    stack.check_alive()
    speeds = out["speeds"]
    mean = sum(speeds) / len(speeds)
    print(f"POSCTL full stick: mean {mean:.3f} m/s, min {min(speeds):.3f}, max {max(speeds):.3f}")
    assert mean == pytest.approx(MPC_VEL_MANUAL, rel=0.15)
    assert min(speeds) > 0.8 * MPC_VEL_MANUAL and max(speeds) < 1.2 * MPC_VEL_MANUAL
    hold = out["hold"]
    first = hold[0]
    drift = max(math.dist(p[:2], first[:2]) for p in hold)
    climb = max(abs(p[2] - first[2]) for p in hold)
    print(f"POSCTL centred 10 s: drift {drift:.3f} m, altitude change {climb:.3f} m")
    assert drift <= 0.3 and climb <= 0.3


def _at(truth, t_ms: int):
    """The first truth sample at or after ``t_ms`` (the caller has waited past it)."""
    return truth.since(t_ms)[0]


def _fwd_side(vel_ned_m_s, yaw: float) -> tuple[float, float]:
    """A horizontal NED vector in the heading frame: (forward, right)."""
    n, e = vel_ned_m_s[0], vel_ned_m_s[1]
    return n * math.cos(yaw) + e * math.sin(yaw), -n * math.sin(yaw) + e * math.cos(yaw)


ONSET_M_S = 0.3  # a stick move has reached the vehicle once the speed it asks for has changed this much


def test_altctl_forward_stick_tilts_and_accelerates_centred_holds_altitude(stack, truth):
    """ALTCTL does not hold the horizontal velocity (as in PX4): with centred sticks the vehicle levels on its
    attitude estimate and drifts with what that estimate gets wrong (the accelerometer's bias: about
    0.1 m/s^2 here), so the speed a fixed time after the switch depends on how long that time truly was.
    Measured instead: the horizontal acceleration with centred sticks (small) and with the forward stick (the
    commanded tilt), each over a window of simulated time that begins at a moment found in the truth."""

    async def body(system, tel, action, sticks):
        out = {}
        await action.set_takeoff_altitude(5.0)
        await action.arm()
        await action.takeoff()
        await _altitude_above(tel, 4.6)
        await _mode(tel, FlightMode.HOLD)
        await sticks.mc.start_altitude_control()
        await _mode(tel, FlightMode.ALTCTL)
        out["t_alt"] = t_alt = sim_ms(truth)  # in ALTCTL since this moment at least (noticed by polling)
        out["t_fwd"] = await sim_sleep(truth, 2.0)  # centred sticks
        out["yaw"] = yaw = truth_yaw(truth)
        v0 = _fwd_side(_at(truth, out["t_fwd"]).vel_ned_m_s, yaw)[0]
        await sticks.move((0.4, 0.0, 0.5, 0.0))  # forward: (0.4 - 0.1) / 0.9 of MPC_MAN_TILT_MAX

        async def moving():
            return _fwd_side(truth.latest().vel_ned_m_s, yaw)[0] > v0 + ONSET_M_S

        await until(moving, WAIT_S, "the forward stick's acceleration", period_s=0.005)
        out["t_on"] = truth.latest().time_ms
        await sim_sleep(truth, 1.0)
        await sticks.move((-0.4, 0.0, 0.5, 0.0))  # back: until about stopped

        async def stopped():
            return _fwd_side(truth.latest().vel_ned_m_s, yaw)[0] < ONSET_M_S

        await until(stopped, WAIT_S, "stopped by the back stick", period_s=0.005)
        await sticks.move((0.0, 0.0, 0.5, 0.0))
        t_hold = await sim_sleep(truth, 2.0)
        await sim_sleep(truth, 10.0)
        out["alt_all"] = [-s.pos_ned_m[2] for s in truth.since(t_alt)]
        out["alt_hold"] = [-s.pos_ned_m[2] for s in truth.since(t_hold)]
        out["samples"] = truth.since(t_alt)
        return out

    out = asyncio.run(_session(stack, body))
    stack.check_alive()

    def acc(t_a: int, t_b: int) -> tuple[float, float]:
        """Mean (forward, right) acceleration between two truth times, m/s^2."""
        a, b = (next(s for s in out["samples"] if s.time_ms >= t) for t in (t_a, t_b))
        dt = (b.time_ms - a.time_ms) / 1000.0
        fwd_a, right_a = _fwd_side(a.vel_ned_m_s, out["yaw"])
        fwd_b, right_b = _fwd_side(b.vel_ned_m_s, out["yaw"])
        return (fwd_b - fwd_a) / dt, (right_b - right_a) / dt

    drift = math.hypot(*acc(out["t_alt"], out["t_fwd"]))
    a_fwd, a_side = acc(out["t_on"], out["t_on"] + 1000)
    print(f"ALTCTL centred sticks: {drift:.3f} m/s^2 over {(out['t_fwd'] - out['t_alt']) / 1000:.1f} s; "
          f"forward stick: forward {a_fwd:.2f} m/s^2, sideways {a_side:.2f} m/s^2")  # fmt: skip
    assert drift < 0.3  # levelled: a tenth of the 2 m/s^2 the forward stick asks for
    # tilt g tan(11.7 deg) = 2.0 m/s^2, less the drag: accelerated forward, not sideways
    assert 1.2 < a_fwd < 2.4 and abs(a_side) < 0.3 * a_fwd
    hold = out["alt_hold"]
    print(f"ALTCTL altitude: held within {max(hold) - min(hold):.3f} m, whole flight within "
          f"{max(out['alt_all']) - min(out['alt_all']):.3f} m")  # fmt: skip
    assert max(hold) - min(hold) <= 0.3
    assert max(out["alt_all"]) - min(out["alt_all"]) <= 0.6


KEY_SCRIPT = """\
# gcs fly key script: wait, position mode, forward, stop
0.5 -
m
1 -
3 w
1 space
"""


def test_gcs_fly_key_script_moves_the_vehicle_forward(stack, truth, tmp_path):
    keys = tmp_path / "forward.keys"
    keys.write_text(KEY_SCRIPT)
    cmd = [
        sys.executable,
        "-m",
        "gcs",
        "--url",
        f"udpin:0.0.0.0:{stack.gcs_port}",
        "fly",
        "--keys",
        str(keys),
    ]

    async def body(system, tel, action, sticks):
        from mavsdk.asyncio.plugins.param import ParamAsync

        # The sticks change hands (MAVSDK's stop, gcs fly's start a process later): no manual-control loss
        # action meanwhile (NAV_RCL_ACT 0), else the default (return) takes the vehicle home during take-off.
        await ParamAsync(system).set_param_int("NAV_RCL_ACT", 0)
        await sticks.stop()  # gcs fly sends the sticks now
        await action.set_takeoff_altitude(4.0)
        await action.arm()
        await action.takeoff()
        await _altitude_above(tel, 3.6)
        await _mode(tel, FlightMode.HOLD)
        out = {"yaw": truth_yaw(truth), "t0": sim_ms(truth)}
        out["run"] = await asyncio.to_thread(
            subprocess.run, cmd, capture_output=True, text=True, timeout=WAIT_S, stdin=subprocess.DEVNULL
        )
        out["samples"] = truth.since(out["t0"])
        out["mode"] = await tel.flight_mode()
        await sticks.start()  # sticks again while landing (no manual-control loss)
        await ParamAsync(system).set_param_int("NAV_RCL_ACT", 2)
        return out

    out = asyncio.run(_session(stack, body))
    stack.check_alive()
    run = out["run"]
    assert run.returncode == 0, run.stdout + run.stderr
    assert "POSCTL" in run.stdout
    samples, yaw = out["samples"], out["yaw"]
    start = samples[0].pos_ned_m
    ahead = max((s.pos_ned_m[0] - start[0]) * math.cos(yaw) + (s.pos_ned_m[1] - start[1]) * math.sin(yaw)
                for s in samples)  # fmt: skip
    top = max(math.hypot(*s.vel_ned_m_s[:2]) for s in samples)
    print(f"gcs fly: {ahead:.2f} m forward, top speed {top:.2f} m/s")
    assert ahead > 1.0
    assert top < 1.2 * MPC_VEL_MANUAL
