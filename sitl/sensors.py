"""The sensor suite: IMU, magnetometer and barometer models (noise, bias, drift, failures) and the GPS receiver.

Inputs are ground truth in MAVLink frames (NED world, FRD body, SI units);
outputs are what the sensors would read, still in SI (the MAVLink edge converts
to its own units).  Every error figure comes from a :class:`SensorSettings`
(``sitl.sim_settings``; each field is a ``SIM_*`` MAVLink parameter).  That
object is mutable: :class:`SensorSuite` reads it on every call, so a parameter
set in flight acts on the next call.

Error models (k counts calls of :meth:`SensorSuite.imu`, ``dt`` is its ``dt_s``;
n ~ N(0, 1) is a fresh standard normal draw per axis and per use):

Accelerometer (m/s^2, FRD) and gyro (rad/s, FRD), per axis::

    b_walk[k] = b_walk[k-1] + walk * sqrt(dt) * n          (random walk, updated before the sample)
    bias[k]   = bias_sd * z0 + b_walk[k]                    (z0 ~ N(0,1) drawn once per axis at start)
    reading   = truth + bias[k] + density * sqrt(1/dt) * n

  with density = SIM_ACC_NOISE / SIM_GYR_NOISE (unit/sqrt(Hz)), walk =
  SIM_ACC_BIAS_RW / SIM_GYR_BIAS_RW (unit/s/sqrt(Hz)), bias_sd = SIM_ACC_BIAS_SD /
  SIM_GYR_BIAS_SD (the turn-on bias; the same draw z0 is scaled by the current
  setting, so a change of it acts at once).  Truth: the specific force f = R^T (a - g)
  and the body rate, both FRD.

Magnetometer (gauss, FRD)::

    m = R^T F_ned + ofs + I * mot + SIM_MAG_NOISE * n

  R = ``r_ned_frd`` (FRD -> NED), F_ned the World Magnetic Model field at home,
  ofs = SIM_MAG_OFS_X/Y/Z (gauss), I = battery current (A), mot = SIM_MAG_MOT_X/Y/Z
  (gauss/A).

Barometer (hPa)::

    drift[k] = drift[k-1] + SIM_BARO_DRIFT * dt              (m; drift = rate * t for a constant rate)
    h        = home_alt - pos_d + drift[k] + SIM_BARO_RND * n   (m AMSL)
    p        = 1013.25 * (1 - 2.25577e-5 * h) ** 5.25588     (ISA)

  temperature = 15 - 0.0065 * true altitude (deg C).

Failures (:mod:`sitl.sensor_faults`): each of the four sensors can be off (NaN), read garbage or be
stuck (repeat its last reading), by SIM_ACC_OFF / _STUCK / _GARBAGE, SIM_GYR_*, SIM_MAG_* and
SIM_BARO_*; the healthy reading is computed first either way (the drift keeps growing underneath).

GPS: :class:`sitl.gps.GpsReceiver` (fix timing, latency, noise, wander, outages; its
module docstring has the model), reached through :meth:`SensorSuite.gps`.

Randomness: one ``numpy.random.default_rng(seed)`` spawns four independent
streams (IMU/mag/baro here; GPS fixes and GPS outages for the receiver; the sensors' garbage), so a
run is reproducible for a seed and switching one sensor's errors on or off does
not change the others' noise.  The IMU stream is drawn in blocks of standard
normals, a fixed 16 per call, so the per-call cost stays a few microseconds.
"""

from __future__ import annotations

import math
from functools import lru_cache
from typing import NamedTuple

import numpy as np

from mavsim_core.constants import (
    MAGNETIC_MODEL_EPOCH_YEAR,
    SEA_LEVEL_PRESSURE_HPA,
    SEA_LEVEL_TEMPERATURE_C,
    TEMPERATURE_LAPSE_K_M,
)
from sitl.gps import GpsReading, GpsReceiver, course_over_ground_deg
from sitl.sensor_faults import SensorFaults
from sitl.sim_settings import SensorSettings

__all__ = [  # GpsReading and course_over_ground_deg live in sitl.gps; still importable from here
    "GpsReading",
    "ImuReading",
    "SensorSuite",
    "course_over_ground_deg",
    "earth_field_ned_gauss",
    "pressure_hpa_at",
]

