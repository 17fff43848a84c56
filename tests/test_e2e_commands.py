"""The remaining commands a MAVSDK or QGroundControl user sends, against the real stack.

With MAVSDK 4's Action plugin: ``goto_location`` with a heading (DO_REPOSITION, yaw in
radians on the wire) ends at the point facing east by the simulator's truth;
``set_current_speed`` (DO_CHANGE_SPEED) changes the speed of the move being flown (truth);
``do_orbit`` (DO_ORBIT) circles a centre at the radius (truth); ``reboot``
(PREFLIGHT_REBOOT_SHUTDOWN) comes back disarmed, healthy and armable, with the parameters
(``set_return_to_launch_altitude``) kept; ``terminate``
(DO_FLIGHTTERMINATION) stops the motors in the air and refuses arming afterwards, and MAVSDK's health
then shows the vehicle not armable (the pre-arm checks say why: issue 36).  With
pymavlink: GET_HOME_POSITION answers HOME_POSITION; DO_MOTOR_TEST on the ground spins one
motor, seen in SERVO_OUTPUT_RAW and applied by the simulator (its truth log), for its timeout.

One stack at full speed, and clients in wall time (MAVSDK, a bare pymavlink connection as
QGroundControl's): not flown in simulated time (issue 33), so where a command lands in simulated time
depends on the machine's load.  What is asserted does not: each figure is a settled state measured
simulated seconds after the command that made it (a point reached and stopped, a speed in the middle of
a 150 m leg, an orbit after 20 s), or a duration the vehicle counts on its own clock (the motor test's
timeout); each test says why.
"""

from __future__ import annotations

import asyncio
import math
import time
from pathlib import Path

import numpy as np
import pytest
from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink

mavsdk = pytest.importorskip("mavsdk", reason="MAVSDK is in the test extras: pip install '.[test]'")
from mavsdk.asyncio.plugins.action import ActionAsync  # noqa: E402
from mavsdk.asyncio.plugins.telemetry import TelemetryAsync  # noqa: E402
from mavsdk.plugins.action import ActionError, ActionResult, OrbitYawBehavior  # noqa: E402
from mavsdk_session import ground_station  # noqa: E402

from e2e_flight_helpers import (
    latlon,
    sim_sleep,
    truth_and_stack_fixtures,
    truth_yaw,
    until,
)  # tests/e2e_flight_helpers.py

pytestmark = pytest.mark.e2e
truth, stack = truth_and_stack_fixtures(flight_logs=True)  # a test reads them
ALT_M = 5.0


def truth_speed(truth) -> float:
    return math.hypot(*truth.latest().vel_ned_m_s[:2])


async def _session(stack, body):
    async with ground_station() as sdk:  # tests/mavsdk_session.py: plugins released first
        await sdk.add_any_connection(f"udpin://0.0.0.0:{stack.api_port}")
        system = await sdk.first_autopilot(timeout_s=30.0)
        assert system is not None, "MAVSDK found no autopilot"
        tel, action = TelemetryAsync(system), ActionAsync(system)

        async def ready():
            h = await tel.health()
            return h.is_global_position_ok and h.is_home_position_ok and h.is_armable and not await tel.armed()

        await until(ready, 90, "health: position, home, armable, disarmed")
        return await body(tel, action)


async def _take_off(tel, action) -> float:
    """Armed and hovering ALT_M above home; home's altitude AMSL."""
    await action.set_takeoff_altitude(ALT_M)
    await action.arm()
    await action.takeoff()

    async def up():
        return (await tel.position()).relative_altitude_m > ALT_M - 0.4

    await until(up, 60, f"take-off to {ALT_M} m")

    async def holding():  # the take-off done (AUTO.LOITER): its climb no longer braking
        return getattr(await tel.flight_mode(), "name", "") == "HOLD"

    await until(holding, 60, "take-off complete (Hold)")
    return (await tel.home()).absolute_altitude_m


async def _land(tel, action) -> None:
    await action.land()

    async def disarmed():
        return not await tel.armed()

    await until(disarmed, 120, "disarmed after landing")


