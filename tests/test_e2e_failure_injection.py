"""End-to-end: MAV_CMD_INJECT_FAILURE against the real stack, each fault with the reaction a user expects.

Real ``sitl`` and ``autopilot`` processes (``--speed max``); MAVSDK's Failure plugin (it reads
SYS_FAILURE_EN and refuses by itself while it is 0) and a pymavlink ground station
(:class:`gcs.client.VehicleClient` on the stack's own ground-station port) send the command; the
flight controller sets the simulator's fault parameters over the simulator link and is told nothing
else: its estimator and commander find the fault in the sensors.  Checks are what a user checks:
the COMMAND_ACK, the STATUSTEXTs, SYS_STATUS health bits, the mode, and where the vehicle truly went
(the simulator's truth, :class:`gcs.sim_client.SimClient`).  Three stacks: MAVSDK with a GPS loss
(then a stuck GPS and a motor off on the quadcopter); the magnetometer, barometer and battery in one
flight, then on the same vehicle, landed, the IMU (on the ground, then in flight); and the hexacopter
losing a motor.  Durations are simulated seconds; wall-clock timeouts are safety nets only.
"""

from __future__ import annotations

import asyncio
import math

import pytest

from gcs.client import VehicleClient, mavlink
from gcs.launcher import Stack
from gcs.sim_client import SimClient
from mavsim_core import ports

from e2e_flight_helpers import (  # tests/e2e_flight_helpers.py
    horizontal,
    sim_sleep,
    texts_since,
    until,
    wait_armable,
    wait_text,
)

pytestmark = pytest.mark.e2e
WAIT_S = 120.0
ALT_M = 5.0
NO_FLY_AWAY_M = 5.0  # a landing without GPS drifts on the unaided estimate (3.4 m seen): more is a fly-away
INJECT = mavlink.MAV_CMD_INJECT_FAILURE
GYRO, ACCEL, MAG, BARO, GPS = 0, 1, 2, 3, 4  # FAILURE_UNIT
BATTERY, MOTOR = 100, 101
OK, OFF, STUCK, GARBAGE = 0, 1, 2, 3  # FAILURE_TYPE
SENSOR = {
    "gyro": mavlink.MAV_SYS_STATUS_SENSOR_3D_GYRO,
    "baro": mavlink.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE,
    "mag": mavlink.MAV_SYS_STATUS_SENSOR_3D_MAG,
}


def start(vehicle: str = "quad_x"):
    """A class fixture: (stack, truth) of a fresh stack on a free instance.  Class, not module, scope: a stack
    at ``--speed max`` steps as fast as it can even while no test uses it, so each one stops when its class
    of tests ends instead of burning CPU beside the next ones (and the other pytest worker) until the module
    ends."""

    @pytest.fixture(scope="class")
    def fixture(free_instance):
        i = free_instance()
        with Stack(instance=i, vehicle=vehicle, speed="max") as stack, SimClient(ports.sim_component_port(i)) as truth:
            truth.wait_connected()
            yield stack, truth

    return fixture


mavsdk_stack = start()  # TestQuadcopterWithMavsdk
sensor_stack = start()  # TestSensorsThenImu: the IMU faults after the battery failsafe's landing (a stack fewer)
hexa_stack = start(vehicle="firefly")  # TestHexacopter


def client_of(stack: Stack) -> VehicleClient:
    return VehicleClient(stack.gcs_url, timeout_s=WAIT_S, idle=stack.check_alive)


def inject(client: VehicleClient, unit: int, ftype: int, inst: int = 0):
    return client.command_long(INJECT, unit, ftype, inst, 0, 0, 0, 0)


def take_off(client: VehicleClient, truth: SimClient):
    """Arm, take off to ALT_M, settle; the truth sample of the hover point."""
    client.wait_until(client.prearm_ok, WAIT_S, "ready to arm")
    client.arm().check()
    client.takeoff(client.wait_home().alt_amsl_m + ALT_M).check()
    client.wait_until(lambda: client.takeoff_done(ALT_M), WAIT_S, "take-off")
    client.wait_sim_time(2.0)
    return truth.latest()