_BLOCK = 4096  # standard normals drawn at once for the IMU; a multiple of _IMU_DRAWS
_IMU_DRAWS = 16  # per imu() call: accel noise 3, accel walk 3, gyro noise 3, gyro walk 3, mag 3, baro 1

Vec3 = tuple[float, float, float]


def pressure_hpa_at(alt_amsl_m: float) -> float:
    """International Standard Atmosphere pressure (hPa) at an altitude (m AMSL)."""
    return SEA_LEVEL_PRESSURE_HPA * (1.0 - 2.25577e-5 * alt_amsl_m) ** 5.25588


@lru_cache(maxsize=64)
def _earth_field(lat_deg: float, lon_deg: float, alt_amsl_m: float, year: float) -> Vec3:
    from pygeomag import GeoMag

    r = GeoMag().calculate(glat=lat_deg, glon=lon_deg, alt=alt_amsl_m / 1000.0, time=year)
    return (r.x * 1e-5, r.y * 1e-5, r.z * 1e-5)  # nT -> gauss


def earth_field_ned_gauss(
    lat_deg: float, lon_deg: float, alt_amsl_m: float, year: float = MAGNETIC_MODEL_EPOCH_YEAR
) -> np.ndarray:
    """Earth's magnetic field (gauss, NED) from the World Magnetic Model."""
    return np.array(_earth_field(float(lat_deg), float(lon_deg), float(alt_amsl_m), float(year)))


class ImuReading(NamedTuple):
    """One IMU/magnetometer/barometer sample; vectors are tuples of 3 floats (FRD).  (A NamedTuple: a frozen
    dataclass costs 0.4 us more to build, every lockstep period.)"""

    accel_frd_m_s2: Vec3  # specific force
    gyro_frd_rad_s: Vec3
    mag_frd_gauss: Vec3
    pressure_hpa: float
    temperature_c: float


