"""A companion computer flies the real stack in OFFBOARD: MAVSDK's Offboard plugin, and pymavlink.

One stack for the file.  First, in simulated time (``stepped_flight_fixture``, issue 33: the simulator held,
every setpoint sent between two steps, each figure the same in every run), a pymavlink client
(:class:`gcs.client.VehicleClient`) streams velocity setpoints (SET_POSITION_TARGET_LOCAL_NED) around a
circle, one every 0.1 s of simulated time, and sends one MAV_FRAME_BODY_OFFSET_NED target.  Then the hold
is lifted and MAVSDK, a client in wall time, does what a MAVSDK user does: stream a setpoint, arm,
``offboard.start()`` (the vehicle lifts off to the streamed position), fly a 5 m square with
``set_position_ned``, a straight leg with ``set_velocity_ned``, an attitude step with ``set_attitude``,
``offboard.stop()`` (the vehicle holds), start again and then stop sending (the plugin destroyed, as a
crashed companion computer): after COM_OF_LOSS_T the vehicle leaves OFFBOARD for the COM_OBL_RC_ACT
fallback (POSCTL by default, holding) and says so in a STATUSTEXT.

MAVSDK streams setpoints at about 20 Hz of wall-clock time while the simulation runs several times
faster: the loss timer needs silence on both clocks, so the stream counts as alive.  Where a MAVSDK
command lands in simulated time depends on the machine's load, so the MAVSDK flight asserts only
settled states (a corner reached, a constant velocity or attitude held, a hover's drift), each measured
after the command has had simulated seconds to act; a setpoint that changes with time (the circle) is
flown in simulated time.  Where the vehicle went and how it was tilted is the simulator's ground truth
(NED from the simulator's home); the setpoints are in the estimator's frame (origin at the first GPS
fix), so the test measures the offset between the two while hovering.  Durations are simulated
seconds; wall-clock waits are safety nets.
"""

from __future__ import annotations

import asyncio
import math

import numpy as np
import pytest

from gcs.client import mavlink

mavsdk = pytest.importorskip("mavsdk", reason="MAVSDK is in the test extras: pip install '.[test]'")
from mavsdk.asyncio.plugins.action import ActionAsync  # noqa: E402
from mavsdk.asyncio.plugins.offboard import (  # noqa: E402
    Attitude,
    OffboardAsync,
    PositionGlobalYaw,
    PositionNedYaw,
    VelocityNedYaw,
)
from mavsdk.asyncio.plugins.telemetry import TelemetryAsync  # noqa: E402
from mavsdk.plugins.telemetry import FlightMode  # noqa: E402
from mavsdk_session import ground_station  # noqa: E402

from e2e_flight_helpers import (  # tests/e2e_flight_helpers.py
    latlon,
    record_figure,
    sim_ms,
    sim_sleep,
    stepped_flight_fixture,
    until,
)

pytestmark = pytest.mark.e2e
WAIT_S = 120.0  # wall-clock safety net of each wait
ALT_M = 5.0
SQUARE = [(5.0, 0.0), (5.0, 5.0), (0.0, 5.0), (0.0, 0.0)]  # north, east from the estimator origin, m
CORNER_SETTLE_S = 8.0  # simulated seconds at each corner before the truth is read
CIRCLE_SPEED, CIRCLE_RADIUS = 2.0, 3.0  # m/s, m
SETPOINT_EVERY_S = 0.1  # the circle's velocity setpoints: one every 0.1 s of simulated time
VELOCITY_NE = (1.2, -1.6)  # MAVSDK's velocity leg, m/s north and east: 2 m/s to the north-west
ROLL_DEG, PITCH_DEG = 10.0, -6.0  # the attitude step
ATTITUDE_THRUST = 0.58  # its thrust: quad_x hovers at 57 % of full thrust, divided by cos(11.7 deg) of tilt
GLOBAL_NE = (-3.0, 2.0)  # the set_position_global point, m north and east of the simulator's home

flight = stepped_flight_fixture(then_free=True)  # one stack, held from its start; its client on the ground-station port


