"""Failure injection: the table (unit/type/instance -> SIM_* values), the simulator's sensor faults, and
the bridge: MAV_CMD_INJECT_FAILURE handled by the flight controller's service, which sets the simulator's
parameters over a real lockstep TCP link to a real simulator (``sitl.lockstep.LockstepServer`` with its
MuJoCo simulation in a thread), while the test drives the flight controller's side of the lockstep.
"""

from __future__ import annotations

import math
import socket
import threading

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink import failure_table as ft
from autopilot.mavlink.failure_injection import FailureInjection, SimParamBridge
from autopilot.mavlink.sim_link import SimLink, imu_from_msg
from autopilot.param_catalogue import default_store
from params.vehicle import load_vehicle
from sitl.sensor_faults import ACCEL_FIELDS, ALL_FIELDS, BARO_FIELDS, GYRO_RANGE_RAD_S, hil_sensor_fields
from sitl.sensors import SensorSuite
from sitl.sim_params import SimParameters
from sitl.sim_settings import CameraSettings, MotorSettings, SensorSettings, UgvSettings, WindSettings

ACCEPTED, DENIED, UNSUPPORTED, FAILED = (
    mavlink.MAV_RESULT_ACCEPTED,
    mavlink.MAV_RESULT_DENIED,
    mavlink.MAV_RESULT_UNSUPPORTED,
    mavlink.MAV_RESULT_FAILED,
)
HOME = (47.397742, 8.545594, 488.0)


# --------------------------------------------------------------------------- the table


def test_each_unit_and_type_maps_to_its_sim_parameters():
    gps_off = ft.resolve(ft.GPS, ft.OFF, 0, 4)
    assert isinstance(gps_off, ft.Fault)
    assert gps_off.values == {"SIM_GPS_DISABLE": 1} and gps_off.label == "GPS off"
    assert gps_off.flags == {"SIM_GPS_DISABLE": 0, "SIM_GPS_STUCK": 0} and gps_off.settings == []
    slow = ft.resolve(ft.GPS, ft.SLOW, 1, 4)
    assert slow.values == {"SIM_GPS_HZ": 1.0} and slow.settings == ["SIM_GPS_HZ"]
    assert ft.resolve(ft.GPS, ft.INTERMITTENT, 0, 4).values == {"SIM_GPS_DROP_RT": 12.0, "SIM_GPS_DROP_S": 1.0}
    assert ft.resolve(ft.ACCEL, ft.GARBAGE, 0, 4).values == {"SIM_ACC_GARBAGE": 1}
    assert ft.resolve(ft.GYRO, ft.STUCK, 0, 4).values == {"SIM_GYR_STUCK": 1}
    assert ft.resolve(ft.MAG, ft.STUCK, 0, 4).values == {"SIM_MAG_STUCK": 1}
    assert ft.resolve(ft.BARO, ft.OFF, 0, 4).values == {"SIM_BARO_OFF": 1}
    assert ft.resolve(ft.BATTERY, ft.OFF, 0, 4).values == {"SIM_BAT_EMPTY": 1}
    motor = ft.resolve(ft.MOTOR, ft.OFF, 3, 6)
    assert motor.values == {"SIM_ENGINE_FAIL": 3, "SIM_ENGINE_MUL": 0.0} and motor.label == "motor 3 off"
    assert motor.settings == ["SIM_ENGINE_MUL"]
    assert ft.resolve(ft.MOTOR, ft.WRONG, 1, 4).values == {"SIM_ENGINE_FAIL": 1, "SIM_ENGINE_MUL": 0.5}
    ok = ft.resolve(ft.GPS, ft.OK, 0, 4)
    assert ok.values == {} and ok.flags == ft.FLAGS[ft.GPS] and ok.label == "GPS"
    assert ft.resolve(ft.MOTOR, ft.OK, 0, 4).flags == {"SIM_ENGINE_FAIL": 0}  # OK of all motors clears