def healthy(client: VehicleClient, bit: int) -> bool:
    return bool(client.latest("SYS_STATUS").onboard_control_sensors_health & bit)


def drift_m(truth: SimClient, since) -> tuple[float, float]:
    """(worst horizontal, worst vertical) distance of the true vehicle from a truth sample, since it, m."""
    later = truth.since(since.time_ms)
    p = since.pos_ned_m
    return max(horizontal(s.pos_ned_m, p) for s in later), max(abs(s.pos_ned_m[2] - p[2]) for s in later)


# ------------------------------------------------------------------- helpers: MAVSDK's GPS loss, a fault cleared


async def _mavsdk_gps_loss(stack: Stack, truth: SimClient) -> dict:
    from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
    from mavsdk.asyncio.plugins.action import ActionAsync
    from mavsdk.asyncio.plugins.failure import FailureAsync, FailureError, FailureResult, FailureType, FailureUnit
    from mavsdk.asyncio.plugins.param import ParamAsync
    from mavsdk.asyncio.plugins.telemetry import TelemetryAsync
    from mavsdk.plugins.telemetry import FlightMode

    out: dict = {}
    async with Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION)) as sdk:
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
        out["during"] = drift_m(truth, hold), truth.latest().pos_ned_m[2] - hold.pos_ned_m[2]
        out["gps_ok_during"] = (await tel.health()).is_global_position_ok
        out["restore"] = await failure.inject(FailureUnit.SENSOR_GPS, FailureType.OK, 0)

        async def position_back():
            return (await tel.health()).is_global_position_ok

        await until(position_back, WAIT_S, "the position estimate back")

        async def landed():
            return not await tel.armed()

        await until(landed, WAIT_S, "landed and disarmed")
        out["landed_m"] = horizontal(truth.latest().pos_ned_m, hold.pos_ned_m)
        out["texts"] = texts
        listener.cancel()
    out["success"] = FailureResult.SUCCESS
    out["refusals"] = (FailureResult.DISABLED, FailureResult.DENIED)
    return out


def _fault_then_ok(client, truth, unit, ftype, detected: str, recovered: str, bit: int, hold_s: float):
    """Inject, wait for the flight controller's own report, hold ``hold_s``, clear, wait for the recovery;
    the worst (horizontal, vertical) drift from the point held when the fault came."""
    n = len(client.statustexts)
    point = truth.latest()
    assert inject(client, unit, ftype).result == mavlink.MAV_RESULT_ACCEPTED
    wait_text(client, n, detected)
    client.wait_until(lambda: not healthy(client, bit), WAIT_S, f"SYS_STATUS unhealthy after {detected!r}")
    client.wait_sim_time(hold_s)
    drift = drift_m(truth, point)
    assert client.mode_name() == "LOITER" and client.armed(), texts_since(client, n)
    assert inject(client, unit, OK).result == mavlink.MAV_RESULT_ACCEPTED
    wait_text(client, n, recovered)
    client.wait_until(lambda: healthy(client, bit), WAIT_S, f"healthy after {recovered!r}")
    return drift