@pytest.fixture
def f(flight):
    """The flight in simulated time (before the hold is lifted for MAVSDK: the file's order)."""
    assert not flight.free, "the stepped flights come before the hold is lifted (file order)"
    return flight


@pytest.fixture(scope="module")
def free(flight):
    """The same stack with its hold lifted (the simulation at full speed, for MAVSDK): (stack, truth)."""
    flight.run_free()
    return flight.stack, flight.truth


def truth_euler_deg(state) -> tuple[float, float]:
    w, x, y, z = state.attitude_quaternion
    roll = math.atan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = math.asin(max(-1.0, min(1.0, 2 * (w * y - z * x))))
    return math.degrees(roll), math.degrees(pitch)


def truth_yaw(state) -> float:
    w, x, y, z = state.attitude_quaternion
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


# --------------------------------------------------------------------------- pymavlink, in simulated time

BODY_OFFSET = (3.0, 2.0, -1.0)  # forward, right, down from where the vehicle is, m (heading frame)
POS_ONLY_MASK = 0b1101_1111_1000  # x, y, z given; velocity, acceleration, yaw and yaw rate ignored (yaw held)
POS_YAW_MASK = 0b1001_1111_1000  # x, y, z and yaw given
VEL_YAW_MASK = 0b1001_1100_0111  # vx, vy, vz and yaw given (as MAVSDK's set_velocity_ned)


def send_local(client, frame: int, mask: int, pos, yaw: float = 0.0, vel=(0.0, 0.0, 0.0)) -> None:
    client.conn.mav.set_position_target_local_ned_send(
        0, client.target_system, client.target_component, frame, mask, *pos, *vel, 0, 0, 0, yaw, 0
    )


def test_velocity_setpoints_fly_a_circle(f):
    """Velocity setpoints (SET_POSITION_TARGET_LOCAL_NED, as MAVSDK's set_velocity_ned sends them) turned
    round a circle for one period, one every SETPOINT_EVERY_S of simulated time: the vehicle flies them at
    the speed commanded and its course goes round.  The vehicle is left hovering in LOITER."""
    client = f.client
    f.take_off(ALT_M)
    send_local(client, mavlink.MAV_FRAME_LOCAL_NED, VEL_YAW_MASK, (0.0, 0.0, 0.0))  # OFFBOARD needs a setpoint
    client.set_mode("OFFBOARD").check()
    omega = CIRCLE_SPEED / CIRCLE_RADIUS
    t0 = f.now_ms
    period_ms = 2 * math.pi / omega * 1000
    while f.now_ms - t0 < period_ms:
        phase = omega * (f.now_ms - t0) / 1000
        vel = (CIRCLE_SPEED * math.cos(phase), CIRCLE_SPEED * math.sin(phase), 0.0)
        send_local(client, mavlink.MAV_FRAME_LOCAL_NED, VEL_YAW_MASK, (0.0, 0.0, 0.0), 0.0, vel)
        f.wait(SETPOINT_EVERY_S)
    assert client.mode_name() == "OFFBOARD"
    samples = f.truth_since(t0 + 2000)  # after the first 2 s of turning in
    client.set_mode("AUTO.LOITER").check()
    speeds = [math.hypot(*s.vel_ned_m_s[:2]) for s in samples]
    courses = np.unwrap([math.atan2(s.vel_ned_m_s[1], s.vel_ned_m_s[0]) for s in samples])
    turned = math.degrees(float(courses[-1] - courses[0]))
    expected = 360.0 - math.degrees(CIRCLE_SPEED / CIRCLE_RADIUS * 2.0)  # one period less the first 2 s
    record_figure(
        "circle_mean_speed_error_m_s", abs(float(np.mean(speeds)) - CIRCLE_SPEED), 0.15 * CIRCLE_SPEED, unit="m/s"
    )
    record_figure("circle_course_turned_error_deg", abs(turned - expected), 30.0, unit="deg")  # went round
    f.mode_is("LOITER")