@pytest.mark.parametrize(
    "unit, ftype, instance, n, result, words",
    [
        (ft.GPS, ft.GARBAGE, 0, 4, UNSUPPORTED, "GPS garbage is not supported"),
        (ft.BARO, ft.SLOW, 0, 4, UNSUPPORTED, "barometer slow"),
        (mavlink.FAILURE_UNIT_SENSOR_AIRSPEED, ft.OFF, 0, 4, UNSUPPORTED, "airspeed off"),
        (mavlink.FAILURE_UNIT_SENSOR_AIRSPEED, ft.OK, 0, 4, UNSUPPORTED, "airspeed ok"),
        (mavlink.FAILURE_UNIT_SYSTEM_RC_SIGNAL, ft.OFF, 0, 4, UNSUPPORTED, "RC signal"),
        (ft.MOTOR, ft.OFF, 0, 4, UNSUPPORTED, "one motor"),
        (ft.MOTOR, ft.STUCK, 1, 4, UNSUPPORTED, "motor stuck"),
        (ft.MOTOR, ft.OFF, 5, 4, DENIED, "no motor 5: the vehicle has 4"),
        (ft.GPS, ft.OFF, 2, 4, DENIED, "no GPS 2: the vehicle has 1"),
        (42, ft.OFF, 0, 4, DENIED, "unknown failure unit 42"),
        (ft.GPS, 9, 0, 4, DENIED, "unknown failure type 9"),
        (ft.GPS, ft.OFF, math.nan, 4, DENIED, "bad instance"),
        (ft.GPS, ft.OFF, -3, 4, DENIED, "bad instance"),
    ],
)
def test_what_the_simulator_cannot_produce_is_refused_with_a_reason(unit, ftype, instance, n, result, words):
    refusal = ft.resolve(unit, ftype, instance, n)
    assert isinstance(refusal, ft.Refusal)
    assert refusal.result == result and words in refusal.reason


def test_every_value_in_the_table_is_a_valid_simulator_parameter_value():
    params = SimParameters(WindSettings(), SensorSettings(), MotorSettings(), UgvSettings(), CameraSettings())
    for unit, flags in ft.FLAGS.items():
        for name, healthy in flags.items():
            assert params.validate(name, healthy) == params.param(name).default, name  # healthy = the default
    for (unit, ftype), values in ft.FAULTS.items():
        fault = ft.resolve(unit, ftype, 1, 6)
        assert isinstance(fault, ft.Fault)
        for name, value in fault.values.items():
            params.validate(name, value)  # raises if the simulator would refuse it


# --------------------------------------------------------------------------- the simulator's faults


def _imu(suite: SensorSuite, n: int = 1):
    r = np.eye(3)
    return [suite.imu((0.0, 0.0, -9.81), (0.1, 0.0, 0.0), r, (0.0, 0.0, -5.0), 0.004) for _ in range(n)][-1]


def test_a_sensor_off_reads_nan_and_clears_its_hil_sensor_bits():
    s = SensorSettings()
    suite = SensorSuite(*HOME, seed=3, settings=s)
    healthy = _imu(suite)
    assert hil_sensor_fields(healthy.accel_frd_m_s2[0], healthy.gyro_frd_rad_s[0], healthy.mag_frd_gauss[0],
                             healthy.pressure_hpa) == ALL_FIELDS  # fmt: skip
    s.accel_off = s.baro_off = 1
    off = _imu(suite)
    assert all(math.isnan(x) for x in off.accel_frd_m_s2) and math.isnan(off.pressure_hpa)
    assert not any(math.isnan(x) for x in off.gyro_frd_rad_s + off.mag_frd_gauss)
    fields = hil_sensor_fields(off.accel_frd_m_s2[0], off.gyro_frd_rad_s[0], off.mag_frd_gauss[0], off.pressure_hpa)
    assert fields == ALL_FIELDS & ~ACCEL_FIELDS & ~BARO_FIELDS
    # ... and the flight controller's side reads those fields as missing (NaN)
    msg = mavlink.MAVLink_hil_sensor_message(1000, *([1.0] * 9), 950.0, 0.0, 500.0, 20.0, fields, 0)
    sample = imu_from_msg(msg)
    assert np.isnan(sample.accel_frd_m_s2).all() and math.isnan(sample.pressure_hpa)
    assert np.isfinite(sample.gyro_frd_rad_s).all() and np.isfinite(sample.mag_frd_gauss).all()


def test_stuck_repeats_the_last_reading_and_garbage_is_random_within_range():
    s = SensorSettings()
    suite = SensorSuite(*HOME, seed=3, settings=s)
    last = _imu(suite)
    s.gyro_stuck = s.mag_stuck = s.baro_stuck = 1
    stuck = [_imu(suite) for _ in range(5)]
    assert all(r.gyro_frd_rad_s == last.gyro_frd_rad_s and r.mag_frd_gauss == last.mag_frd_gauss for r in stuck)
    assert all(r.pressure_hpa == last.pressure_hpa for r in stuck)
    assert len({r.accel_frd_m_s2 for r in stuck}) == 5  # the accelerometer still lives
    s.gyro_garbage = 1  # garbage wins over stuck
    garbage = [_imu(suite).gyro_frd_rad_s for _ in range(50)]
    assert len(set(garbage)) == 50 and max(abs(x) for g in garbage for x in g) <= GYRO_RANGE_RAD_S
    assert max(abs(x) for g in garbage for x in g) > 5.0  # not a healthy gyro at 0.1 rad/s
    s.gyro_stuck = s.gyro_garbage = s.mag_stuck = s.baro_stuck = 0
    assert abs(_imu(suite).gyro_frd_rad_s[0] - 0.1) < 0.05