class TestQuadcopterWithMavsdk:
    """One stack: the gating, MAVSDK's GPS loss, the refusals, a stuck GPS, a motor off."""

    def test_disabled_by_default_denied_with_the_reason(self, mavsdk_stack):
        stack, truth = mavsdk_stack
        with client_of(stack) as client:
            assert client.param_get("SYS_FAILURE_EN") == 0  # PX4's default
            ack = inject(client, GPS, OFF)
            assert ack.result == mavlink.MAV_RESULT_DENIED
            assert ack.reason == "Failure injection disabled: set SYS_FAILURE_EN to 1"
            client.wait_sim_time(1.0)
            assert client.gps()[0] >= 3, "the GPS still works"

    def test_mavsdk_gps_loss_in_hold_lands_where_it_is_and_ok_restores_it(self, mavsdk_stack):
        """COM_POSCTL_NAVL 0 and no pilot sticks: a position lost in HOLD lands on the height estimate (PX4's
        position-loss failsafe), where the vehicle is: no fly-away in the truth.  FAILURE_TYPE_OK brings the
        GPS back; the landing, a failsafe action, goes on."""
        pytest.importorskip("mavsdk", reason="MAVSDK is in the test extras: pip install '.[test]'")
        stack, truth = mavsdk_stack
        out = asyncio.run(_mavsdk_gps_loss(stack, truth))
        texts = out["texts"]
        assert out["disabled"] in out["refusals"]
        assert out["inject"] == out["success"] and out["restore"] == out["success"]
        (worst_h, worst_v), descended = out["during"]
        assert worst_h < NO_FLY_AWAY_M, f"drifted {worst_h:.1f} m without GPS ({texts})"
        assert descended > 0.5, "not descending"
        assert not out["gps_ok_during"]
        assert "Failure injected: GPS off" in texts and "Failure cleared: GPS" in texts
        assert "Position estimate lost: landing" in texts and "Position estimate regained" in texts
        assert out["landed_m"] < NO_FLY_AWAY_M, f"landed {out['landed_m']:.1f} m from where the GPS was lost"

    def test_refusals_name_what_the_simulator_cannot_do(self, mavsdk_stack):
        stack, truth = mavsdk_stack
        with client_of(stack) as client:
            assert client.param_get("SYS_FAILURE_EN") == 1
            cases = [
                ((GPS, GARBAGE), mavlink.MAV_RESULT_UNSUPPORTED, "GPS garbage is not supported in simulation"),
                ((mavlink.FAILURE_UNIT_SENSOR_AIRSPEED, OFF), mavlink.MAV_RESULT_UNSUPPORTED, "airspeed off"),
                ((MOTOR, OFF, 0), mavlink.MAV_RESULT_UNSUPPORTED, "all motors at once"),
                ((MOTOR, OFF, 5), mavlink.MAV_RESULT_DENIED, "no motor 5: the vehicle has 4"),
                ((GPS, OFF, 2), mavlink.MAV_RESULT_DENIED, "no GPS 2"),
            ]
            for args, result, words in cases:
                ack = inject(client, *args)
                assert ack.result == result and words in (ack.reason or ""), (args, ack.describe())

    def test_a_stuck_gps_is_found_and_the_vehicle_lands_where_it_was(self, mavsdk_stack):
        """A frozen receiver (its fixes repeat exactly) is not fused (PX4's STALE rule): the position times
        out and the position-loss failsafe lands, without flying after the frozen velocity."""
        stack, truth = mavsdk_stack
        with client_of(stack) as client:
            hold = take_off(client, truth)
            n = len(client.statustexts)
            try:
                assert inject(client, GPS, STUCK).result == mavlink.MAV_RESULT_ACCEPTED
                wait_text(client, n, "GPS failed: stale data")
                wait_text(client, n, "Position estimate lost: landing")
                client.wait_until(client.landed_and_disarmed, WAIT_S, "landed and disarmed")
                drifted = drift_m(truth, hold)[0]
                print(f"stuck GPS: drifted {drifted:.2f} m ({texts_since(client, n)})")
                assert drifted < NO_FLY_AWAY_M, f"drifted {drifted:.1f} m ({texts_since(client, n)})"
            finally:
                assert inject(client, GPS, OK).result == mavlink.MAV_RESULT_ACCEPTED
            wait_text(client, n, "GPS healthy again")

    def test_a_quadcopter_with_a_motor_off_falls_where_it_was(self, mavsdk_stack):
        """Three rotors cannot hold a quadcopter: it falls, near where it was (no fly-away).  The failure
        detector (FD_FAIL_R/FD_FAIL_P) reports it and the crash check disarms the wreck
        (test_e2e_failure_detection); here a forced disarm at touchdown comes before the crash check's 2 s."""
        stack, truth = mavsdk_stack
        with client_of(stack) as client:
            hold = take_off(client, truth)
            assert inject(client, MOTOR, OFF, 1).result == mavlink.MAV_RESULT_ACCEPTED
            client.wait_until(lambda: truth.latest().pos_ned_m[2] > -0.5, WAIT_S, "on the ground")
            fall = truth.since(hold.time_ms)
            assert max(s.vel_ned_m_s[2] for s in fall) > 3.0, "it did not fall"
            assert max(horizontal(s.pos_ned_m, hold.pos_ned_m) for s in fall) < 5.0
            client.disarm(force=True).check()
            assert inject(client, MOTOR, OK, 1).result == mavlink.MAV_RESULT_ACCEPTED


