"""Mahony complementary filter for attitude ([F]'s attitude estimator).

Gyro integration corrected by the accelerometer's gravity direction (roll,
pitch) and by the magnetometer's heading (yaw only, so a disturbed magnetometer
cannot tilt the estimate), with an integral term that learns the gyro bias.
Frames: body FRD, world NED; q rotates FRD into NED; gyro rad/s, accel m/s^2,
mag in any unit (only its direction is used).
"""

from __future__ import annotations

import math

import numpy as np

from autopilot.parameters import ParamDef, param
from mavsim_core import quaternion as quat
from mavsim_core.constants import GRAVITY_M_S2

P_KP = param("ATT_MAHONY_KP", 0.5, 0.0, 20.0, "rad/s", "Mahony filter proportional gain (accelerometer and heading)")
P_KI = param("ATT_MAHONY_KI", 0.05, 0.0, 5.0, "rad/s^2", "Mahony filter integral gain (gyro bias learning)")
P_KMAG = param("ATT_MAHONY_KMAG", 0.5, 0.0, 20.0, "rad/s", "Mahony filter heading gain from the magnetometer")

# The parameters this module reads (listed in autopilot/param_catalogue.py).
PARAMS: tuple[ParamDef, ...] = (
    P_KP,
    P_KI,
    P_KMAG,
)

HEADING_BIAS_MAX_ERR_RAD = math.radians(5.0)  # heading errors larger than this do not teach the gyro bias
CORRECTION_EVERY = 5  # accelerometer/heading correction at 1/5 of the gyro rate (50 Hz at 250 Hz)


class MahonyFilter:
    def __init__(self, kp: float = P_KP.default, ki: float = P_KI.default, k_mag: float = P_KMAG.default) -> None:
        self.kp, self.ki, self.k_mag = kp, ki, k_mag
        self.correct_every = CORRECTION_EVERY  # 1 when fed 50 Hz delta-angle averages
        self.q = np.array([1.0, 0.0, 0.0, 0.0])
        self.gyro_bias = np.zeros(3)
        self.declination_rad = 0.0
        self.initialised = False
        self.time_aligned_s = 0.0  # time since initialisation
        self._corr = np.zeros(3)
        self._count = 0
        self._acc_sum = np.zeros(3)  # accelerometer samples summed over one correction interval

    def _heading_from_mag(self, roll: float, pitch: float, mag: np.ndarray) -> float:
        """True heading (rad) from the magnetometer, tilt-compensated."""
        cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
        mx = mag[0] * cp + mag[1] * sr * sp + mag[2] * cr * sp
        my = mag[1] * cr - mag[2] * sr
        return math.atan2(-my, mx) + self.declination_rad

    def initialise(self, accel_frd: np.ndarray, mag_frd: np.ndarray) -> None:
        """Level from gravity and heading from the magnetometer, at rest."""
        ax, ay, az = -accel_frd  # gravity direction in body
        roll = math.atan2(ay, az)
        pitch = math.atan2(-ax, math.hypot(ay, az))
        yaw = self._heading_from_mag(roll, pitch, mag_frd)
        self.q = quat.from_euler(roll, pitch, yaw)
        self.initialised = True
        self.time_aligned_s = 0.0

    def update(
        self,
        gyro_frd: np.ndarray,
        accel_frd: np.ndarray,
        mag_frd: np.ndarray | None,
        dt_s: float,
        accel_ned_kinematic: np.ndarray | None = None,
    ) -> np.ndarray:
        """One step; returns the bias-corrected body rate (rad/s)."""
        if not self.initialised:
            if abs(np.linalg.norm(accel_frd) - GRAVITY_M_S2) > 0.1 * GRAVITY_M_S2:
                return gyro_frd - self.gyro_bias  # not at rest: wait for a sample that shows gravity
            self.initialise(accel_frd, mag_frd if mag_frd is not None else np.array([1.0, 0.0, 0.0]))
        self._count += 1
        self._acc_sum += accel_frd
        n = self.correct_every
        if self._count % n == 0:
            # The mean of the interval's samples: 1/sqrt(n) of one sample's noise.
            self._correct(self._acc_sum / n, mag_frd, dt_s * n, accel_ned_kinematic)
            self._acc_sum[:] = 0.0
        rate = gyro_frd - self.gyro_bias
        self.q = quat.integrate(self.q, rate + self._corr, dt_s)
        self.time_aligned_s += dt_s
        return rate

    def _correct(
        self, accel_frd: np.ndarray, mag_frd: np.ndarray | None, dt_s: float, accel_ned_kinematic: np.ndarray | None
    ) -> None:
        """Recompute the correction rate from gravity and heading; learn the gyro bias."""
        r = quat.to_matrix(self.q)
        err = np.zeros(3)
        # Gravity: measured specific force f = R^T (a - g); expected direction from the estimate.
        a_kin = accel_ned_kinematic if accel_ned_kinematic is not None else np.zeros(3)
        expected = r.T @ (a_kin - np.array([0.0, 0.0, GRAVITY_M_S2]))
        n_meas = np.linalg.norm(accel_frd)
        n_exp = np.linalg.norm(expected)
        if n_meas > 1e-3 and n_exp > 1e-3 and abs(n_meas - n_exp) < 0.25 * GRAVITY_M_S2:
            err += quat.cross(accel_frd / n_meas, expected / n_exp)
        gyro_corr_err = err * self.kp
        bias_err = err
        if mag_frd is not None and np.linalg.norm(mag_frd) > 1e-6 and self.k_mag > 0:
            roll, pitch, yaw = quat.to_euler(self.q)
            yaw_err = quat.wrap_pi(self._heading_from_mag(roll, pitch, mag_frd) - yaw)
            heading_err = r.T @ np.array([0.0, 0.0, yaw_err])
            gyro_corr_err = gyro_corr_err + heading_err * self.k_mag
            if abs(yaw_err) < HEADING_BIAS_MAX_ERR_RAD:  # not while still aligning: that would wind up
                bias_err = err + heading_err * (self.k_mag / self.kp if self.kp > 0 else 1.0)
        if self.ki > 0:
            # The integral learns the gyro bias from both corrections (the heading one for the z gyro).
            self.gyro_bias -= self.ki * bias_err * dt_s
            self.gyro_bias = np.minimum(np.maximum(self.gyro_bias, -0.1), 0.1)
        self._corr = gyro_corr_err
