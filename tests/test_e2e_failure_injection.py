"""End-to-end: MAV_CMD_INJECT_FAILURE against the real stack, each fault with the reaction a user expects.

Real ``sitl`` and ``autopilot`` processes (``--speed max``); a pymavlink ground station
(:class:`gcs.client.VehicleClient` on the stack's own ground-station port) sends the command; the
flight controller sets the simulator's fault parameters over the simulator link and is told nothing
else: its estimator and commander find the fault in the sensors.  Checks are what a user checks:
the COMMAND_ACK, the STATUSTEXTs, SYS_STATUS health bits, the mode, and where the vehicle truly went
(the simulator's truth, :class:`gcs.sim_client.SimClient`).  MAVSDK's Failure plugin, a client in wall
time: tests/test_e2e_failure_injection_mavsdk.py.  Two stacks, one per class:

* the quadcopter flown by pymavlink in simulated time (``SteppedFlight``, tests/e2e_flight_helpers.py:
  every command between two steps, so every figure is the same in every run): the gating and the
  refusals, the GPS off and stuck, the magnetometer and barometer in one flight, the battery, then on
  the vehicle the battery failsafe landed the IMU (on the ground, then in flight), and last a motor off
  (the quadcopter falls);
* the hexacopter losing a motor, in simulated time (it may end on its side: last on its stack).

Wall-clock timeouts are safety nets only.
"""

from __future__ import annotations

import math

import pytest

from gcs.client import VehicleClient, mavlink

from e2e_flight_helpers import (  # tests/e2e_flight_helpers.py
    SteppedFlight,
    horizontal,
    record_figure,
    stepped_flight_fixture,
    texts_since,
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
    "gps": mavlink.MAV_SYS_STATUS_SENSOR_GPS,
}


quad = stepped_flight_fixture(scope="class")  # TestQuadcopter (tests/e2e_flight_helpers.py)
hexa = stepped_flight_fixture(vehicle="firefly", scope="class")  # TestHexacopter


def inject(client: VehicleClient, unit: int, ftype: int, inst: int = 0):
    return client.command_long(INJECT, unit, ftype, inst, 0, 0, 0, 0)


def healthy(client: VehicleClient, bit: int) -> bool:
    return bool(client.latest("SYS_STATUS").onboard_control_sensors_health & bit)


def landed(f: SteppedFlight, max_s: float = 60.0) -> None:
    f.until(f.client.landed_and_disarmed, max_s, "landed and disarmed", every_s=0.5)


def on_ground(f: SteppedFlight, max_s: float = 60.0, every_s: float = 0.1) -> None:
    f.until(lambda: f.truth_now().pos_ned_m[2] > -0.5, max_s, "on the ground", every_s=every_s)


def drift_m(f: SteppedFlight, since) -> tuple[float, float]:
    """(worst horizontal, worst vertical) distance of the true vehicle from a truth sample, since it, m."""
    later = f.truth_since(since.time_ms)
    p = since.pos_ned_m
    return max(horizontal(s.pos_ned_m, p) for s in later), max(abs(s.pos_ned_m[2] - p[2]) for s in later)


def fault_then_ok(f: SteppedFlight, label: str, unit, ftype, detected: str, recovered: str, bit: int, hold_s: float):
    """Inject, wait for the flight controller's own report, hold ``hold_s``, clear, wait for the recovery;
    the worst horizontal and vertical drift from the point held when the fault came, as figures."""
    client = f.client
    n = len(client.statustexts)
    point = f.truth_now()
    assert inject(client, unit, ftype).result == mavlink.MAV_RESULT_ACCEPTED
    f.text_seen(n, detected, 10.0)
    f.until(lambda: not healthy(client, bit), 2.0, f"SYS_STATUS unhealthy after {detected!r}", every_s=0.25)
    f.wait(hold_s)
    h, v = drift_m(f, point)
    assert client.mode_name() == "LOITER" and client.armed(), texts_since(client, n)
    assert inject(client, unit, OK).result == mavlink.MAV_RESULT_ACCEPTED
    f.text_seen(n, recovered, 10.0, every_s=0.5)
    f.until(lambda: healthy(client, bit), 2.0, f"healthy after {recovered!r}", every_s=0.25)
    record_figure(f"inject_{label}_drift_m", h, 1.5, unit="m")
    record_figure(f"inject_{label}_vertical_m", v, 1.0, unit="m")