class TestSensorsThenImu:
    """One stack: magnetometer, barometer and battery in flight, then the IMU (on the ground, in flight)."""

    # magnetometer, barometer, battery
    def test_magnetometer_and_barometer_faults_in_flight_are_found_and_the_vehicle_holds(self, sensor_stack):
        stack, truth = sensor_stack
        with client_of(stack) as client:
            client.param_set("SYS_FAILURE_EN", 1)
            take_off(client, truth)
            mag = SENSOR["mag"]
            healthy_again = "magnetometer healthy again"
            h, v = _fault_then_ok(client, truth, MAG, OFF, "EKF: no magnetometer data", healthy_again, mag, 5.0)
            assert h < 1.5 and v < 1.0, f"mag off: drift {h:.1f} m, {v:.1f} m"
            h, v = _fault_then_ok(client, truth, MAG, STUCK, "EKF: magnetometer stuck", healthy_again, mag, 3.0)
            assert h < 1.5 and v < 1.0, f"mag stuck: drift {h:.1f} m, {v:.1f} m"
            baro = SENSOR["baro"]
            for ftype, detected in ((STUCK, "Barometer failed: stale data"), (OFF, "Barometer failed: no data")):
                h, v = _fault_then_ok(client, truth, BARO, ftype, detected, "Barometer healthy again", baro, 5.0)
                assert h < 1.5 and v < 1.0, f"baro {ftype}: drift {h:.1f} m, {v:.1f} m"

    def test_an_empty_battery_lands_by_the_low_battery_failsafe(self, sensor_stack):
        """FAILURE_UNIT_SYSTEM_BATTERY OFF: the battery monitor reads an empty pack, as in PX4's SITL; with
        COM_LOW_BAT_ACT 3 the emergency level lands where the vehicle is.  OK: the real charge again."""
        stack, truth = sensor_stack
        with client_of(stack) as client:
            client.param_set("COM_LOW_BAT_ACT", 3)
            point = truth.latest()
            n = len(client.statustexts)
            assert inject(client, BATTERY, OFF).result == mavlink.MAV_RESULT_ACCEPTED
            wait_text(client, n, "Emergency battery (0% left): landing")
            client.wait_until(client.landed_and_disarmed, WAIT_S, "landed and disarmed")
            assert horizontal(truth.latest().pos_ned_m, point.pos_ned_m) < 2.0
            assert inject(client, BATTERY, OK).result == mavlink.MAV_RESULT_ACCEPTED
            client.wait_until(lambda: (client.battery()[1] or 0) > 50, WAIT_S, "the real charge again")

    # the IMU, on the vehicle the battery failsafe landed
    def test_a_gyro_off_on_the_ground_refuses_arming_until_it_is_back(self, sensor_stack):
        stack, truth = sensor_stack
        with client_of(stack) as client:
            client.param_set("SYS_FAILURE_EN", 1)
            client.wait_until(client.prearm_ok, WAIT_S, "ready to arm")
            n = len(client.statustexts)
            assert inject(client, GYRO, OFF).result == mavlink.MAV_RESULT_ACCEPTED
            wait_text(client, n, "Gyro failed: no data")
            client.wait_until(lambda: not healthy(client, SENSOR["gyro"]), WAIT_S, "gyro unhealthy in SYS_STATUS")
            refused = client.arm()
            assert not refused.accepted and "Gyro failed: no data" in (refused.reason or ""), refused.describe()
            assert inject(client, GYRO, OK).result == mavlink.MAV_RESULT_ACCEPTED
            wait_text(client, n, "Gyro healthy again")
            client.wait_until(client.prearm_ok, WAIT_S, "ready to arm again")

    def test_a_stuck_accelerometer_in_flight_is_found_and_the_vehicle_comes_down_where_it_was(self, sensor_stack):
        """A single IMU repeating itself: the estimator declares it failed (PX4's STALE check), the attitude
        can no longer be trusted and the attitude failsafe descends; nothing flies away."""
        stack, truth = sensor_stack
        with client_of(stack) as client:
            hold = take_off(client, truth)
            n = len(client.statustexts)
            assert inject(client, ACCEL, STUCK).result == mavlink.MAV_RESULT_ACCEPTED
            wait_text(client, n, "Accelerometer failed: stale data")
            wait_text(client, n, "Attitude estimate lost: descending")
            client.wait_until(lambda: truth.latest().pos_ned_m[2] > -0.5, WAIT_S, "on the ground")
            down = truth.since(hold.time_ms)
            assert max(horizontal(s.pos_ned_m, hold.pos_ned_m) for s in down) < NO_FLY_AWAY_M
            assert min(s.pos_ned_m[2] for s in down) > hold.pos_ned_m[2] - 1.0, "it climbed"
            assert inject(client, ACCEL, OK).result == mavlink.MAV_RESULT_ACCEPTED
            if client.armed():
                client.disarm(force=True).check()


