"""Sensor models: IMU, magnetometer, barometer and GPS with noise, bias, drift, delay and failures.

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
  (gauss/A).  SIM_MAG_STUCK = 1 repeats the last reading given before it got stuck.

Barometer (hPa)::

    drift[k] = drift[k-1] + SIM_BARO_DRIFT * dt              (m; drift = rate * t for a constant rate)
    h        = home_alt - pos_d + drift[k] + SIM_BARO_RND * n   (m AMSL)
    p        = 1013.25 * (1 - 2.25577e-5 * h) ** 5.25588     (ISA)

  temperature = 15 - 0.0065 * true altitude (deg C).  SIM_BARO_STUCK = 1 repeats
  the last pressure and temperature (the drift keeps growing underneath).

GPS (one fix per period 1/SIM_GPS_HZ, sent at the caller's call nearest to each
multiple of the period, i.e. rounded to the 4 ms step).  A fix sent at time t
describes the truth at t - SIM_GPS_LAG_MS (linearly interpolated in a ring
buffer of the truth given at every call); the caller stamps it with t.  Per fix,
with dt_f the time since the previous fix and tau = 60 s::

    z[j]   = a * z[j-1] + sqrt(1 - a^2) * n,   a = exp(-dt_f / tau)   (unit Gauss-Markov, N/E/D; z0 ~ N(0,1))
    e_N    = SIM_GPS_NOISE * n + SIM_GPS_DRIFT * z_N + SIM_GPS_GLITCH_N     (m; E likewise)
    e_D    = SIM_GPS_VNOISE * n + 1.5 * SIM_GPS_DRIFT * z_D + SIM_GPS_GLITCH_D
    v_err  = SIM_GPS_VELNOISE * n                                   (m/s, each NED axis)
    eph    = max(0.01, sqrt(SIM_GPS_NOISE^2 + SIM_GPS_DRIFT^2))       (1-sigma, per horizontal axis)
    epv    = max(0.01, sqrt(SIM_GPS_VNOISE^2 + (1.5 SIM_GPS_DRIFT)^2))

  The glitch is not in eph/epv (the receiver does not know of it).  Healthy
  fixes have fix_type 3 and 12-14 satellites (a slow random walk).  Outages
  start as a Poisson process of rate SIM_GPS_DROP_RT per minute while the
  receiver has lock and last SIM_GPS_DROP_S; so the long-run fraction of time
  without a fix is r*d / (60 + r*d).  During an outage fixes are still sent at
  the normal rate, with fix_type 1, 0 satellites, eph = epv = 99.99 m, the last
  good position and zero velocity.  SIM_GPS_DISABLE = 1 silences the receiver:
  :meth:`SensorSuite.gps` returns None.

Randomness: one ``numpy.random.default_rng(seed)`` spawns three independent
streams (IMU/mag/baro, GPS fixes, GPS outages), so a run is reproducible for a
seed and switching one sensor's errors on or off does not change the others'
noise.  The IMU stream is drawn in blocks of standard normals, a fixed 16 per
call, so the per-call cost stays a few microseconds.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from functools import lru_cache

import numpy as np

from mavsim_core.constants import (
    LOCKSTEP_DT_US,
    MAGNETIC_MODEL_EPOCH_YEAR,
    SEA_LEVEL_PRESSURE_HPA,
    SEA_LEVEL_TEMPERATURE_C,
    TEMPERATURE_LAPSE_K_M,
)
from mavsim_core.geodesy import ned_to_geodetic
from sitl.sim_settings import SensorSettings

CALL_PERIOD_US = LOCKSTEP_DT_US  # the caller's period; fix times are rounded to it
GPS_DRIFT_TAU_S = 60.0  # correlation time of the GPS wander
GPS_VERTICAL_DRIFT_FACTOR = 1.5  # vertical wander RMS / horizontal
GPS_MIN_ERROR_M = 0.01  # floor of the reported eph/epv
GPS_NO_FIX_ERROR_M = 99.99  # eph/epv reported without lock
GPS_SATS_MIN, GPS_SATS_MAX = 12, 14
GPS_SATS_STEP_Z = 2.326  # |n| beyond this (2 % per fix) moves the satellite count by one
FIX_TYPE_NO_FIX, FIX_TYPE_3D = 1, 3
HISTORY_LEN = 1024  # truth samples kept for the GPS latency (>= 500 ms at calls down to 0.5 ms apart)

_BLOCK = 4096  # standard normals drawn at once for the IMU; a multiple of _IMU_DRAWS
_IMU_DRAWS = 16  # per imu() call: accel noise 3, accel walk 3, gyro noise 3, gyro walk 3, mag 3, baro 1
_GPS_DRAWS = 10  # per fix: position white 3, Gauss-Markov 3, velocity 3, satellites 1
_HALF_CALL_US = CALL_PERIOD_US / 2

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


@dataclass(frozen=True, slots=True)
class ImuReading:
    """One IMU/magnetometer/barometer sample; vectors are tuples of 3 floats (FRD)."""

    accel_frd_m_s2: Vec3  # specific force
    gyro_frd_rad_s: Vec3
    mag_frd_gauss: Vec3
    pressure_hpa: float
    temperature_c: float


@dataclass(frozen=True, slots=True)
class GpsReading:
    """One GPS fix as the receiver reports it (position and velocity of SIM_GPS_LAG_MS ago)."""

    lat_deg: float
    lon_deg: float
    alt_amsl_m: float
    vel_ned_m_s: Vec3
    eph_m: float  # 1-sigma error per horizontal axis
    epv_m: float  # 1-sigma vertical error
    satellites: int
    fix_type: int  # GPS_FIX_TYPE: 1 no fix, 3 3D fix


def _vec(v) -> tuple | list:
    """A 3-vector as plain Python floats (numpy arrays converted, sequences copied)."""
    return v.tolist() if type(v) is np.ndarray else tuple(v)


class SensorSuite:
    """Turns ground truth into sensor readings with the errors of ``settings`` (read on every call)."""

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
        self.field_ned_gauss = earth_field_ned_gauss(*self.home)
        self._field = tuple(self.field_ned_gauss.tolist())
        # IMU: unit turn-on draws (scaled by the current *_bias_sd) and the random-walk parts.
        z0 = self._imu_rng.standard_normal(6).tolist()
        self._acc_z0, self._gyr_z0 = z0[0:3], z0[3:6]
        self._acc_walk = [0.0, 0.0, 0.0]
        self._gyr_walk = [0.0, 0.0, 0.0]
        self._z: list[float] = []
        self._zi = _BLOCK  # empty: the first call draws a block
        self._mag_last: Vec3 | None = None
        self._baro_last: tuple[float, float] | None = None
        self.baro_drift_m = 0.0
        # GPS
        self._hist: deque = deque(maxlen=HISTORY_LEN)
        self._gps_rate_hz = self.settings.gps_rate_hz
        self._gps_next_us = 0.0  # the first call at or after time 0 sends a fix
        self._last_fix_us: int | None = None
        self._gm = self._gps_rng.standard_normal(3).tolist()  # stationary start: RMS right from the first fix
        self._gm_time_us: int | None = None
        self._sats = 13
        self._last_lla = self.home
        self._hazard_time_s: float | None = None
        self._hazard = 0.0
        self._hazard_target = float(self._outage_rng.standard_exponential())
        self._outage_start_s = -math.inf
        self.gps_outage = False  # whether the last fix was sent during an outage

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
        (na0, na1, na2, wa0, wa1, wa2, ng0, ng1, ng2, wg0, wg1, wg2, nm0, nm1, nm2, nb) = self._z[i : i + _IMU_DRAWS]
        self._zi = i + _IMU_DRAWS
        sqdt = math.sqrt(dt_s)

        accel = _inertial_axes(
            specific_force_frd,
            self._acc_walk,
            s.accel_bias_walk * sqdt,
            (wa0, wa1, wa2),
            s.accel_bias_sd,
            self._acc_z0,
            s.accel_noise_density / sqdt,
            (na0, na1, na2),
        )
        gyro = _inertial_axes(
            rate_frd,
            self._gyr_walk,
            s.gyro_bias_walk * sqdt,
            (wg0, wg1, wg2),
            s.gyro_bias_sd,
            self._gyr_z0,
            s.gyro_noise_density / sqdt,
            (ng0, ng1, ng2),
        )

        # magnetometer
        mag = self._mag_last
        if not s.mag_stuck or mag is None:
            (r00, r01, r02), (r10, r11, r12), (r20, r21, r22) = (
                r_ned_frd.tolist() if type(r_ned_frd) is np.ndarray else r_ned_frd
            )
            bn, be, bd = self._field
            sig = s.mag_noise_gauss
            mag = (
                r00 * bn + r10 * be + r20 * bd + s.mag_offset_x_gauss + current_a * s.mag_motor_x_gauss_a + sig * nm0,
                r01 * bn + r11 * be + r21 * bd + s.mag_offset_y_gauss + current_a * s.mag_motor_y_gauss_a + sig * nm1,
                r02 * bn + r12 * be + r22 * bd + s.mag_offset_z_gauss + current_a * s.mag_motor_z_gauss_a + sig * nm2,
            )
            self._mag_last = mag

        # barometer
        drift = self.baro_drift_m = self.baro_drift_m + s.baro_drift_m_s * dt_s
        baro = self._baro_last
        if not s.baro_stuck or baro is None:
            alt = self.home[2] - float(pos_ned_m[2])
            h = alt + drift + s.baro_noise_m * nb
            baro = self._baro_last = (
                SEA_LEVEL_PRESSURE_HPA * (1.0 - 2.25577e-5 * h) ** 5.25588,
                SEA_LEVEL_TEMPERATURE_C - TEMPERATURE_LAPSE_K_M * alt,
            )
        return ImuReading(accel, gyro, mag, baro[0], baro[1])

    # -- GPS -------------------------------------------------------------------------
    def gps(self, time_us: int, pos_ned_m, vel_ned_m_s) -> GpsReading | None:
        """Call every period with the truth at ``time_us``; a fix when one is due to be sent, else None.

        The fix describes the truth SIM_GPS_LAG_MS before ``time_us``.
        """
        self._hist.append((time_us, _vec(pos_ned_m), _vec(vel_ned_m_s)))
        s = self.settings
        if s.gps_rate_hz != self._gps_rate_hz:  # a new rate: the next multiple of the new period
            self._gps_rate_hz = s.gps_rate_hz
            last = self._last_fix_us
            self._gps_next_us = 0.0 if last is None else self._next_due_us(last)
        if time_us + _HALF_CALL_US < self._gps_next_us:
            return None
        self._gps_next_us = self._next_due_us(time_us)
        self._last_fix_us = time_us
        if s.gps_disable:
            return None
        return self._fix(time_us, s)

    def _next_due_us(self, time_us: float) -> float:
        period_us = 1e6 / self._gps_rate_hz
        return (math.floor((time_us + _HALF_CALL_US) / period_us) + 1) * period_us

    def _truth_at(self, t_us: float):
        """(pos, vel) at ``t_us``, interpolated in the history (the oldest sample if it does not reach)."""
        newer = None
        for entry in reversed(self._hist):
            t0 = entry[0]
            if t0 <= t_us:
                if newer is None or t0 == t_us:
                    return entry[1], entry[2]
                f = (t_us - t0) / (newer[0] - t0)
                p0, v0, p1, v1 = entry[1], entry[2], newer[1], newer[2]
                return (
                    [p0[j] + f * (p1[j] - p0[j]) for j in range(3)],
                    [v0[j] + f * (v1[j] - v0[j]) for j in range(3)],
                )
            newer = entry
        return newer[1], newer[2]

    def _in_outage(self, t_s: float, s: SensorSettings) -> bool:
        """Advance the outage process to ``t_s``; whether the receiver has no lock then."""
        if self._hazard_time_s is None:
            self._hazard_time_s = t_s
        rate_s = s.gps_dropout_per_min / 60.0
        while True:
            end = self._outage_start_s + s.gps_dropout_s
            if t_s < end:
                return True
            t0 = max(self._hazard_time_s, end)  # the clock runs only while the receiver has lock
            if rate_s <= 0.0:
                self._hazard_time_s = t_s
                return False
            start = t0 + (self._hazard_target - self._hazard) / rate_s
            if start > t_s:
                self._hazard += rate_s * (t_s - t0)
                self._hazard_time_s = t_s
                return False
            self._outage_start_s = start
            self._hazard = 0.0
            self._hazard_target = float(self._outage_rng.standard_exponential())
            self._hazard_time_s = start

    def _fix(self, time_us: int, s: SensorSettings) -> GpsReading:
        n = self._gps_rng.standard_normal(_GPS_DRAWS).tolist()  # always the same count: reproducible
        # Gauss-Markov wander, unit variance; scaled by the current SIM_GPS_DRIFT
        if self._gm_time_us is not None:
            a = math.exp(-(time_us - self._gm_time_us) * 1e-6 / GPS_DRIFT_TAU_S)
            b = math.sqrt(max(0.0, 1.0 - a * a))
            gm = self._gm
            self._gm = [a * gm[0] + b * n[3], a * gm[1] + b * n[4], a * gm[2] + b * n[5]]
        self._gm_time_us = time_us
        if n[9] > GPS_SATS_STEP_Z and self._sats < GPS_SATS_MAX:
            self._sats += 1
        elif n[9] < -GPS_SATS_STEP_Z and self._sats > GPS_SATS_MIN:
            self._sats -= 1

        self.gps_outage = self._in_outage(time_us * 1e-6, s)
        if self.gps_outage:
            lat, lon, alt = self._last_lla
            return GpsReading(
                lat, lon, alt, (0.0, 0.0, 0.0), GPS_NO_FIX_ERROR_M, GPS_NO_FIX_ERROR_M, 0, FIX_TYPE_NO_FIX
            )

        p, v = self._truth_at(time_us - s.gps_lag_ms * 1000)
        hn, vn, dr = s.gps_noise_m, s.gps_vnoise_m, s.gps_drift_m
        drv = GPS_VERTICAL_DRIFT_FACTOR * dr
        gm = self._gm
        reported = (
            p[0] + hn * n[0] + dr * gm[0] + s.gps_glitch_n_m,
            p[1] + hn * n[1] + dr * gm[1] + s.gps_glitch_e_m,
            p[2] + vn * n[2] + drv * gm[2] + s.gps_glitch_d_m,
        )
        lat, lon, alt = self._last_lla = ned_to_geodetic(reported, *self.home)
        sv = s.gps_vel_noise_m_s
        vel = (v[0] + sv * n[6], v[1] + sv * n[7], v[2] + sv * n[8])
        return GpsReading(
            lat,
            lon,
            alt,
            vel,
            max(GPS_MIN_ERROR_M, math.hypot(hn, dr)),
            max(GPS_MIN_ERROR_M, math.hypot(vn, drv)),
            self._sats,
            FIX_TYPE_3D,
        )


def _inertial_axes(
    truth, walk: list[float], walk_step: float, walk_draws, bias_sd: float, bias_z0, noise_sd: float, noise_draws
) -> Vec3:
    """One accelerometer or gyro sample on three axes: truth + turn-on bias (bias_sd x its unit
    draw z0) + bias random walk (advanced in place by walk_step x its draws) + white noise."""
    x0, x1, x2 = truth.tolist() if type(truth) is np.ndarray else truth
    w0 = walk[0] = walk[0] + walk_step * walk_draws[0]
    w1 = walk[1] = walk[1] + walk_step * walk_draws[1]
    w2 = walk[2] = walk[2] + walk_step * walk_draws[2]
    return (
        x0 + bias_sd * bias_z0[0] + w0 + noise_sd * noise_draws[0],
        x1 + bias_sd * bias_z0[1] + w1 + noise_sd * noise_draws[1],
        x2 + bias_sd * bias_z0[2] + w2 + noise_sd * noise_draws[2],
    )


def course_over_ground_deg(vel_ned_m_s) -> float:
    return math.degrees(math.atan2(vel_ned_m_s[1], vel_ned_m_s[0])) % 360.0
