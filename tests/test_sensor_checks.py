"""The estimator's sensor checks (PX4's DataValidator TIMEOUT and STALE rules) on synthetic sensor data:
a gyro, accelerometer or barometer without data or repeating itself is declared failed, and a GPS whose
fixes repeat exactly is not fused; what the estimator then publishes (attitude validity, pre-arm
failures, SYS_STATUS health bits) and the recovery.  The faults are applied to the samples the
synthetic generator of ``test_estimators.py`` produces, as the simulator's SIM_* faults would.
"""

from __future__ import annotations

import dataclasses

import numpy as np
from pymavlink.dialects.v20 import common as mavlink
from test_estimators import make

from autopilot.commander.health import sensors_health
from autopilot.estimation.sensor_checks import RECOVER_S, STALE_S, TIMEOUT_S
from autopilot.topics import GpsSample, ImuSample

NAN3 = np.full(3, np.nan)


class Faulty:
    """Stands for the estimator in the generator: the samples go through ``imu_fault`` / ``gps_fault``."""

    def __init__(self, est) -> None:
        self.est = est
        self.imu_fault = None  # ImuSample -> ImuSample
        self.gps_fault = None  # GpsSample -> GpsSample

    @property
    def q(self):
        return self.est.q

    def update_imu(self, s: ImuSample) -> None:
        self.est.update_imu(self.imu_fault(s) if self.imu_fault else s)

    def update_gps(self, g: GpsSample) -> None:
        self.est.update_gps(self.gps_fault(g) if self.gps_fault else g)


def flying(seconds: float = 12.0):
    """A synthetic vehicle whose estimator has converged; (generator, estimator, its faults)."""
    s = make()
    est = s.est
    faulty = s.est = Faulty(est)
    s.run(seconds)
    assert est.estimate().attitude_valid and est.estimate().position_valid
    est.events.clear()
    return s, est, faulty


def texts(est) -> list[str]:
    return [text for _, text in est.events]


def health(est) -> int:
    e = est.estimate()
    return sensors_health(e, est.gps_ok(e.timestamp_us), est.status(), True, True)


def test_a_gyro_without_data_fails_the_attitude_until_it_is_back():
    s, est, faulty = flying()
    faulty.imu_fault = lambda m: dataclasses.replace(m, gyro_frd_rad_s=NAN3)
    s.run(TIMEOUT_S + 0.1)
    assert texts(est) == ["Gyro failed: no data"]
    assert not est.estimate().attitude_valid
    assert est.status().failed_sensors == ("gyro",)
    assert "Gyro failed: no data" in est.prearm_failures()
    assert not health(est) & mavlink.MAV_SYS_STATUS_SENSOR_3D_GYRO
    faulty.imu_fault = None
    s.run(RECOVER_S + 0.1)
    assert texts(est)[-1] == "Gyro healthy again"
    assert est.estimate().attitude_valid and est.status().failed_sensors == ()
    assert health(est) & mavlink.MAV_SYS_STATUS_SENSOR_3D_GYRO


def test_a_stuck_accelerometer_and_barometer_are_stale():
    s, est, faulty = flying()
    first: dict = {}

    def stuck(m: ImuSample) -> ImuSample:
        first.setdefault("m", m)
        return dataclasses.replace(m, accel_frd_m_s2=first["m"].accel_frd_m_s2, pressure_hpa=first["m"].pressure_hpa)

    faulty.imu_fault = stuck
    s.run(STALE_S - 0.1)
    assert texts(est) == []  # a sensor may repeat itself for a while
    s.run(0.2)
    assert sorted(texts(est)) == ["Accelerometer failed: stale data (readings repeat)",
                                  "Barometer failed: stale data (readings repeat)"]  # fmt: skip
    assert set(est.status().failed_sensors) == {"accelerometer", "barometer"}
    assert not est.estimate().attitude_valid
    bits = health(est)
    assert not bits & (mavlink.MAV_SYS_STATUS_SENSOR_3D_ACCEL | mavlink.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE)
    faulty.imu_fault = None
    s.run(RECOVER_S + 0.1)
    assert est.status().failed_sensors == () and est.estimate().attitude_valid


def test_a_frozen_gps_is_not_fused_and_the_position_is_lost_until_it_moves_again():
    s, est, faulty = flying()
    frozen: dict = {}

    def freeze(g: GpsSample) -> GpsSample:  # the receiver repeats its fix; the link stamps it now
        first = frozen.setdefault("g", g)
        return dataclasses.replace(first, timestamp_us=g.timestamp_us)

    faulty.gps_fault = freeze
    s.run(1.1)  # five fixes at 5 Hz
    assert texts(est) == ["GPS failed: stale data (fixes repeat)"]
    s.run(0.6)  # no fix fused for longer than the GPS time-out
    assert not est.estimate().position_valid and not health(est) & mavlink.MAV_SYS_STATUS_SENSOR_GPS
    faulty.gps_fault = None
    s.run(0.5)
    assert texts(est)[-1] == "GPS healthy again"
    s.run(5.0)
    assert est.estimate().position_valid
