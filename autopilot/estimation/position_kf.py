"""Linear Kalman filter for position and velocity, NED, driven by the accelerometer.

State per axis: position (m), velocity (m/s) and accelerometer bias along that
NED axis (m/s^2).  The IMU's kinematic acceleration (R f + g) drives the
prediction; GPS position and velocity correct north and east (and velocity
down); the barometer height corrects down.  Measurements whose normalised
innovation exceeds a gate are rejected.

Why hand-written instead of filterpy's KalmanFilter: the north and east filters
have the same model and the same measurements, so they share one covariance; the
three axes are propagated together as a 3x3 array, which costs a few
microseconds per IMU sample where three filterpy objects cost tens.  The full EKF
(a later issue) replaces this class behind :class:`autopilot.estimation.estimator.Estimator`.
"""

from __future__ import annotations

import numpy as np

from autopilot.estimation.ekf import (  # noqa: E402  (shared with the EKF: one set of sensor noises)
    P_BARO_NOISE,
    P_GPS_P_NOISE,
    P_GPS_V_NOISE,
)
from autopilot.estimation.ekf import (
    P_GPS_P_GATE as P_GATE,
)
from autopilot.parameters import ParamDef, param

P_GPS_DELAY = param(
    "EKF2_GPS_DELAY",
    120.0,
    0.0,
    300.0,
    "ms",
    "GPS measurement delay relative to the IMU: fixes are compared with the estimate this long ago "
    "(default: the simulator's SIM_GPS_LAG_MS)",
)

# The parameters this module reads (listed in autopilot/param_catalogue.py).
PARAMS: tuple[ParamDef, ...] = (P_GPS_DELAY,)
ACC_NOISE_DENSITY = (
    0.35  # m/s^2/sqrt(s): acceleration process noise of this filter (not EKF2_ACC_NOISE's per-step form)
)

_ACC_BIAS_RW = 0.002  # m/s^2 per sqrt(s), accelerometer bias random walk


class PositionVelocityFilter:
    def __init__(self) -> None:
        # x[axis] = (position, velocity, accel bias); axes N, E, D.
        self.x = np.zeros((3, 3))
        self.p_h = np.diag([100.0, 4.0, 0.1])  # shared by north and east
        self.p_v = np.diag([100.0, 4.0, 0.1])
        self.acc_noise = ACC_NOISE_DENSITY
        self.gps_p_noise = P_GPS_P_NOISE.default
        self.gps_v_noise = P_GPS_V_NOISE.default
        self.baro_noise = P_BARO_NOISE.default
        self.gate = P_GATE.default
        self.rejected = 0

    @property
    def pos_ned_m(self) -> np.ndarray:
        return self.x[:, 0].copy()

    @property
    def vel_ned_m_s(self) -> np.ndarray:
        return self.x[:, 1].copy()

    @property
    def accel_bias_ned(self) -> np.ndarray:
        return self.x[:, 2].copy()

    def horizontal_std_m(self) -> float:
        return float(np.sqrt(self.p_h[0, 0]))

    def vertical_std_m(self) -> float:
        return float(np.sqrt(self.p_v[0, 0]))

    def reset(self, pos_ned_m: np.ndarray, vel_ned_m_s: np.ndarray) -> None:
        self.x[:, 0] = pos_ned_m
        self.x[:, 1] = vel_ned_m_s
        self.p_h = np.diag([self.gps_p_noise**2, self.gps_v_noise**2, 0.05])
        self.p_v = np.diag([self.baro_noise**2, self.gps_v_noise**2, 0.05])

    def predict(self, accel_ned_m_s2: np.ndarray, dt_s: float) -> None:
        """Propagate with the kinematic acceleration (gravity removed), NED."""
        a = accel_ned_m_s2 - self.x[:, 2]
        self.x[:, 0] += self.x[:, 1] * dt_s + 0.5 * a * dt_s * dt_s
        self.x[:, 1] += a * dt_s
        f = np.array([[1.0, dt_s, -0.5 * dt_s * dt_s], [0.0, 1.0, -dt_s], [0.0, 0.0, 1.0]])
        q_acc = self.acc_noise**2 * dt_s
        q = np.diag([0.25 * q_acc * dt_s * dt_s, q_acc, _ACC_BIAS_RW**2 * dt_s])
        self.p_h = f @ self.p_h @ f.T + q
        self.p_v = f @ self.p_v @ f.T + q

    def _update_scalar(
        self, axes: list[int], p: np.ndarray, state: int, z: np.ndarray, r: float, reference: np.ndarray | None = None
    ) -> np.ndarray:
        """Fuse a measurement of one state element on the given axes (same P).

        ``reference``: the filter's own value of that element at the time the measurement
        describes (a delayed sensor); the innovation is taken against it and the correction
        applied to the current state.
        """
        s = p[state, state] + r
        innov = z - (self.x[axes, state] if reference is None else reference)
        if np.any(innov * innov > self.gate * self.gate * s):
            self.rejected += 1
            return p
        k = p[:, state] / s  # gain, same for each axis sharing P
        self.x[axes, :] += np.outer(innov, k)
        return p - np.outer(k, p[state, :])

    def fuse_gps(
        self,
        pos_ned_m: np.ndarray,
        vel_ned_m_s: np.ndarray,
        pos_then: np.ndarray | None = None,
        vel_then: np.ndarray | None = None,
    ) -> None:
        """Fuse a GPS fix; ``pos_then``/``vel_then`` are the estimate at the time the fix describes."""
        pos_then = self.x[:, 0] if pos_then is None else pos_then
        vel_then = self.x[:, 1] if vel_then is None else vel_then
        self.p_h = self._update_scalar([0, 1], self.p_h, 0, pos_ned_m[:2], self.gps_p_noise**2, pos_then[:2])
        self.p_h = self._update_scalar([0, 1], self.p_h, 1, vel_ned_m_s[:2], self.gps_v_noise**2, vel_then[:2])
        self.p_v = self._update_scalar([2], self.p_v, 1, vel_ned_m_s[2:3], (1.5 * self.gps_v_noise) ** 2, vel_then[2:3])

    def fuse_height(self, down_m: float, then_m: float | None = None, noise_m: float | None = None) -> None:
        """A height (m down): the barometer's now, or (``then_m``, ``noise_m``) the GPS height's of a delayed fix."""
        r = (self.baro_noise if noise_m is None else noise_m) ** 2
        ref = None if then_m is None else np.array([then_m])
        self.p_v = self._update_scalar([2], self.p_v, 0, np.array([down_m]), r, ref)