def test_a_fault_changes_no_other_sensors_noise():
    a, b = SensorSettings(), SensorSettings()
    b.gyro_garbage, b.mag_off = 1, 1
    sa, sb = SensorSuite(*HOME, seed=5, settings=a), SensorSuite(*HOME, seed=5, settings=b)
    for _ in range(20):
        ra, rb = _imu(sa), _imu(sb)
        assert ra.accel_frd_m_s2 == rb.accel_frd_m_s2 and ra.pressure_hpa == rb.pressure_hpa


def test_a_stuck_gps_repeats_its_last_fix():
    s = SensorSettings()
    suite = SensorSuite(*HOME, seed=3, settings=s)
    fixes = [suite.gps(t, (t * 1e-6, 0.0, -5.0), (1.0, 0.0, 0.0)) for t in range(0, 1_000_000, 4000)]
    fixes = [f for f in fixes if f is not None]
    s.gps_stuck = 1
    later = [suite.gps(t, (t * 1e-6, 0.0, -5.0), (1.0, 0.0, 0.0)) for t in range(1_000_000, 2_000_000, 4000)]
    later = [f for f in later if f is not None]
    assert len(later) == 5 and all(f == fixes[-1] for f in later)


# --------------------------------------------------------------------------- the bridge over a real lockstep link


class LockstepPair:
    """A real simulator (LockstepServer, quad_x) in a thread and the flight controller's SimLink, driven by hand:
    :meth:`step` answers HIL_SENSOR periods with zero motor commands, as the process loop does."""

    def __init__(self) -> None:
        from sitl.lockstep import LockstepServer
        from sitl.simulation import Simulation

        self.sim = Simulation(load_vehicle("quad_x"), HOME, seed=1)
        self.server = LockstepServer(self.sim, 0, None, None)  # any free port, no truth, no pacing
        port = self.server.listener.getsockname()[1]
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()
        self.link = SimLink("127.0.0.1", port, sysid=1)
        self.link.connect()
        self.sensor_times: list[int] = []
        self.last_sensor = None
        self.latest: dict[str, object] = {}  # the latest message of each type from the simulator

    def _run(self) -> None:
        try:
            self.server.run(duration_s=60.0)
        except (OSError, ValueError):
            pass  # the test closed the link, then the listening socket

    def step(self, n: int = 1) -> None:
        done = 0
        while done < n:
            msgs = self.link.receive(timeout_s=10.0)
            assert msgs is not None, "the simulator closed the link"
            for m in msgs:
                self.latest[m.get_type()] = m
                if m.get_type() == "HIL_SENSOR":
                    self.sensor_times.append(m.time_usec)
                    self.last_sensor = m
                    self.link.send_actuators(m.time_usec, np.zeros(4), False)
                    done += 1

    def close(self) -> None:
        self.link.sock.close()
        self.server.close()  # its thread, waiting for a flight controller again, ends
        self.thread.join(10.0)


@pytest.fixture
def pair():
    p = LockstepPair()
    yield p
    p.close()


def service(link: SimLink, enabled: int = 1, timeout_s: float = 2.0):
    params = default_store()
    params.set("SYS_FAILURE_EN", enabled)
    said: list[tuple[int, str]] = []
    svc = FailureInjection(params, SimParamBridge(link, timeout_s), 4, lambda sev, text: said.append((sev, text)))
    command = svc.commands()[mavlink.MAV_CMD_INJECT_FAILURE]
    return (lambda unit, ftype, inst=0: command(None, (unit, ftype, inst, 0, 0, 0, 0), 0)), said


def test_disabled_by_default_denied_with_the_reason(pair):
    inject, said = service(pair.link, enabled=0)
    assert default_store().get("SYS_FAILURE_EN") == 0  # PX4's default
    assert inject(ft.GPS, ft.OFF) == DENIED
    assert said == [(mavlink.MAV_SEVERITY_WARNING, "Failure injection disabled: set SYS_FAILURE_EN to 1")]
    assert pair.sim.sensors.settings.gps_disable == 0