class TestQuadcopter:
    """One stack in simulated time: the gating, the refusals, the GPS, magnetometer, barometer, battery, the IMU
    (on the ground, in flight) and a motor off (last: the quadcopter falls)."""

    def test_disabled_by_default_denied_with_the_reason(self, quad):
        f = quad
        client = f.client
        assert client.param_get("SYS_FAILURE_EN") == 0  # PX4's default
        ack = inject(client, GPS, OFF)
        assert ack.result == mavlink.MAV_RESULT_DENIED
        assert ack.reason == "Failure injection disabled: set SYS_FAILURE_EN to 1"
        f.wait(1.0)
        assert client.gps()[0] >= 3, "the GPS still works"
        client.param_set("SYS_FAILURE_EN", 1)  # enabled for the rest of the class

    def test_refusals_name_what_the_simulator_cannot_do(self, quad):
        client = quad.client
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

    def test_gps_off_in_loiter_lands_where_it_is_and_ok_restores_it(self, quad):
        """The figures of MAVSDK's GPS loss (TestMavsdk), in simulated time: a position lost in LOITER lands on
        the height estimate where the vehicle is (no fly-away in the truth); FAILURE_TYPE_OK 2.5 s into the
        descent brings the GPS back and the landing goes on."""
        f = quad
        client = f.client
        hold = f.take_off(ALT_M, settle_s=3.0)
        n = len(client.statustexts)
        assert inject(client, GPS, OFF).result == mavlink.MAV_RESULT_ACCEPTED
        f.until(lambda: client.mode_name() == "LAND", 10.0, "LAND after the GPS loss")
        f.wait(2.5)  # descending without GPS
        worst_h = drift_m(f, hold)[0]
        descended = f.truth_now().pos_ned_m[2] - hold.pos_ned_m[2]
        assert not healthy(client, SENSOR["gps"])
        assert inject(client, GPS, OK).result == mavlink.MAV_RESULT_ACCEPTED
        f.text_seen(n, "Position estimate regained", 10.0)
        landed(f)
        texts = texts_since(client, n)
        record_figure("inject_gps_off_drift_m", worst_h, NO_FLY_AWAY_M, unit="m")
        record_figure("inject_gps_off_descent_m", descended, 0.5, below=False, unit="m")
        landed_m = horizontal(f.truth_now().pos_ned_m, hold.pos_ned_m)
        record_figure("inject_gps_off_landed_from_hold_m", landed_m, NO_FLY_AWAY_M, unit="m")
        assert "Failure injected: GPS off" in texts and "Failure cleared: GPS" in texts
        assert "Position estimate lost: landing" in texts

    def test_a_stuck_gps_is_found_and_the_vehicle_lands_where_it_was(self, quad):
        """A frozen receiver (its fixes repeat exactly) is not fused (PX4's STALE rule): the position times
        out and the position-loss failsafe lands, without flying after the frozen velocity."""
        f = quad
        client = f.client
        hold = f.take_off(ALT_M)
        n = len(client.statustexts)
        try:
            assert inject(client, GPS, STUCK).result == mavlink.MAV_RESULT_ACCEPTED
            f.text_seen(n, "GPS failed: stale data", 10.0)
            f.text_seen(n, "Position estimate lost: landing", 20.0)
            landed(f)
            print(f"stuck GPS: {texts_since(client, n)}")
            record_figure("inject_stuck_gps_drift_m", drift_m(f, hold)[0], NO_FLY_AWAY_M, unit="m")
        finally:
            assert inject(client, GPS, OK).result == mavlink.MAV_RESULT_ACCEPTED
        f.text_seen(n, "GPS healthy again", 10.0)
        f.text_seen(n, "Position estimate regained", 10.0)  # (before the next take-off)

    def test_magnetometer_and_barometer_faults_in_flight_are_found_and_the_vehicle_holds(self, quad):
        f = quad
        f.take_off(ALT_M)
        mag, mag_back = SENSOR["mag"], "magnetometer healthy again"
        fault_then_ok(f, "mag_off", MAG, OFF, "EKF: no magnetometer data", mag_back, mag, 5.0)
        fault_then_ok(f, "mag_stuck", MAG, STUCK, "EKF: magnetometer stuck", mag_back, mag, 3.0)
        baro, baro_back = SENSOR["baro"], "Barometer healthy again"
        fault_then_ok(f, "baro_stuck", BARO, STUCK, "Barometer failed: stale data", baro_back, baro, 5.0)
        fault_then_ok(f, "baro_off", BARO, OFF, "Barometer failed: no data", baro_back, baro, 5.0)

    def test_an_empty_battery_lands_by_the_low_battery_failsafe(self, quad):
        """FAILURE_UNIT_SYSTEM_BATTERY OFF: the battery monitor reads an empty pack, as in PX4's SITL; with
        COM_LOW_BAT_ACT 3 the emergency level lands where the vehicle is.  OK: the real charge again."""
        f = quad
        client = f.client
        client.param_set("COM_LOW_BAT_ACT", 3)
        point = f.take_off(ALT_M)  # (still hovering after the magnetometer and barometer faults)
        n = len(client.statustexts)
        assert inject(client, BATTERY, OFF).result == mavlink.MAV_RESULT_ACCEPTED
        f.text_seen(n, "Emergency battery (0% left): landing", 10.0)
        landed(f)
        record_figure(
            "inject_empty_battery_landed_from_point_m",
            horizontal(f.truth_now().pos_ned_m, point.pos_ned_m),
            2.0,
            unit="m",
        )
        assert inject(client, BATTERY, OK).result == mavlink.MAV_RESULT_ACCEPTED
        f.until(lambda: (client.battery()[1] or 0) > 50, 10.0, "the real charge again")

    # the IMU, on the vehicle the battery failsafe landed
    def test_a_gyro_off_on_the_ground_refuses_arming_until_it_is_back(self, quad):
        f = quad
        client = f.client
        f.ready()
        n = len(client.statustexts)
        assert inject(client, GYRO, OFF).result == mavlink.MAV_RESULT_ACCEPTED
        f.text_seen(n, "Gyro failed: no data", 10.0)
        f.until(lambda: not healthy(client, SENSOR["gyro"]), 2.0, "gyro unhealthy in SYS_STATUS")
        refused = client.arm()
        assert not refused.accepted and "Gyro failed: no data" in (refused.reason or ""), refused.describe()
        assert inject(client, GYRO, OK).result == mavlink.MAV_RESULT_ACCEPTED
        f.text_seen(n, "Gyro healthy again", 10.0)
        f.until(client.prearm_ok, 10.0, "ready to arm again")

    def test_a_stuck_accelerometer_in_flight_is_found_and_the_vehicle_comes_down_where_it_was(self, quad):
        """A single IMU repeating itself: the estimator declares it failed (PX4's STALE check), the attitude
        can no longer be trusted and the attitude failsafe descends; nothing flies away."""
        f = quad
        client = f.client
        hold = f.take_off(ALT_M)
        n = len(client.statustexts)
        assert inject(client, ACCEL, STUCK).result == mavlink.MAV_RESULT_ACCEPTED
        f.text_seen(n, "Accelerometer failed: stale data", 10.0)
        f.text_seen(n, "Attitude estimate lost: descending", 10.0)
        on_ground(f)
        down = f.truth_since(hold.time_ms)
        worst = max(horizontal(s.pos_ned_m, hold.pos_ned_m) for s in down)
        record_figure("inject_stuck_accel_drift_m", worst, NO_FLY_AWAY_M, unit="m")
        climbed = hold.pos_ned_m[2] - min(s.pos_ned_m[2] for s in down)  # m above the hover point (NED: up is -)
        record_figure("inject_stuck_accel_climb_m", climbed, 1.0, unit="m")
        assert inject(client, ACCEL, OK).result == mavlink.MAV_RESULT_ACCEPTED
        if client.armed():
            client.disarm(force=True).check()
        f.text_seen(n, "Accelerometer healthy again", 10.0)  # (before the next take-off)

    def test_a_quadcopter_with_a_motor_off_falls_where_it_was(self, quad):
        """Three rotors cannot hold a quadcopter: it falls, near where it was (no fly-away).  The failure
        detector (FD_FAIL_R/FD_FAIL_P) reports it and the crash check disarms the wreck
        (test_e2e_failure_detection); here a forced disarm at touchdown comes before the crash check's 2 s."""
        f = quad
        client = f.client
        hold = f.take_off(ALT_M)
        assert inject(client, MOTOR, OFF, 1).result == mavlink.MAV_RESULT_ACCEPTED
        on_ground(f, 20.0, every_s=0.05)
        fall = f.truth_since(hold.time_ms)
        record_figure(
            "inject_quad_motor_off_fall_speed_m_s", max(s.vel_ned_m_s[2] for s in fall), 3.0, below=False, unit="m/s"
        )
        record_figure(
            "inject_quad_motor_off_drift_m", max(horizontal(s.pos_ned_m, hold.pos_ned_m) for s in fall), 5.0, unit="m"
        )
        client.disarm(force=True).check()
        assert inject(client, MOTOR, OK, 1).result == mavlink.MAV_RESULT_ACCEPTED


