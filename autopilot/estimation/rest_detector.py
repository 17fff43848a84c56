"""Whether the vehicle is at rest, from the raw IMU and GPS (the idea of PX4's EKF2 "vehicle at rest").

Home is set automatically only from a vehicle at rest (the commander's ``at_rest``): a flight
controller restarted in the air comes up disarmed while the vehicle falls, and a home set then would
be in the air, so that RTL would "land" there.  At rest: the specific force's magnitude within
:data:`ACCEL_TOL_M_S2` of g and the body rates below :data:`GYRO_MAX_RAD_S` on every IMU sample, and the
GPS speed below :data:`GPS_SPEED_MAX_M_S`, all for :data:`REST_TIME_S`.  ``moving`` is the opposite
held for :data:`MOVING_TIME_S` (free fall reads ~0 m/s², an impact far more than g), which the flight
controller reports.  A NaN sensor (not sent) says neither.

Pure: sample timestamps (simulated µs) are the clock; SI units, FRD body axes, NED velocity.
"""

from __future__ import annotations

import math

import numpy as np

from mavsim_core.constants import GRAVITY_M_S2

ACCEL_TOL_M_S2 = 1.0  # | |specific force| - g | while at rest
GYRO_MAX_RAD_S = 0.2  # |body rate| while at rest
GPS_SPEED_MAX_M_S = 0.5  # GPS speed (3-D) while at rest
REST_TIME_S = 1.0  # the still conditions must hold this long
MOVING_TIME_S = 0.1  # ... and their opposite this long to report motion


class RestDetector:
    """See the module docstring."""

    def __init__(self) -> None:
        self._reset()

    def _reset(self) -> None:
        self._still_since_us: int | None = None  # first IMU sample of the current still stretch
        self._moving_since_us: int | None = None
        self._gps_fast_until_us = -1  # the latest GPS speed above the limit counts until this time
        self._now_us = 0

    def update_imu(self, time_us: int, accel_frd_m_s2: np.ndarray, gyro_frd_rad_s: np.ndarray) -> None:
        """One IMU sample (specific force m/s², body rates rad/s, FRD)."""
        ax, ay, az = accel_frd_m_s2.tolist()
        gx, gy, gz = gyro_frd_rad_s.tolist()
        f = math.sqrt(ax * ax + ay * ay + az * az)
        w = math.sqrt(gx * gx + gy * gy + gz * gz)
        if not math.isfinite(f + w):
            return
        if time_us < self._now_us:  # the clock restarted: start again
            self._reset()
        self._now_us = time_us
        if abs(f - GRAVITY_M_S2) < ACCEL_TOL_M_S2 and w < GYRO_MAX_RAD_S:
            self._moving_since_us = None
            if self._still_since_us is None:
                self._still_since_us = time_us
        else:
            self._still_since_us = None
            if self._moving_since_us is None:
                self._moving_since_us = time_us

    def update_gps(self, time_us: int, vel_ned_m_s: np.ndarray) -> None:
        """One GPS fix's velocity (m/s, NED); a fast one keeps the vehicle from being at rest for REST_TIME_S."""
        speed = float(np.linalg.norm(vel_ned_m_s))
        if math.isfinite(speed) and speed > GPS_SPEED_MAX_M_S:
            self._gps_fast_until_us = time_us + round(REST_TIME_S * 1e6)

    @property
    def at_rest(self) -> bool:
        still, now = self._still_since_us, self._now_us
        return still is not None and now - still >= REST_TIME_S * 1e6 and now > self._gps_fast_until_us

    @property
    def moving(self) -> bool:
        since = self._moving_since_us
        return (since is not None and self._now_us - since >= MOVING_TIME_S * 1e6) or (
            self._now_us <= self._gps_fast_until_us
        )