def test_body_offset_ned_target_moves_the_vehicle_relative_to_itself(f):
    """A client turns the vehicle to face east, then sends one target 3 m forward, 2 m right, 1 m up in
    MAV_FRAME_BODY_OFFSET_NED: the vehicle goes 3 m east, 2 m south, 1 m up of where it was.  One message
    is the target (each one is an offset from the vehicle at its arrival), so COM_OF_LOSS_T is raised for
    the test rather than streamed."""
    client, truth = f.client, f.truth
    f.client.param_set("COM_OF_LOSS_T", 60.0)  # between two steps: it acts from the next
    try:
        f.take_off(ALT_M)
        here = client.local_position_ned()
        for _ in range(3):  # hold here, facing east
            send_local(client, mavlink.MAV_FRAME_LOCAL_NED, POS_YAW_MASK, here, math.pi / 2)
        client.set_mode("OFFBOARD").check()

        def facing_east() -> bool:  # and no longer turning
            st = truth.state_at(f.now_ms, within_ms=0)
            return st is not None and abs(truth_yaw(st) - math.pi / 2) < 0.02 and abs(st.yawspeed) < 0.03

        f.until(facing_east, 30.0, "facing east")
        f.wait(2.0)
        before = f.truth_now()
        state = truth.state_at(before.time_ms, within_ms=0)  # its attitude
        for _ in range(2):
            send_local(client, mavlink.MAV_FRAME_BODY_OFFSET_NED, POS_ONLY_MASK, BODY_OFFSET)
        f.wait(10.0)
        after = f.truth_now()
        mode = client.mode_name()
        f.land()
    finally:
        f.client.param_set("COM_OF_LOSS_T", 1.0)

    assert state is not None
    yaw = truth_yaw(state)
    forward, right, down = BODY_OFFSET
    expected = np.array(before.pos_ned_m) + [
        forward * math.cos(yaw) - right * math.sin(yaw), forward * math.sin(yaw) + right * math.cos(yaw), down
    ]  # fmt: skip
    moved = np.array(after.pos_ned_m) - before.pos_ned_m
    error = float(np.linalg.norm(np.array(after.pos_ned_m) - expected))
    print(f"BODY_OFFSET_NED {BODY_OFFSET} at heading {math.degrees(yaw):.1f} deg: moved {np.round(moved, 2)}")
    record_figure("body_offset_heading_error_deg", abs(math.degrees(yaw) - 90.0), 3.0, unit="deg")
    assert mode == "OFFBOARD"
    record_figure("body_offset_true_error_m", error, 0.3, unit="m")


# --------------------------------------------------------------------------- MAVSDK, in wall time


async def _mode(tel, mode) -> None:
    async def in_mode():
        return await tel.flight_mode() == mode

    await until(in_mode, WAIT_S, f"flight mode {mode}")


async def _offset(tel, truth) -> np.ndarray:
    """Truth minus estimate (m NED) while hovering still: the estimator origin seen from the simulator's home."""
    diffs = []
    for _ in range(10):
        est = (await tel.position_velocity_ned()).position
        diffs.append(np.array(truth.latest().pos_ned_m) - [est.north_m, est.east_m, est.down_m])
        await sim_sleep(truth, 0.2)
    return np.median(diffs, axis=0)


async def _square(offboard, truth, offset) -> list[float]:
    errors = []
    for north, east in SQUARE:
        await offboard.set_position_ned(PositionNedYaw(north, east, -ALT_M, 0.0))
        await sim_sleep(truth, CORNER_SETTLE_S)
        target = np.array([north, east, -ALT_M]) + offset
        errors.append(float(np.linalg.norm(np.array(truth.latest().pos_ned_m) - target)))
    return errors


async def _velocity_leg(offboard, truth) -> tuple[list[float], list[float]]:
    """A constant velocity setpoint (VELOCITY_NE) for 6 s: the truth's speeds and courses (rad) over the last
    2 s.  The velocity loop overshoots a step by about 13 % and settles within 2-3 % in 4 s; settled, the
    figures do not depend on when the setpoint arrived."""
    await offboard.set_velocity_ned(VelocityNedYaw(*VELOCITY_NE, 0.0, 0.0))
    t0 = await sim_sleep(truth, 4.0)
    await sim_sleep(truth, 2.0)
    samples = truth.since(t0)
    speeds = [math.hypot(*s.vel_ned_m_s[:2]) for s in samples]
    courses = [math.atan2(s.vel_ned_m_s[1], s.vel_ned_m_s[0]) for s in samples]
    return speeds, courses