def test_goto_with_heading_change_speed_and_orbit(stack, truth):
    """Load-independent figures of a flight in wall time: the goto's end and heading are read 2 s after the
    vehicle stopped there; the cruise speed 8 s into a 150 m leg (at cruise within a few seconds, the leg's
    end 20 s away), the changed speed 6 s after DO_CHANGE_SPEED (a 0.5 m/s step), the orbit over 15 s after
    20 s of settling onto it.  A command landing later on a busy machine moves these windows a little within
    states that last many seconds."""
    out = {}

    async def body(tel, action):
        home_amsl = await _take_off(tel, action)
        await sim_sleep(truth, 1.0)  # settled (a goto into the climb's braking: tests/test_commander.py)
        # goto_location with yaw 90 deg: MAVSDK sends DO_REPOSITION param4 = pi/2 (radians)
        lat, lon = latlon(15.0, 0.0)
        await action.goto_location(lat, lon, home_amsl + ALT_M, 90.0)

        async def there():
            s = truth.latest()
            return math.hypot(s.pos_ned_m[0] - 15.0, s.pos_ned_m[1]) < 0.5 and truth_speed(truth) < 0.2

        await until(there, 120, "at 15 m north, stopped")
        await sim_sleep(truth, 2.0)
        out["goto_pos"] = truth.latest().pos_ned_m
        out["goto_yaw"] = math.degrees(truth_yaw(truth))
        # a long move at the cruise speed, then DO_CHANGE_SPEED in the middle of it
        lat, lon = latlon(15.0, 150.0)
        await action.goto_location(lat, lon, home_amsl + ALT_M, math.nan)
        await sim_sleep(truth, 8.0)
        out["cruise_speed"] = truth_speed(truth)
        await action.set_current_speed(4.5)
        await sim_sleep(truth, 6.0)
        out["changed_speed"] = truth_speed(truth)
        # orbit 8 m about a point 10 m south of the vehicle, at 2 m/s, facing the centre
        here = truth.latest().pos_ned_m
        centre = (here[0] - 10.0, here[1])
        lat, lon = latlon(*centre)
        await action.do_orbit(8.0, 2.0, OrbitYawBehavior.HOLD_FRONT_TO_CIRCLE_CENTER, lat, lon, home_amsl + ALT_M)
        await sim_sleep(truth, 20.0)
        out["orbit_mode"] = getattr(await tel.flight_mode(), "name", "?")
        start_ms = truth.latest().time_ms
        await sim_sleep(truth, 15.0)
        samples = truth.since(start_ms)
        out["orbit_radii"] = [math.hypot(s.pos_ned_m[0] - centre[0], s.pos_ned_m[1] - centre[1]) for s in samples]
        out["orbit_speeds"] = [math.hypot(*s.vel_ned_m_s[:2]) for s in samples]
        await _land(tel, action)

    asyncio.run(_session(stack, body))
    stack.check_alive()
    radii, speeds = out["orbit_radii"], out["orbit_speeds"]
    print(
        f"goto end {out['goto_pos']}, yaw {out['goto_yaw']:.2f} deg; speed {out['cruise_speed']:.2f} -> "
        f"{out['changed_speed']:.2f} m/s; orbit mode {out['orbit_mode']}, radius {min(radii):.2f}..{max(radii):.2f} m, "
        f"mean speed {sum(speeds) / len(speeds):.2f} m/s"
    )
    assert math.hypot(out["goto_pos"][0] - 15.0, out["goto_pos"][1]) < 0.5
    assert abs(out["goto_yaw"] - 90.0) < 5.0, f"faces {out['goto_yaw']:.1f} deg, not east"
    assert out["cruise_speed"] == pytest.approx(5.0, abs=0.3)  # MPC_XY_CRUISE (default)
    assert out["changed_speed"] == pytest.approx(4.5, abs=0.3)
    assert out["orbit_mode"] == "POSCTL"  # PX4's orbit: main mode POSCTL (sub-mode ORBIT), as MAVSDK shows it
    assert min(radii) > 7.0 and max(radii) < 9.0, (min(radii), max(radii))
    assert sum(speeds) / len(speeds) == pytest.approx(2.0, abs=0.3)


def _gcs(stack) -> mavutil.mavfile:
    return mavutil.mavlink_connection(
        f"udpin:127.0.0.1:{stack.gcs_port}", source_system=255, source_component=190, dialect="common"
    )


