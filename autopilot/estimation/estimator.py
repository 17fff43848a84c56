"""The estimator the controllers fly on: attitude filter + position filter.

Input: IMU samples (HIL_SENSOR) and GPS fixes (HIL_GPS).  Output:
:class:`autopilot.topics.VehicleEstimate` in NED/FRD.  The local origin is set at
the first good GPS fix (latitude, longitude, GPS altitude); the barometer gives
height relative to its reading at that moment.

A later, fuller filter (the EKF of the estimation issue) replaces this class by
implementing the same three methods: ``update_imu``, ``update_gps`` and
``estimate``; nothing in the controllers changes.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from autopilot import quat
from autopilot.estimation.mahony import MahonyFilter
from autopilot.estimation.position_kf import P_GPS_DELAY, PositionVelocityFilter
from autopilot.topics import GpsSample, ImuSample, VehicleEstimate
from autopilot.geodesy import geodetic_to_ned

GRAVITY_M_S2 = 9.80665
ALIGN_TIME_S = 3.0  # attitude must have run this long before it is trusted
BARO_PERIOD_US = 20_000  # barometer fused at 50 Hz, the rate of a real one
POSITION_SETTLE_S = 3.0  # GPS must have been fused this long before position is trusted
MAX_H_STD_M = 0.5
MAX_V_STD_M = 0.5
GPS_MIN_SATS = 6
GPS_TIMEOUT_US = 500_000
GPS_ACCEL_TAU_S = 0.5  # low-pass of the GPS velocity derivative given to the attitude filter


def _finite(v: np.ndarray) -> bool:
    """All three components finite (cheaper than np.all(np.isfinite(v)) on a 3-vector)."""
    return math.isfinite(float(v[0]) + float(v[1]) + float(v[2]))


def pressure_to_altitude_m(pressure_hpa: float) -> float:
    """ISA barometric altitude (m) from static pressure (hPa)."""
    return (1.0 - (pressure_hpa / 1013.25) ** (1.0 / 5.25588)) / 2.25577e-5


class Estimator:
    def __init__(self) -> None:
        self.attitude = MahonyFilter()
        self.position = PositionVelocityFilter()
        self.rate_frd = np.zeros(3)
        self.accel_ned = np.zeros(3)
        self.last_imu_us: int | None = None
        self.last_gps_us: int | None = None
        self.first_gps_us: int | None = None
        self.origin: tuple[float, float, float] | None = None
        self.baro_offset_m = 0.0
        self.last_baro_alt_m: float | None = None
        self.r_ned_frd = np.eye(3)  # attitude as a matrix (FRD -> NED), refreshed on each IMU sample
        self._acc_sum = np.zeros(3)  # kinematic acceleration accumulated since the last prediction
        self._acc_dt = 0.0
        self.gps_delay_us = int(P_GPS_DELAY.default * 1000)
        # Kinematic acceleration for the attitude filter's gravity reference, NED m/s^2: the
        # low-passed derivative of GPS velocity.  It must not come from the accelerometer itself
        # (that would make the gravity correction compare the accelerometer with itself).
        self.gps_accel_ned = np.zeros(3)
        self._gps_vels: deque[tuple[int, np.ndarray]] = deque(maxlen=2)
        # (time_us, position, velocity) after each prediction (50 Hz, 0.64 s): what the estimate was
        # when a delayed GPS fix was measured.
        self._history: deque[tuple[int, np.ndarray, np.ndarray]] = deque(maxlen=32)

    # -- inputs ---------------------------------------------------------------------
    def update_imu(self, s: ImuSample) -> None:
        dt = 0.004 if self.last_imu_us is None else (s.timestamp_us - self.last_imu_us) * 1e-6
        self.last_imu_us = s.timestamp_us
        if not 0.0 < dt < 0.1 or not _finite(s.accel_frd_m_s2) or not _finite(s.gyro_frd_rad_s):
            return  # NaN never reaches the filters
        mag = s.mag_frd_gauss if _finite(s.mag_frd_gauss) else None
        self.rate_frd = self.attitude.update(s.gyro_frd_rad_s, s.accel_frd_m_s2, mag, dt, self.gps_accel_ned)
        r = self.r_ned_frd = quat.to_matrix(self.attitude.q)
        self._acc_sum += (r @ s.accel_frd_m_s2) * dt
        self._acc_dt += dt
        if s.timestamp_us % BARO_PERIOD_US >= 4000:
            return
        self._predict()
        if math.isfinite(s.pressure_hpa) and s.pressure_hpa > 0:
            self.last_baro_alt_m = pressure_to_altitude_m(s.pressure_hpa)
            if self.origin is not None:
                self.position.fuse_height(-(self.last_baro_alt_m - self.baro_offset_m))

    def _predict(self) -> None:
        """Run the position filter's prediction over the accumulated IMU samples (50 Hz)."""
        if self._acc_dt <= 0:
            return
        accel_ned = self._acc_sum / self._acc_dt + np.array([0.0, 0.0, GRAVITY_M_S2])
        self.position.predict(accel_ned, self._acc_dt)
        self.accel_ned = accel_ned - self.position.accel_bias_ned
        self._acc_sum[:] = 0.0
        self._acc_dt = 0.0
        if self.last_imu_us is not None:
            x = self.position.x
            self._history.append((self.last_imu_us, x[:, 0].copy(), x[:, 1].copy()))

    def _estimate_at(self, time_us: int) -> tuple[np.ndarray, np.ndarray] | tuple[None, None]:
        """Position and velocity estimate nearest to an earlier time (None if the history does not reach)."""
        best = None
        for t, pos, vel in reversed(self._history):
            if best is None or abs(t - time_us) < abs(best[0] - time_us):
                best = (t, pos, vel)
            if t < time_us:
                break
        if best is None or abs(best[0] - time_us) > 20_000:
            return None, None
        return best[1], best[2]

    def update_gps(self, g: GpsSample) -> None:
        self._predict()
        if g.fix_type < 3 or g.satellites < GPS_MIN_SATS:
            return
        self.last_gps_us = g.timestamp_us
        self._update_gps_accel(g.timestamp_us, np.asarray(g.vel_ned_m_s, dtype=float))
        if self.origin is None:
            if self.last_baro_alt_m is None:
                return
            self.origin = (g.lat_deg, g.lon_deg, g.alt_amsl_m)
            self.baro_offset_m = self.last_baro_alt_m
            self.first_gps_us = g.timestamp_us
            self.position.reset(np.zeros(3), g.vel_ned_m_s)
            self._set_declination(g.lat_deg, g.lon_deg, g.alt_amsl_m)
            return
        pos = geodetic_to_ned(g.lat_deg, g.lon_deg, g.alt_amsl_m, *self.origin)
        pos_then, vel_then = self._estimate_at(g.timestamp_us - self.gps_delay_us)
        self.position.fuse_gps(pos, g.vel_ned_m_s, pos_then, vel_then)

    def _update_gps_accel(self, time_us: int, vel_ned: np.ndarray) -> None:
        """Low-pass (GPS_ACCEL_TAU_S) the derivative of GPS velocity between fixes."""
        if not _finite(vel_ned):
            return
        last = self._gps_vels[-1] if self._gps_vels else None
        self._gps_vels.append((time_us, vel_ned))
        if last is None:
            return
        dt = (time_us - last[0]) * 1e-6
        if 0.0 < dt < 1.0:
            accel = (vel_ned - last[1]) / dt
            self.gps_accel_ned += dt / (dt + GPS_ACCEL_TAU_S) * (accel - self.gps_accel_ned)
        else:
            self.gps_accel_ned[:] = 0.0

    def _set_declination(self, lat: float, lon: float, alt: float) -> None:
        """Magnetic declination at the origin, from the World Magnetic Model."""
        from pygeomag import GeoMag

        d = GeoMag().calculate(glat=lat, glon=lon, alt=alt / 1000.0, time=2026.9).d
        self.attitude.declination_rad = math.radians(d)
        # Re-align the heading now that declination is known.
        roll, pitch, yaw = quat.to_euler(self.attitude.q)
        self.attitude.q = quat.from_euler(roll, pitch, yaw + math.radians(d))

    # -- output ---------------------------------------------------------------------
    def gps_ok(self, now_us: int) -> bool:
        return self.last_gps_us is not None and now_us - self.last_gps_us < GPS_TIMEOUT_US

    def estimate(self) -> VehicleEstimate:
        now = self.last_imu_us if self.last_imu_us is not None else 0
        q = self.attitude.q
        roll, pitch, yaw = quat.to_euler(q)
        att_ok = self.attitude.initialised and self.attitude.time_aligned_s >= ALIGN_TIME_S
        pos_ok = (
            self.origin is not None
            and self.gps_ok(now)
            and self.first_gps_us is not None
            and now - self.first_gps_us >= POSITION_SETTLE_S * 1e6
            and self.position.horizontal_std_m() < MAX_H_STD_M
            and self.position.vertical_std_m() < MAX_V_STD_M
        )
        o = self.origin or (math.nan, math.nan, math.nan)
        return VehicleEstimate(
            timestamp_us=now, q_wxyz=q.copy(), rate_frd_rad_s=self.rate_frd.copy(),
            accel_ned_m_s2=self.accel_ned.copy(), pos_ned_m=self.position.pos_ned_m,
            vel_ned_m_s=self.position.vel_ned_m_s, attitude_valid=att_ok, position_valid=pos_ok,
            origin_lat_deg=o[0], origin_lon_deg=o[1], origin_alt_amsl_m=o[2],
            roll_rad=roll, pitch_rad=pitch, yaw_rad=yaw,
        )