def test_injection_sets_the_simulator_between_steps_and_ok_restores(pair):
    inject, said = service(pair.link)
    s, motors = pair.sim.sensors.settings, pair.sim.motor_settings
    pair.step(5)
    assert pair.last_sensor.fields_updated == ALL_FIELDS
    assert inject(ft.ACCEL, ft.OFF) == ACCEPTED  # between two steps, as the process loop calls it
    assert s.accel_off == 1 and said[-1] == (mavlink.MAV_SEVERITY_INFO, "Failure injected: accelerometer off")
    pair.step(2)  # the period already sent was measured before; the next is without the accelerometer
    assert pair.last_sensor.fields_updated == ALL_FIELDS & ~ACCEL_FIELDS
    assert inject(ft.ACCEL, ft.STUCK) == ACCEPTED  # replaces the previous fault of the unit
    assert (s.accel_off, s.accel_stuck) == (0, 1)
    assert inject(ft.ACCEL, ft.OK) == ACCEPTED and (s.accel_off, s.accel_stuck) == (0, 0)
    assert said[-1][1] == "Failure cleared: accelerometer"
    # settings the fault changes come back to what they were before, not to the defaults
    s.gps_rate_hz, motors.fail_efficiency = 10.0, 0.8
    assert inject(ft.GPS, ft.SLOW) == ACCEPTED and s.gps_rate_hz == 1.0
    assert inject(ft.GPS, ft.INTERMITTENT) == ACCEPTED and s.gps_rate_hz == 10.0 and s.gps_dropout_per_min == 12
    assert inject(ft.GPS, ft.OK) == ACCEPTED and (s.gps_rate_hz, s.gps_dropout_per_min, s.gps_dropout_s) == (10, 0, 1)
    assert inject(ft.MOTOR, ft.OFF, 2) == ACCEPTED and (motors.fail_motor, motors.fail_efficiency) == (2, 0.0)
    assert inject(ft.MOTOR, ft.OK, 2) == ACCEPTED
    assert (motors.fail_motor, motors.fail_efficiency) == (0, pytest.approx(0.8))  # (as a float32 carries it)
    pair.step(5)
    # the lockstep went on undisturbed: one HIL_SENSOR every 4 ms, none lost or repeated
    assert np.all(np.diff(pair.sensor_times) == 4000)


def test_battery_off_reads_an_empty_pack_until_ok(pair):
    inject, said = service(pair.link)
    pair.step(60)  # BATTERY_STATUS at 5 Hz
    assert pair.latest["BATTERY_STATUS"].battery_remaining == 100
    assert inject(ft.BATTERY, ft.OFF) == ACCEPTED
    pair.step(60)
    empty = pair.latest["BATTERY_STATUS"]
    assert empty.battery_remaining == 0 and empty.voltages[0] == 3300  # mV: a cell at 0 %
    assert pair.sim.battery.remaining_frac > 0.99  # the pack itself is full: only the monitor reads empty
    assert inject(ft.BATTERY, ft.OK) == ACCEPTED
    pair.step(60)
    assert pair.latest["BATTERY_STATUS"].battery_remaining == 100


def test_refusals_say_why_and_change_nothing(pair):
    inject, said = service(pair.link)
    pair.step(1)
    assert inject(ft.GPS, ft.GARBAGE) == UNSUPPORTED
    assert said[-1] == (mavlink.MAV_SEVERITY_WARNING, "Failure injection: GPS garbage is not supported in simulation")
    assert inject(ft.MOTOR, ft.OFF, 7) == DENIED and "no motor 7" in said[-1][1]
    assert pair.sim.motor_settings.fail_motor == 0


def test_no_answer_from_the_simulator_fails():
    listener = socket.create_server(("127.0.0.1", 0))  # accepts the link but never answers
    link = SimLink("127.0.0.1", listener.getsockname()[1])
    link.connect()
    try:
        inject, said = service(link, timeout_s=0.2)
        assert inject(ft.BARO, ft.OFF) == FAILED
        assert "failed" in said[-1][1] and "no answer from the simulator" in said[-1][1]
    finally:
        link.sock.close()
        listener.close()
    unconnected = SimLink("127.0.0.1", 1)  # before the simulator is there (the process loop's on_wait)
    inject, said = service(unconnected)
    assert inject(ft.GPS, ft.OFF) == FAILED