async def _attitude_step(offboard, truth) -> list[tuple[float, float]]:
    """The attitude step's settled second: from 0.6 s to 1.6 s of simulated time after the truth first shows the
    step under way (half the commanded roll).  Both ends are counted from that sample, not from when this client
    noticed it: at full speed a client stalled for a wall second on a busy machine sees tens of simulated seconds
    go by, and a window counted from its own waits ended, in two flake hunts, after the vehicle (thrust 0.5, below
    the hover thrust) had sunk to the ground and lay tilted on its legs (roll 10.8 with pitch 0; roll 11 off).
    The thrust is about the hover thrust tilted, so the vehicle holds its height meanwhile."""
    start = await asyncio.get_running_loop().run_in_executor(None, truth.caught_up, WAIT_S)
    await offboard.set_attitude(Attitude(ROLL_DEG, PITCH_DEG, 0.0, ATTITUDE_THRUST))

    def first_rolling() -> int | None:
        with truth.lock:
            times = sorted(t for t in truth.states if t >= start)
            return next((t for t in times if truth_euler_deg(truth.states[t])[0] > ROLL_DEG / 2), None)

    async def rolling():
        return first_rolling() is not None

    await until(rolling, WAIT_S, f"the truth's roll past {ROLL_DEG / 2:g} deg", period_s=0.005)
    t_roll = first_rolling()
    assert t_roll is not None

    async def window_passed():
        return sim_ms(truth) >= t_roll + 1600

    await until(window_passed, WAIT_S, "the attitude step's settled second", period_s=0.005)
    a, b = truth.at(t_roll + 600), truth.at(t_roll + 1600)
    if a is not None and b is not None:
        print(f"attitude step: height {-a.pos_ned_m[2]:.2f} -> {-b.pos_ned_m[2]:.2f} m over the settled second")
    states = [truth.state_at(t) for t in range(t_roll + 600, t_roll + 1600, 20)]
    return [truth_euler_deg(s) for s in states if s is not None]


async def _texts(tel, into: list[str]) -> None:
    async for st in tel.subscribe_status_text():
        into.append(st.text)


async def _flight(stack, truth) -> dict:
    out: dict = {}
    async with ground_station() as sdk:  # tests/mavsdk_session.py: plugins released first
        await sdk.add_any_connection(f"udpin://0.0.0.0:{stack.api_port}")
        system = await sdk.first_autopilot(timeout_s=30.0)
        assert system is not None, "MAVSDK found no autopilot"
        tel, action, offboard = TelemetryAsync(system), ActionAsync(system), OffboardAsync(system)
        texts: list[str] = []
        listener = asyncio.ensure_future(_texts(tel, texts))

        async def ready():
            h = await tel.health()
            return h.is_global_position_ok and h.is_home_position_ok and h.is_armable

        await until(ready, WAIT_S, "health: position, home, armable")
        await offboard.set_position_ned(PositionNedYaw(0.0, 0.0, -ALT_M, 0.0))  # streaming from now on
        await asyncio.sleep(0.3)
        await action.arm()
        await offboard.start()  # on the ground: the streamed position 5 m up lifts off
        await _mode(tel, FlightMode.OFFBOARD)

        async def up():
            return (await tel.position()).relative_altitude_m > ALT_M - 0.5

        await until(up, WAIT_S, "climbed to the streamed altitude")
        await sim_sleep(truth, 6.0)
        offset = await _offset(tel, truth)
        out["square"] = await _square(offboard, truth, offset)
        lat, lon = latlon(*GLOBAL_NE)
        await offboard.set_position_global(
            PositionGlobalYaw(lat, lon, ALT_M, 0.0, PositionGlobalYaw.AltitudeType.REL_HOME)
        )
        await sim_sleep(truth, CORNER_SETTLE_S)
        out["global"] = truth.latest().pos_ned_m
        out["velocity"] = await _velocity_leg(offboard, truth)
        await offboard.set_position_ned(PositionNedYaw(0.0, 0.0, -ALT_M, 0.0))
        await sim_sleep(truth, 8.0)
        out["attitude"] = await _attitude_step(offboard, truth)
        await offboard.set_position_ned(PositionNedYaw(0.0, 0.0, -ALT_M, 0.0))
        await sim_sleep(truth, 8.0)

        await offboard.stop()  # MAVSDK switches to Hold
        await _mode(tel, FlightMode.HOLD)
        t_hold = await sim_sleep(truth, 1.0)
        await sim_sleep(truth, 5.0)
        out["hold"] = [s.pos_ned_m for s in truth.since(t_hold)]

        await offboard.set_position_ned(PositionNedYaw(0.0, 0.0, -ALT_M, 0.0))
        await asyncio.sleep(0.3)
        await offboard.start()
        await _mode(tel, FlightMode.OFFBOARD)
        await sim_sleep(truth, 2.0)
        n_texts = len(texts)
        offboard.destroy()  # the companion computer stops sending
        await _mode(tel, FlightMode.POSCTL)  # COM_OBL_RC_ACT 0: position mode, holding without sticks
        t_lost = await sim_sleep(truth, 1.0)
        await sim_sleep(truth, 5.0)
        out["after_loss"] = [s.pos_ned_m for s in truth.since(t_lost)]

        async def said_lost():
            return any("Offboard control lost" in t for t in texts[n_texts:])

        await until(said_lost, WAIT_S, "a STATUSTEXT saying offboard control was lost")
        out["texts"] = texts[n_texts:]
        await action.land()

        async def disarmed():
            return not await tel.armed()

        await until(disarmed, WAIT_S, "disarmed after landing")
        listener.cancel()
        try:
            await listener
        except asyncio.CancelledError:
            pass
    return out


