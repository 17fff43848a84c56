"""Sensor failures: an accelerometer, gyro, magnetometer or barometer that sends nothing, repeats
itself or reads garbage.

Each of the four sensors has three ``SIM_*`` flags (:mod:`sitl.sim_settings`), read on every sample:

* OFF (``SIM_ACC_OFF``, ``SIM_GYR_OFF``, ``SIM_MAG_OFF``, ``SIM_BARO_OFF``): the reading is NaN; the
  MAVLink edge (:func:`hil_sensor_fields`, used by :mod:`sitl.lockstep`) clears the sensor's bits in
  HIL_SENSOR's ``fields_updated``, as a sensor that stopped sending;
* GARBAGE (``SIM_*_GARBAGE``): uniform random values within the sensor's range, fresh every sample
  (accelerometer +-16 g, gyro +-2000 deg/s, magnetometer +-4 gauss, pressure 300-1100 hPa and
  temperature -40..85 deg C);
* STUCK (``SIM_ACC_STUCK``, ``SIM_GYR_STUCK``, ``SIM_MAG_STUCK``, ``SIM_BARO_STUCK``): the last
  reading given, repeated exactly (nothing before it: the true reading).

With several set, OFF wins over GARBAGE and GARBAGE over STUCK.  The healthy reading is computed
first in every case (:class:`sitl.sensors.SensorSuite` draws the same noise either way), so a
failure changes no other sensor's noise and the error states (bias walk, baro drift) go on
underneath.  Garbage comes from its own random stream.  Readings are tuples of floats in the
sensors' SI units, FRD for vectors.
"""

from __future__ import annotations

import math

import numpy as np

from mavsim_core.constants import GRAVITY_M_S2, SEA_LEVEL_PRESSURE_HPA
from sitl.sim_settings import SensorSettings

NAN = math.nan
ACCEL_RANGE_M_S2 = 16.0 * GRAVITY_M_S2
GYRO_RANGE_RAD_S = math.radians(2000.0)
MAG_RANGE_GAUSS = 4.0
PRESSURE_RANGE_HPA = (300.0, 1100.0)
TEMPERATURE_RANGE_C = (-40.0, 85.0)

# HIL_SENSOR fields_updated bits (MAVLink HIL_SENSOR_UPDATED_FLAGS) of each sensor.
ACCEL_FIELDS = 0x007  # xacc, yacc, zacc
GYRO_FIELDS = 0x038  # xgyro, ygyro, zgyro
MAG_FIELDS = 0x1C0  # xmag, ymag, zmag
BARO_FIELDS = 0x200 | 0x800 | 0x1000  # abs_pressure, pressure_alt, temperature
ALL_FIELDS = 0x1FFF

Reading = tuple[float, ...]


class FaultySensor:
    """One sensor's failure behaviour: ``lo``/``hi`` are the per-element range of its garbage."""

    def __init__(self, lo: Reading, hi: Reading, rng: np.random.Generator) -> None:
        self.lo, self.hi = lo, hi
        self.rng = rng
        self.last: Reading | None = None  # the last reading given (what STUCK repeats)

    def apply(self, reading: Reading, off: int, stuck: int, garbage: int) -> Reading:
        """The reading the sensor gives, from the healthy ``reading`` and the three flags."""
        if off:
            return (NAN,) * len(reading)
        if garbage:
            reading = tuple(self.rng.uniform(self.lo, self.hi).tolist())
        elif stuck and self.last is not None:
            return self.last
        self.last = reading
        return reading


class SensorFaults:
    """The failure behaviour of the IMU, magnetometer and barometer of one :class:`SensorSuite`."""

    def __init__(self, rng: np.random.Generator) -> None:
        a, g, m = ACCEL_RANGE_M_S2, GYRO_RANGE_RAD_S, MAG_RANGE_GAUSS
        self.accel = FaultySensor((-a, -a, -a), (a, a, a), rng)
        self.gyro = FaultySensor((-g, -g, -g), (g, g, g), rng)
        self.mag = FaultySensor((-m, -m, -m), (m, m, m), rng)
        p, t = PRESSURE_RANGE_HPA, TEMPERATURE_RANGE_C
        self.baro = FaultySensor((p[0], t[0]), (p[1], t[1]), rng)

    def apply(
        self, s: SensorSettings, accel: Reading, gyro: Reading, mag: Reading, baro: Reading
    ) -> tuple[Reading, Reading, Reading, Reading]:
        """(accel m/s^2, gyro rad/s, mag gauss, (pressure hPa, temperature deg C)) as the failing sensors give them."""
        return (
            self.accel.apply(accel, s.accel_off, s.accel_stuck, s.accel_garbage),
            self.gyro.apply(gyro, s.gyro_off, s.gyro_stuck, s.gyro_garbage),
            self.mag.apply(mag, s.mag_off, s.mag_stuck, s.mag_garbage),
            self.baro.apply(baro, s.baro_off, s.baro_stuck, s.baro_garbage),
        )


def hil_sensor_fields(accel_x: float, gyro_x: float, mag_x: float, pressure_hpa: float) -> int:
    """HIL_SENSOR ``fields_updated``: every field but those of a sensor that is off (its reading NaN)."""
    fields = ALL_FIELDS
    if accel_x != accel_x:  # NaN: cheaper than math.isnan on the lockstep's hot path
        fields &= ~ACCEL_FIELDS
    if gyro_x != gyro_x:
        fields &= ~GYRO_FIELDS
    if mag_x != mag_x:
        fields &= ~MAG_FIELDS
    if pressure_hpa != pressure_hpa:
        fields &= ~BARO_FIELDS
    return fields


def pressure_altitude_m(pressure_hpa: float) -> float:
    """ISA pressure altitude (m AMSL) of a barometer reading (hPa); NaN for a barometer that is off."""
    if not pressure_hpa > 0.0:
        return NAN
    return (1.0 - (pressure_hpa / SEA_LEVEL_PRESSURE_HPA) ** (1.0 / 5.25588)) / 2.25577e-5
