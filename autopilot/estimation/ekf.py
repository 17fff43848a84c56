"""Error-state extended Kalman filter: position, velocity, attitude, gyro and accelerometer bias.

Frames and units: position (m) and velocity (m/s) NED relative to the estimator
origin; attitude a unit quaternion (w, x, y, z) rotating FRD body vectors into
NED; gyro bias (rad/s) and accelerometer bias (m/s^2) in FRD.

Nominal state (16): p, v, q, b_g, b_a.  Error state (15), in this order::

    dp (0:3)  dv (3:6)  dtheta (6:9, body frame: q_true = q * exp(dtheta))  db_g (9:12)  db_a (12:15)

Prediction (50 Hz, the rate of the outer loops and the barometer), on the IMU's
summed delta angle and delta velocity of the interval, as PX4's EKF2 runs on
downsampled IMU data; the estimator's output predictor carries the attitude
between predictions at the IMU rate.  The covariance is propagated with the
error-state Jacobian over the interval T::

    dp' = dp + dv T
    dv' = dv - R [dv_b]x dtheta - R db_a T
    dtheta' = (I - [dtheta_b]x) dtheta - db_g T
    db' = db

with dv_b and dtheta_b the bias-corrected body-frame velocity and angle increments
of the interval.  Process noise follows PX4's EKF2 parameters: (EKF2_ACC_NOISE T)^2
on each velocity axis, (EKF2_GYR_NOISE T)^2 on each angle, (EKF2_*_B_NOISE T)^2 on
the biases.  The defaults come from the simulator's IMU (sitl/sensors.py): a noise density
n (unit/sqrt(Hz)) is a rate noise of n/sqrt(T) over T = 20 ms, a bias random walk w
(unit/s/sqrt(Hz)) a bias noise of w/sqrt(T): the gyro's 1.87e-4 and 3.9e-5 give 0.0013 rad/s
and 2.7e-4 rad/s^2 (EKF2_GYR_NOISE 0.004 leaves room for the 50 Hz downsampling), the
accelerometer's walk 6e-3 gives EKF2_ACC_B_NOISE 0.04 m/s^3.  EKF2_ACC_NOISE (0.15 m/s^2)
is above the accelerometer's own 0.013: it also covers the tilt errors that turn gravity
into a false acceleration.

The state after a filter run at sample time t describes t + one IMU period: a sample
holds over the period that starts at its time stamp (the simulator steps on from it), and
the history of states kept for delayed fusion is stamped so.

Measurements, each fused as a scalar with an innovation gate (test ratio =
innovation^2 / (gate^2 S); > 1 is rejected, as in PX4's EKF2):

* GPS horizontal position and NED velocity, against the state at the time the fix
  describes (EKF2_GPS_DELAY, default the simulator's SIM_GPS_LAG_MS): the innovation is
  taken against the stored estimate of that time, interpolated between filter runs
  (:mod:`autopilot.estimation.state_history`), and the correction applied now; for position
  the Jacobian carries the lag (error then = dp - lag dv);
* barometer height (the height reference, as EKF2_HGT_REF = baro);
* the magnetometer: all three axes against the World Magnetic Model's field once the origin
  is known (:mod:`autopilot.estimation.mag_fusion`, EKF2_MAG_TYPE 0), which also observes
  roll and pitch and so separates a tilt from a horizontal accelerometer bias; or the
  tilt-compensated heading alone (EKF2_MAG_TYPE 1, and before the origin is known);
* a constant-position pseudo-measurement when nothing aids the filter (on the
  ground before the first fix, or after GPS is lost): PX4's "fake position" fusion,
  which keeps velocity and tilt bounded.

What is left out, and why: PX4's EKF2 and ArduPilot's EKF3 also estimate the
earth magnetic field and body magnetic bias and the wind (from airspeed or a drag
model).  Here the field is the model's and the magnetometer is taken as calibrated (the
simulator's offsets default to zero; one far off is caught by the field-strength check of
:mod:`autopilot.estimation.mag_health`); a multirotor without an airspeed sensor gains
little from wind states, and the position controller's integrator already holds against
wind.  A barometer bias state (EKF2 keeps one against GPS height) is not estimated: the
baro is the only height reference.  No GPS position-bias state: the receiver's slow wander
(a 60 s Gauss-Markov error, SIM_GPS_DRIFT) cannot be told from a position error without
another absolute reference, so it stays in the estimate whatever the filter does.

Why hand-written and not filterpy's ExtendedKalmanFilter: the attitude is a
quaternion kept outside the covariance (the error-state form), each correction is
injected multiplicatively and the error reset, measurements are delayed and fused
as sequential gated scalars.  filterpy's classes assume an additive state vector
updated in place and a full-vector update, so neither the quaternion nor the
gating per component fits them.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Sequence

import numpy as np

from autopilot.estimation.attitude_matrix import LazyAttitudeMatrix
from autopilot.estimation.ekf_transition import F_INDEX, N, f_blocks
from autopilot.estimation.state_history import state_at
from autopilot.parameters import ParamDef, param
from mavsim_core import quaternion as quat
from mavsim_core.constants import GRAVITY_M_S2
from mavsim_core.floats import floats3

_GRAVITY_M_S2 = float(GRAVITY_M_S2)
P, V, TH, BG, BA = slice(0, 3), slice(3, 6), slice(6, 9), slice(9, 12), slice(12, 15)

P_GYR_NOISE = param("EKF2_GYR_NOISE", 0.004, 0.0001, 0.1, "rad/s", "Rate gyro noise for covariance prediction")
P_ACC_NOISE = param("EKF2_ACC_NOISE", 0.15, 0.01, 2.0, "m/s^2", "Accelerometer noise for covariance prediction")
P_GYR_B_NOISE = param("EKF2_GYR_B_NOISE", 0.0003, 0.0, 0.01, "rad/s^2", "Process noise of the gyro bias")
P_ACC_B_NOISE = param("EKF2_ACC_B_NOISE", 0.04, 0.0, 0.1, "m/s^3", "Process noise of the accelerometer bias")
P_GPS_P_NOISE = param(
    "EKF2_GPS_P_NOISE", 0.15, 0.01, 10.0, "m", "GPS position measurement noise (minimum; eph if larger)"
)
P_GPS_V_NOISE = param("EKF2_GPS_V_NOISE", 0.1, 0.01, 5.0, "m/s", "GPS velocity measurement noise")
P_BARO_NOISE = param("EKF2_BARO_NOISE", 0.08, 0.01, 15.0, "m", "Barometer height measurement noise")
P_HEAD_NOISE = param("EKF2_HEAD_NOISE", 0.1, 0.01, 1.0, "rad", "Magnetometer heading measurement noise")
P_GPS_P_GATE = param("EKF2_GPS_P_GATE", 5.0, 1.0, 20.0, "SD", "Innovation gate of GPS position (standard deviations)")
P_GPS_V_GATE = param("EKF2_GPS_V_GATE", 5.0, 1.0, 20.0, "SD", "Innovation gate of GPS velocity (standard deviations)")
P_BARO_GATE = param("EKF2_BARO_GATE", 5.0, 1.0, 20.0, "SD", "Innovation gate of barometer height (standard deviations)")
P_HDG_GATE = param(
    "EKF2_HDG_GATE", 2.6, 1.0, 20.0, "SD", "Innovation gate of magnetometer heading (standard deviations)"
)
P_NOAID_NOISE = param(
    "EKF2_NOAID_NOISE", 10.0, 0.5, 50.0, "m",
    "Noise of the constant-position pseudo-measurement fused when nothing aids the filter in flight",
)  # fmt: skip

# The parameters this module reads (listed in autopilot/param_catalogue.py).
PARAMS: tuple[ParamDef, ...] = (
    P_GYR_NOISE,
    P_ACC_NOISE,
    P_GYR_B_NOISE,
    P_ACC_B_NOISE,
    P_GPS_P_NOISE,
    P_GPS_V_NOISE,
    P_BARO_NOISE,
    P_HEAD_NOISE,
    P_GPS_P_GATE,
    P_GPS_V_GATE,
    P_BARO_GATE,
    P_HDG_GATE,
    P_NOAID_NOISE,
)

_FAKE_POS_NOISE_GROUND_M = 0.5  # at rest on the ground before the first fix
_MIN_VAR = np.array([1e-6] * 6 + [1e-9] * 3 + [1e-12] * 6)
_MAX_VAR = np.array([1e6] * 6 + [1.0] * 3 + [0.01] * 3 + [1.0] * 3)


class ErrorStateEkf(LazyAttitudeMatrix):
    """The filter; :class:`autopilot.estimation.estimator.Estimator` feeds it and reads it."""

    def __init__(self) -> None:
        self.p = np.zeros(3)
        self.v = np.zeros(3)
        self._r_ned_frd: np.ndarray | None = None  # to_matrix(q), made when first asked for (r_ned_frd)
        self.q = np.array([1.0, 0.0, 0.0, 0.0])
        self.bg = np.zeros(3)
        self.ba = np.zeros(3)
        self.cov = np.zeros((N, N))
        self.accel_ned = np.zeros(3)  # kinematic acceleration (gravity removed), m/s^2
        self.initialised = False
        self.time_aligned_s = 0.0
        self.gyr_noise = P_GYR_NOISE.default
        self.acc_noise = P_ACC_NOISE.default
        self.gyr_b_noise = P_GYR_B_NOISE.default
        self.acc_b_noise = P_ACC_B_NOISE.default
        # (time_us, position, velocity) after each prediction: the estimate a delayed fix is compared with.
        self.history: deque[tuple[int, np.ndarray, np.ndarray]] = deque(maxlen=32)
        # Latest test ratios (innovation^2 / (gate^2 S)), PX4's ESTIMATOR_STATUS quantities.
        self.ratio = {"pos": 0.0, "vel": 0.0, "hgt": 0.0, "mag": 0.0}
        self.rejected = {"pos": 0, "vel": 0, "hgt": 0, "mag": 0}
        self._batch_kind: str | None = None  # scalars of one sensor being fused together
        self._f = np.eye(N)  # state transition of one prediction (blocks rewritten each time)
        self._fp = np.empty((N, N))  # F P, a buffer of predict()
        self._q_key: tuple | None = None
        self._q_diag = np.zeros(N)
        self._predictions = 0
        self.time_us: int | None = None  # what the state describes (the latest prediction's time stamp), µs

    # -- set-up ---------------------------------------------------------------------------
    def initialise(self, q: np.ndarray, time_s: float = 0.0) -> None:
        """Start from a levelled attitude (from gravity and magnetometer) at rest."""
        self.q = q / np.linalg.norm(q)
        self.p[:] = 0.0
        self.v[:] = 0.0
        self.cov = np.diag(
            np.concatenate(([1.0] * 3, [0.25] * 3, [0.05**2, 0.05**2, 0.15**2], [0.01**2] * 3, [0.1**2] * 3))
        )
        self.initialised = True
        self.time_aligned_s = 0.0

    def reset_position(self, pos_ned_m: np.ndarray, var_m2: float, axes: slice = slice(0, 3)) -> np.ndarray:
        """Set the position on some axes (decorrelating them); return the change (m)."""
        old = self.p.copy()
        self.p[axes] = pos_ned_m[axes]
        self.cov[axes, :] = 0.0
        self.cov[:, axes] = 0.0
        idx = range(axes.start, axes.stop)
        for i in idx:
            self.cov[i, i] = var_m2
        for t, pos, _ in self.history:
            pos[axes] += (self.p - old)[axes]
        return self.p - old

    def reset_velocity(self, vel_ned_m_s: np.ndarray, var: float, tilt_std_rad: float = 0.0) -> None:
        """Set the velocity (decorrelated, variance ``var``); ``tilt_std_rad`` > 0 also widens the roll and
        pitch uncertainty to at least that (an inertial solution gone wrong: the tilt is the likely cause)."""
        delta = vel_ned_m_s - self.v
        self.v[:] = vel_ned_m_s
        self.cov[V, :] = 0.0
        self.cov[:, V] = 0.0
        self.cov[3, 3] = self.cov[4, 4] = self.cov[5, 5] = var
        for i in (6, 7):
            self.cov[i, i] = max(self.cov[i, i], tilt_std_rad * tilt_std_rad)
        for _, _, vel in self.history:
            vel += delta

    def rotate_yaw(self, angle_rad: float) -> None:
        """Turn the attitude about NED down by ``angle_rad`` (e.g. when the declination becomes known)."""
        half = 0.5 * angle_rad
        self.q = quat.mul(np.array([math.cos(half), 0.0, 0.0, math.sin(half)]), self.q)

    # -- prediction -------------------------------------------------------------------------
    def predict(
        self, dtheta_frd: np.ndarray | Sequence[float], dvel_frd: np.ndarray | Sequence[float], t: float, time_us: int
    ) -> None:
        """Advance over ``t`` seconds of IMU data: ``dtheta_frd`` (rad) and ``dvel_frd`` (m/s) are the
        summed gyro and accelerometer increments of the interval (PX4's downsampled delta angle and
        delta velocity), biases not yet removed; 3-vectors (arrays or sequences of floats).

        The 3-vector and quaternion part on plain floats, the covariance with NumPy."""
        if t <= 0.0:
            return
        (a0, a1, a2), (b0, b1, b2) = floats3(dtheta_frd), floats3(dvel_frd)
        (bg0, bg1, bg2), (ba0, ba1, ba2) = self.bg.tolist(), self.ba.tolist()
        d0, d1, d2 = a0 - bg0 * t, a1 - bg1 * t, a2 - bg2 * t  # bias-corrected delta angle
        u0, u1, u2 = b0 - ba0 * t, b1 - ba1 * t, b2 - ba2 * t  # bias-corrected delta velocity (FRD)
        # Velocity increment rotated with the attitude at the middle of the interval.
        qw, qx, qy, qz = self._q.tolist()
        m = quat.matrix_floats(*quat.integrate_floats(qw, qx, qy, qz, d0, d1, d2, 0.5))
        dv0 = m[0] * u0 + m[1] * u1 + m[2] * u2
        dv1 = m[3] * u0 + m[4] * u1 + m[5] * u2
        dv2 = m[6] * u0 + m[7] * u1 + m[8] * u2 + _GRAVITY_M_S2 * t
        (p0, p1, p2), (v0, v1, v2) = self.p.tolist(), self.v.tolist()
        self.p[:] = (p0 + (v0 + 0.5 * dv0) * t, p1 + (v1 + 0.5 * dv1) * t, p2 + (v2 + 0.5 * dv2) * t)
        self.v[:] = (v0 + dv0, v1 + dv1, v2 + dv2)
        self.accel_ned = np.array((dv0 / t, dv1 / t, dv2 / t))
        q = quat.integrate_floats(qw, qx, qy, qz, d0, d1, d2, 1.0)
        self.q = np.array(q)
        r = quat.matrix_floats(*q)
        self._r_ned_frd = np.array(r).reshape(3, 3)
        self.time_aligned_s += t
        f = self._f
        f[0, 3] = f[1, 4] = f[2, 5] = t
        f.put(F_INDEX, f_blocks(r, (u0, u1, u2), (d0, d1, d2), t))
        c = np.dot(np.dot(f, self.cov, out=self._fp), f.T)  # F P F^T (F P into a buffer kept for it)
        c.ravel()[:: N + 1] += self._process_noise(t)  # (c is contiguous: ravel is a view)
        self._predictions += 1
        if self._predictions % 10 == 0:  # keep P symmetric and its variances sane (once per 0.2 s)
            c = 0.5 * (c + c.T)
            self.cov = c
            self._condition()
        else:
            self.cov = c
        self.time_us = time_us
        self.history.append((time_us, self.p.copy(), self.v.copy()))

    def _process_noise(self, t: float) -> np.ndarray:
        """Diagonal of Q for an interval of t seconds (cached: t is nearly always the same)."""
        key = (t, self.acc_noise, self.gyr_noise, self.gyr_b_noise, self.acc_b_noise)
        if key != self._q_key:
            qa, qg = (self.acc_noise * t) ** 2, (self.gyr_noise * t) ** 2
            qbg, qba = (self.gyr_b_noise * t) ** 2, (self.acc_b_noise * t) ** 2
            self._q_diag = np.array([0.0] * 3 + [qa] * 3 + [qg] * 3 + [qbg] * 3 + [qba] * 3)
            self._q_key = key
        return self._q_diag

    def _condition(self) -> None:
        """Keep the variances inside sane bounds (a numerically broken P must not blow up the state)."""
        d = np.diagonal(self.cov)
        if np.any(d < _MIN_VAR) or np.any(d > _MAX_VAR):
            idx = np.arange(N)
            self.cov[idx, idx] = np.clip(d, _MIN_VAR, _MAX_VAR)

    def state_at(self, time_us: int) -> tuple[np.ndarray, np.ndarray] | tuple[None, None]:
        """Position and velocity estimate stored nearest to an earlier time (None if not reached)."""
        return state_at(self.history, time_us)

    # -- corrections ----------------------------------------------------------------------------
    def inject(self, dx: np.ndarray) -> None:
        """Add an error-state correction to the nominal state (attitude multiplicatively)."""
        d = dx.tolist()
        (p0, p1, p2), (v0, v1, v2) = self.p.tolist(), self.v.tolist()
        self.p[:] = (p0 + d[0], p1 + d[1], p2 + d[2])
        self.v[:] = (v0 + d[3], v1 + d[4], v2 + d[5])
        w, x, y, z = self._q.tolist()
        a, b, c = 0.5 * d[6], 0.5 * d[7], 0.5 * d[8]
        qn = (
            w - x * a - y * b - z * c,
            x + w * a + y * c - z * b,
            y + w * b + z * a - x * c,
            z + w * c + x * b - y * a,
        )
        k = 1.0 / math.sqrt(qn[0] * qn[0] + qn[1] * qn[1] + qn[2] * qn[2] + qn[3] * qn[3])
        self.q = np.array((qn[0] * k, qn[1] * k, qn[2] * k, qn[3] * k))
        (g0, g1, g2), (b0, b1, b2) = self.bg.tolist(), self.ba.tolist()
        self.bg[:] = (g0 + d[9], g1 + d[10], g2 + d[11])
        self.ba[:] = (b0 + d[12], b1 + d[13], b2 + d[14])

    def fuse_state(
        self, i: int, innovation: float, r: float, gate: float, kind: str | None = None, lag_s: float = 0.0
    ) -> bool:
        """Fuse a direct measurement of error-state element ``i``; False if the gate rejects it.

        ``lag_s`` > 0 (position elements only): the measurement describes the position ``lag_s`` ago, whose
        error is dp - lag_s dv in terms of the current errors (the Jacobian then has -lag_s on velocity)."""
        c = self.cov
        if lag_s > 0.0:
            j = i + 3
            ph = c[:, i] - lag_s * c[:, j]
            s = ph[i] - lag_s * ph[j] + r
        else:
            ph = c[:, i]
            s = ph[i] + r
        ratio = innovation * innovation / (gate * gate * s)
        if kind is not None:
            self.ratio[kind] = max(self.ratio[kind], ratio) if kind == self._batch_kind else ratio
        if ratio > 1.0:
            if kind is not None:
                self.rejected[kind] += 1
            return False
        k = ph / s
        c -= k[:, None] * ph  # k ph^T (in place: ph, a column of c, is read before)
        self.inject(k * innovation)
        return True

    def fuse(self, h: np.ndarray, innovation: float, r: float, gate: float, kind: str | None = None) -> bool:
        """Fuse a scalar measurement with Jacobian ``h`` (15,); False if the gate rejects it."""
        ph = self.cov @ h
        s = float(h @ ph) + r
        ratio = innovation * innovation / (gate * gate * s)
        if kind is not None:
            self.ratio[kind] = ratio
        if ratio > 1.0:
            if kind is not None:
                self.rejected[kind] += 1
            return False
        k = ph / s
        self.cov = self.cov - np.outer(k, ph)
        self.inject(k * innovation)
        return True

    def fuse_vector(
        self, first: int, values: np.ndarray, then: np.ndarray, r: float, gate: float, kind: str, lag_s: float = 0.0
    ) -> int:
        """Fuse consecutive direct measurements (e.g. velocity N, E, D) of error-state elements
        ``first``...; ``then`` is the state they are compared with, of ``lag_s`` ago (see :meth:`fuse_state`).
        Returns how many were rejected."""
        self._batch_kind = kind
        self.ratio[kind] = 0.0
        rejected = 0
        current = self.p if first < 3 else self.v
        offset = first if first < 3 else first - 3
        n = len(values)
        then = np.array(then[:n], dtype=float)
        for j in range(n):
            before = current[offset : offset + n].copy()
            if not self.fuse_state(first + j, float(values[j] - then[j]), r, gate, kind, lag_s):
                rejected += 1
            # Later components are compared with the delayed estimate moved by this correction.
            then += current[offset : offset + n] - before
        self._batch_kind = None
        return rejected

    def heading_jacobian(self) -> np.ndarray:
        """d(yaw)/d(error state): yaw (3-2-1) moves with the body-frame angle error through R."""
        r = self.r_ned_frd
        yaw = math.atan2(r[1, 0], r[0, 0])
        pitch = -math.asin(max(-1.0, min(1.0, r[2, 0])))
        tp = math.tan(pitch)
        hw = np.array([tp * math.cos(yaw), tp * math.sin(yaw), 1.0])
        h = np.zeros(N)
        h[TH] = hw @ r
        return h

    # -- outputs --------------------------------------------------------------------------
    def horizontal_pos_std_m(self) -> float:
        return math.sqrt(max(self.cov[0, 0], self.cov[1, 1]))

    def vertical_pos_std_m(self) -> float:
        return math.sqrt(self.cov[2, 2])

    def tilt_std_rad(self) -> float:
        return math.sqrt(max(self.cov[6, 6], self.cov[7, 7]))

    def yaw_std_rad(self) -> float:
        h = self.heading_jacobian()
        return math.sqrt(float(h @ self.cov @ h))