def test_get_home_position_and_motor_test_on_the_ground(stack, truth):
    """QGroundControl's way, a bare pymavlink link in wall time.  The motor test's duration is the flight
    controller's timeout, counted on its (simulated) clock and read from the simulator's truth log, so it
    does not depend on when the command arrived."""
    conn = _gcs(stack)
    try:
        assert conn.wait_heartbeat(timeout=30) is not None
        conn.mav.command_long_send(stack.sysid, 1, mavlink.MAV_CMD_GET_HOME_POSITION, 0, 0, 0, 0, 0, 0, 0, 0)
        home = conn.recv_match(type="HOME_POSITION", blocking=True, timeout=10)
        assert home is not None and abs(home.latitude * 1e-7 - latlon(0, 0)[0]) < 1e-4
        conn.mav.command_long_send(stack.sysid, 1, mavlink.MAV_CMD_DO_MOTOR_TEST, 0, 3, 0, 15, 2.0, 0, 0, 0)
        ack = None
        while ack is None or ack.command != mavlink.MAV_CMD_DO_MOTOR_TEST:
            ack = conn.recv_match(type="COMMAND_ACK", blocking=True, timeout=10)
            assert ack is not None, "no COMMAND_ACK for DO_MOTOR_TEST"
        assert ack.result == mavlink.MAV_RESULT_ACCEPTED
        spinning, stopped = None, None
        end = time.monotonic() + 30.0  # safety net only
        while time.monotonic() < end and stopped is None:
            msg = conn.recv_match(type="SERVO_OUTPUT_RAW", blocking=True, timeout=5)
            if msg is None:
                continue
            pwm = [msg.servo1_raw, msg.servo2_raw, msg.servo3_raw, msg.servo4_raw]
            if spinning is None and pwm[2] > 900:
                spinning = pwm
            elif spinning is not None and pwm[2] == 900:
                stopped = pwm
    finally:
        conn.close()
    stack.check_alive()
    assert spinning == [900, 900, 1150, 900], spinning  # motor 3 at 15 %, the others disarmed
    assert stopped == [900, 900, 900, 900]  # the timeout ended it
    # ... and the simulator spun it: its truth log (written while the outputs are live) has the command applied
    applied = None
    end = time.monotonic() + 30.0  # safety net only: the log's last chunk is written when it closes
    while time.monotonic() < end and applied is None:
        for path in sorted(Path(stack.log_dir).glob("*.truth.npy")):
            log = np.load(path)
            others_off = all((log[f"motor_{i}"] == 0).all() for i in (0, 1, 3)) if len(log) else False
            # the motor test's own log (a flight's log also ends with its motors off): only motor 3 ever spun
            if others_off and log["motor_2"].max() > 0 and log["motor_2"][-1] == 0:
                applied = log
        time.sleep(0.2)
    assert applied is not None, "no truth log in which motor 3 alone spun and stopped"
    spun = applied[applied["motor_2"] > 0]
    assert spun["motor_2"] == pytest.approx(0.15)
    assert (spun["time_us"][-1] - spun["time_us"][0]) * 1e-6 == pytest.approx(2.0, abs=0.05)  # the timeout
    assert abs(applied["pos_d_m"]).max() < 0.2  # stayed on the ground


async def arm_once_armable(action, truth, within_s: float = 20.0) -> None:
    """Arm, trying again each simulated second while the vehicle refuses (COMMAND_DENIED) for up to ``within_s``
    simulated seconds.  MAVSDK's health is its latest SYS_STATUS and HOME_POSITION: read in wall time just after
    a reboot it may still be the one from before it (flake hunt, 2026-12-02: arm denied under two suites), so
    it cannot say when the rebooted vehicle is armable; the vehicle's own answer does, in its own time."""
    t0 = truth.latest().time_ms
    while True:
        try:
            await action.arm()
            return
        except ActionError as exc:
            if exc.result is not ActionResult.COMMAND_DENIED:
                raise
            if truth.latest().time_ms - t0 > within_s * 1e3:
                raise AssertionError(f"arming refused for {within_s:g} simulated s after the reboot") from exc
        await sim_sleep(truth, 1.0)


def test_reboot_comes_back_disarmed_and_answering(stack, truth):
    async def body(tel, action):
        await action.set_return_to_launch_altitude(17.0)  # RTL_RETURN_ALT: a parameter the reboot keeps
        await action.reboot()
        await sim_sleep(truth, 3.0)  # telemetry from after the reboot

        async def back():
            h = await tel.health()
            return h.is_home_position_ok and h.is_armable and not await tel.armed()

        await until(back, 60, "healthy and disarmed after the reboot")
        await arm_once_armable(action, truth)  # armable again

        async def armed():
            return await tel.armed()

        await until(armed, 30, "armed after the reboot")
        await action.disarm()
        return await action.get_return_to_launch_altitude()

    assert asyncio.run(_session(stack, body)) == pytest.approx(17.0)
    stack.check_alive()


def test_terminate_stops_the_motors_in_the_air_and_arming_is_refused(stack, truth):
    async def body(tel, action):
        await _take_off(tel, action)
        await action.terminate()

        async def fell():
            return truth.latest().pos_ned_m[2] > -0.3 and not await tel.armed()

        await until(fell, 60, "on the ground, disarmed")
        with pytest.raises(ActionError):
            await action.arm()

        async def not_armable():  # SYS_STATUS's PREARM_CHECK bit, cleared by "flight terminated" until a reboot
            return not (await tel.health()).is_armable

        await until(not_armable, 30, "MAVSDK's health: not armable after the termination")
        return await tel.armed()

    assert asyncio.run(_session(stack, body)) is False
    stack.check_alive()