# ------------------------------------------------------------------- the hexacopter, in simulated time


class TestHexacopter:
    """One stack in simulated time: the Firefly with a motor off."""

    def test_the_hexacopter_survives_a_motor_off_and_lands_where_it_was(self, hexa):
        """The Firefly with motor 1 off: the five others cannot balance the rotors' drag torque, so the heading
        is given up (the mixer keeps roll, pitch and thrust first) and it spins at some 250-300 deg/s, but it
        holds its position and height, and on LAND comes down under control where it was.  Spinning that
        fast, the land detector may not see the touchdown, so it is disarmed with the force flag, as a pilot
        would, before the motor is restored (a motor restarted under a spinning vehicle on the ground can
        tip it over)."""
        f = hexa
        client = f.client
        client.param_set("SYS_FAILURE_EN", 1)
        hold = f.take_off(ALT_M)
        assert inject(client, MOTOR, OFF, 1).result == mavlink.MAV_RESULT_ACCEPTED
        f.wait(8.0)
        h, v = drift_m(f, hold)
        record_figure("inject_hexa_motor_off_drift_m", h, 3.0, unit="m")
        record_figure("inject_hexa_motor_off_vertical_m", v, 1.5, unit="m")
        yaw_rate = abs(math.degrees(client.latest("ATTITUDE").yawspeed))
        record_figure("inject_hexa_motor_off_yaw_rate_deg_s", yaw_rate, 90.0, below=False, unit="deg/s")  # given up
        t0 = f.now_ms
        client.land().check()
        on_ground(f, 30.0)
        fastest = max(s.vel_ned_m_s[2] for s in f.truth_since(t0))
        record_figure("inject_hexa_landing_descent_speed_m_s", fastest, 2.5, unit="m/s")  # MPC_LAND_SPEED + margin
        record_figure(
            "inject_hexa_landed_from_hold_m", horizontal(f.truth_now().pos_ned_m, hold.pos_ned_m), 3.0, unit="m"
        )
        f.wait(3.0)
        if client.armed():
            client.disarm(force=True).check()  # spinning at touchdown, the land detector may not see it
        assert inject(client, MOTOR, OK, 1).result == mavlink.MAV_RESULT_ACCEPTED
        f.until(lambda: not client.armed(), 1.0, "disarmed")