def test_offboard_position_velocity_attitude_stop_and_loss(free):
    """MAVSDK's way, in wall time.  Every figure asserted is a settled state, measured simulated seconds after
    the command that made it (a corner after CORNER_SETTLE_S, the velocity leg after 4 s, the attitude after
    0.6 s, a hover's drift once holding), so how late a command landed on a busy machine does not change it."""
    stack, truth = free
    out = asyncio.run(_flight(stack, truth))
    stack.check_alive()
    errors = out["square"]
    print("square corner errors (truth, m):", " ".join(f"{e:.3f}" for e in errors))
    assert max(errors) <= 0.3

    error = math.dist(out["global"], (*GLOBAL_NE, -ALT_M))  # lat/lon and height above home, by the truth
    print(f"set_position_global (GLOBAL_RELATIVE_ALT_INT): truth error {error:.3f} m")
    assert error <= 0.5  # the GPS and barometer errors of the estimate included

    speeds, courses = out["velocity"]
    course = math.degrees(math.atan2(VELOCITY_NE[1], VELOCITY_NE[0]))
    course_err = max(abs(math.degrees(c) - course) for c in courses)
    print(f"velocity leg: mean speed {np.mean(speeds):.3f} m/s, course error up to {course_err:.1f} deg")
    assert np.mean(speeds) == pytest.approx(math.hypot(*VELOCITY_NE), rel=0.15)
    assert course_err < 10.0  # the course as commanded (the circle's course: test_velocity_setpoints_fly_a_circle)

    att = out["attitude"]
    roll_err = max(abs(r - ROLL_DEG) for r, _ in att)
    pitch_err = max(abs(p - PITCH_DEG) for _, p in att)
    print(f"attitude step: roll error {roll_err:.2f} deg, pitch error {pitch_err:.2f} deg over {len(att)} samples")
    assert len(att) > 10 and roll_err <= 3.0 and pitch_err <= 3.0

    hold = out["hold"]
    drift = max(math.dist(p, hold[0]) for p in hold)
    print(f"after offboard.stop() (Hold): drift {drift:.3f} m over 5 s")
    assert drift <= 0.3

    after = out["after_loss"]
    drift = max(math.dist(p, after[0]) for p in after)
    print(f"after the loss (POSCTL): drift {drift:.3f} m over 5 s; texts {out['texts']}")
    assert drift <= 0.3
    assert any(t.startswith("Offboard control lost") for t in out["texts"])