class TestHexacopter:
    """One stack: the Firefly with a motor off."""

    def test_the_hexacopter_survives_a_motor_off_and_lands_where_it_was(self, hexa_stack):
        """The Firefly with motor 1 off: the five others cannot balance the rotors' drag torque, so the heading
        is given up (the mixer keeps roll, pitch and thrust first) and it spins at some 250-300 deg/s, but it
        holds its position and height, and on LAND comes down under control where it was.  Spinning that
        fast, the land detector may not see the touchdown, so it is disarmed with the force flag, as a pilot
        would, before the motor is restored (a motor restarted under a spinning vehicle on the ground can
        tip it over)."""
        stack, truth = hexa_stack
        with client_of(stack) as client:
            client.param_set("SYS_FAILURE_EN", 1)
            hold = take_off(client, truth)
            assert inject(client, MOTOR, OFF, 1).result == mavlink.MAV_RESULT_ACCEPTED
            client.wait_sim_time(8.0)
            h, v = drift_m(truth, hold)
            assert h < 3.0 and v < 1.5, f"drift {h:.1f} m, {v:.1f} m with a motor off"
            assert abs(math.degrees(client.latest("ATTITUDE").yawspeed)) > 90  # the heading is given up
            t0 = truth.latest().time_ms
            client.land().check()
            client.wait_until(lambda: truth.latest().pos_ned_m[2] > -0.5, WAIT_S, "touchdown")
            fastest = max(s.vel_ned_m_s[2] for s in truth.since(t0))
            assert fastest < 2.5, f"fell at {fastest:.1f} m/s"  # a controlled descent: MPC_LAND_SPEED plus margin
            assert horizontal(truth.latest().pos_ned_m, hold.pos_ned_m) < 3.0
            client.wait_sim_time(3.0)
            if client.armed():
                client.disarm(force=True).check()  # spinning at touchdown, the land detector may not see it
            assert inject(client, MOTOR, OK, 1).result == mavlink.MAV_RESULT_ACCEPTED