class SensorSuite:
    """Turns ground truth into sensor readings with the errors of ``settings`` (read on every call).

    The GPS part is ``gps_receiver`` (:class:`sitl.gps.GpsReceiver`), which reads the same settings object.
    """

    def __init__(
        self,
        home_lat_deg: float,
        home_lon_deg: float,
        home_alt_m: float,
        seed: int,
        settings: SensorSettings | None = None,
    ) -> None:
        self.home = (float(home_lat_deg), float(home_lon_deg), float(home_alt_m))
        self.settings = settings if settings is not None else SensorSettings()
        self.rng = np.random.default_rng(seed)
        self._imu_rng, self._gps_rng, self._outage_rng = self.rng.spawn(3)
        self.faults = SensorFaults(self.rng.spawn(1)[0])  # failures: off, stuck, garbage (SIM_*_OFF ...)
        self.field_ned_gauss = earth_field_ned_gauss(*self.home)
        self._field = tuple(self.field_ned_gauss.tolist())
        # IMU: unit turn-on draws (scaled by the current *_bias_sd) and the random-walk parts.
        z0 = self._imu_rng.standard_normal(6).tolist()
        self._acc_z0, self._gyr_z0 = z0[0:3], z0[3:6]
        self._acc_walk = [0.0, 0.0, 0.0]
        self._gyr_walk = [0.0, 0.0, 0.0]
        self._z: list[float] = []
        self._zi = _BLOCK  # empty: the first call draws a block
        self.baro_drift_m = 0.0
        self.gps_receiver = GpsReceiver(self.home, self.settings, self._gps_rng, self._outage_rng)

    # -- truth of the error states ------------------------------------------------
    @property
    def accel_bias_frd(self) -> Vec3:
        """Accelerometer bias (m/s^2, FRD) in the latest reading."""
        sd, z, w = self.settings.accel_bias_sd, self._acc_z0, self._acc_walk
        return (sd * z[0] + w[0], sd * z[1] + w[1], sd * z[2] + w[2])

    @property
    def gyro_bias_frd(self) -> Vec3:
        """Gyro bias (rad/s, FRD) in the latest reading."""
        sd, z, w = self.settings.gyro_bias_sd, self._gyr_z0, self._gyr_walk
        return (sd * z[0] + w[0], sd * z[1] + w[1], sd * z[2] + w[2])

    # -- IMU, magnetometer, barometer ----------------------------------------------
    def imu(
        self, specific_force_frd, rate_frd, r_ned_frd, pos_ned_m, dt_s: float, current_a: float = 0.0
    ) -> ImuReading:
        """One sample of accelerometer, gyro, magnetometer and barometer.

        ``specific_force_frd`` (m/s^2) and ``rate_frd`` (rad/s) are true, FRD;
        ``r_ned_frd`` is the rotation matrix taking FRD vectors to NED;
        ``pos_ned_m`` is relative to home; ``dt_s`` the time since the previous
        call; ``current_a`` the battery current (magnetometer interference).
        """
        s = self.settings
        i = self._zi
        if i >= _BLOCK:
            self._z = self._imu_rng.standard_normal(_BLOCK).tolist()
            i = 0
        z = self._z  # this call's draws: z[i:i+16], in the order of _IMU_DRAWS
        self._zi = i + _IMU_DRAWS
        sqdt = math.sqrt(dt_s)

        accel = _inertial_axes(
            specific_force_frd,
            self._acc_walk,
            s.accel_bias_walk * sqdt,
            s.accel_bias_sd,
            self._acc_z0,
            s.accel_noise_density / sqdt,
            z,
            i,
        )
        gyro = _inertial_axes(
            rate_frd,
            self._gyr_walk,
            s.gyro_bias_walk * sqdt,
            s.gyro_bias_sd,
            self._gyr_z0,
            s.gyro_noise_density / sqdt,
            z,
            i + 6,
        )

        # magnetometer
        (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = (
            r_ned_frd.tolist() if type(r_ned_frd) is np.ndarray else r_ned_frd
        )
        bn, be, bd = self._field
        sig = s.mag_noise_gauss
        mag = (
            r00 * bn + r10 * be + r20 * bd + s.mag_offset_x_gauss + current_a * s.mag_motor_x_gauss_a + sig * z[i + 12],
            r01 * bn + r11 * be + r21 * bd + s.mag_offset_y_gauss + current_a * s.mag_motor_y_gauss_a + sig * z[i + 13],
            r02 * bn + r12 * be + r22 * bd + s.mag_offset_z_gauss + current_a * s.mag_motor_z_gauss_a + sig * z[i + 14],
        )

        # barometer
        drift = self.baro_drift_m = self.baro_drift_m + s.baro_drift_m_s * dt_s
        alt = self.home[2] - float(pos_ned_m[2])
        h = alt + drift + s.baro_noise_m * z[i + 15]
        baro = (
            SEA_LEVEL_PRESSURE_HPA * (1.0 - 2.25577e-5 * h) ** 5.25588,
            SEA_LEVEL_TEMPERATURE_C - TEMPERATURE_LAPSE_K_M * alt,
        )
        accel, gyro, mag, baro = self.faults.apply(s, accel, gyro, mag, baro)
        return ImuReading(accel, gyro, mag, baro[0], baro[1])

    # -- GPS -------------------------------------------------------------------------
    def gps(self, time_us: int, pos_ned_m, vel_ned_m_s) -> GpsReading | None:
        """Call every period with the truth at ``time_us``; a fix when one is due to be sent, else None.

        The fix describes the truth SIM_GPS_LAG_MS before ``time_us`` (see :mod:`sitl.gps`).
        """
        return self.gps_receiver.update(time_us, pos_ned_m, vel_ned_m_s)

    @property
    def gps_outage(self) -> bool:
        """Whether the last fix was sent during an outage."""
        return self.gps_receiver.outage


def _inertial_axes(
    truth, walk: list[float], walk_step: float, bias_sd: float, bias_z0, noise_sd: float, z: list[float], i: int
) -> Vec3:
    """One accelerometer or gyro sample on three axes: truth + turn-on bias (bias_sd x its unit
    draw z0) + bias random walk (advanced in place by walk_step x its draws) + white noise.
    Draws: z[i:i+3] the noise, z[i+3:i+6] the walk (indices into the block: no copies)."""
    x0, x1, x2 = truth.tolist() if type(truth) is np.ndarray else truth
    w0 = walk[0] = walk[0] + walk_step * z[i + 3]
    w1 = walk[1] = walk[1] + walk_step * z[i + 4]
    w2 = walk[2] = walk[2] + walk_step * z[i + 5]
    return (
        x0 + bias_sd * bias_z0[0] + w0 + noise_sd * z[i],
        x1 + bias_sd * bias_z0[1] + w1 + noise_sd * z[i + 1],
        x2 + bias_sd * bias_z0[2] + w2 + noise_sd * z[i + 2],
    )
