"""PX4's landing target estimator: a Kalman filter per horizontal axis on the target's
position and velocity relative to the vehicle.

State per axis (north, east): [relative position m, relative velocity m/s], where
relative = target minus vehicle, NED.  Prediction takes the vehicle's acceleration
(NED, m/s^2) as input (the target is assumed unaccelerated; its acceleration and the
accelerometer noise are the process noise ``LTEST_ACC_UNC``).  Measurements are
:class:`LandingTargetMeasurement` records; each axis's innovation is gated with a
chi-square test (1 degree of freedom) and rejected outliers leave the state unchanged; after
``RESET_AFTER_REJECTS`` refusals in a row the next measurement restarts the filter.
Without an accepted measurement for ``LTEST_TIMEOUT`` seconds the estimate is invalid
and the next measurement re-initialises the filter.  Time is an input (microseconds).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np

from autopilot.parameters import ParamDef, ParamType, param
from autopilot.topics import LandingTargetEstimate, LandingTargetMeasurement

if TYPE_CHECKING:
    from filterpy.kalman import KalmanFilter

CHI2_GATE_1DOF = 6.63  # 99 % of a chi-square with 1 degree of freedom
# (ours) The filter restarts on the measurement after this many consecutive gate refusals: a model gone wrong
# (a deck that set off while the filter held it still, a few noisy first fixes) would otherwise refuse every
# later fix until LTEST_TIMEOUT, while the marker is in view.
RESET_AFTER_REJECTS = 3

PARAMS: tuple[ParamDef, ...] = (
    param("LTEST_MODE", 0, 0, 1, "-", "Landing target mode: 0 moving, 1 stationary (PX4)", ParamType.INT32),
    param("LTEST_ACC_UNC", 10.0, 0.01, 1000.0, "(m/s^2)^2", "Acceleration variance of the prediction (PX4)"),
    param("LTEST_MEAS_UNC", 0.005, 0.0, 10.0, "tan(rad)^2", "Measurement variance per metre^2 of range (PX4)"),
    param("LTEST_POS_UNC_IN", 0.1, 0.001, 100.0, "m^2", "Initial relative position variance (PX4)"),
    param("LTEST_VEL_UNC_IN", 0.1, 0.001, 100.0, "(m/s)^2", "Initial relative velocity variance (PX4)"),
    param("LTEST_SCALE_X", 1.0, 0.01, 100.0, "-", "Scale of the north measurement (PX4: sensor x)"),
    param("LTEST_SCALE_Y", 1.0, 0.01, 100.0, "-", "Scale of the east measurement (PX4: sensor y)"),
    param("LTEST_TIMEOUT", 2.0, 0.1, 60.0, "s", "Estimate invalid after this long without a measurement (ours)"),
)


@dataclass(frozen=True, slots=True)
class LandingTargetSettings:
    """The estimator's parameters, in their parameter units."""

    static: bool = False
    acc_unc: float = 10.0
    meas_unc: float = 0.005
    pos_unc_in: float = 0.1
    vel_unc_in: float = 0.1
    scale_x: float = 1.0
    scale_y: float = 1.0
    timeout_s: float = 2.0

    @staticmethod
    def from_params(get: Callable[[str], float]) -> LandingTargetSettings:
        return LandingTargetSettings(
            static=int(get("LTEST_MODE")) == 1,
            acc_unc=get("LTEST_ACC_UNC"),
            meas_unc=get("LTEST_MEAS_UNC"),
            pos_unc_in=get("LTEST_POS_UNC_IN"),
            vel_unc_in=get("LTEST_VEL_UNC_IN"),
            scale_x=get("LTEST_SCALE_X"),
            scale_y=get("LTEST_SCALE_Y"),
            timeout_s=get("LTEST_TIMEOUT"),
        )


def _axis_filter(pos: float, vel: float, s: LandingTargetSettings) -> KalmanFilter:
    # filterpy is imported with the first target seen: its package imports scipy.stats, 0.7 s of CPU that
    # every flight controller paid at start-up though most flights never see a landing target.
    from filterpy.kalman import KalmanFilter

    kf = KalmanFilter(dim_x=2, dim_z=1, dim_u=1)
    kf.x = np.array([[pos], [vel]])
    kf.P = np.diag([s.pos_unc_in, s.vel_unc_in])
    kf.H = np.array([[1.0, 0.0]])
    return kf


class LandingTargetEstimator:
    """Feed :meth:`predict` with the vehicle's acceleration and :meth:`update` with measurements."""

    def __init__(self, settings: LandingTargetSettings | None = None) -> None:
        self.settings = settings or LandingTargetSettings()
        self._axes: list[KalmanFilter] | None = None
        self._t_us = 0
        self._last_meas_us = 0
        self._accel_ne = np.zeros(2)
        self._rel_down_m = 0.0
        self.rejected_count = 0
        self._rejected_in_row = 0  # consecutive measurements refused by the gate

    def set_settings(self, settings: LandingTargetSettings) -> None:
        self.settings = settings

    def _timed_out(self, t_us: int) -> bool:
        return self._axes is None or (t_us - self._last_meas_us) * 1e-6 > self.settings.timeout_s

    def predict(self, timestamp_us: int, vehicle_accel_ned_m_s2: np.ndarray) -> None:
        """Advance to ``timestamp_us`` with the vehicle's acceleration (used until the next call)."""
        self._advance(timestamp_us)
        self._accel_ne = np.asarray(vehicle_accel_ned_m_s2, dtype=float)[:2].copy()

    def _advance(self, t_us: int) -> None:
        dt = (t_us - self._t_us) * 1e-6
        if self._axes is None or dt <= 0.0:
            self._t_us = max(self._t_us, t_us)
            return
        f = np.array([[1.0, dt], [0.0, 1.0]])
        b = np.array([[-0.5 * dt * dt], [-dt]])  # relative = target - vehicle
        q = b @ b.T * self.settings.acc_unc
        for kf, a in zip(self._axes, self._accel_ne):
            kf.predict(u=np.array([[a]]), B=b, F=f, Q=q)
        self._t_us = t_us

    def update(self, meas: LandingTargetMeasurement, vehicle_vel_ned_m_s: np.ndarray | None = None) -> bool:
        """Fuse one measurement; False if it was refused (invalid, stale, or an outlier).

        ``vehicle_vel_ned_m_s`` (NED, m/s): the vehicle's velocity, used when the measurement (re)starts the
        filter: the target is then taken as still over the ground (relative velocity = minus the vehicle's, as
        PX4's estimator starts), not as moving with the vehicle; a vehicle still braking when it first sees a
        standing deck would otherwise fly after a deck "moving" at its own speed.  None: relative velocity 0.
        """
        rel = np.asarray(meas.rel_pos_ned_m, dtype=float)
        if not meas.valid or not np.all(np.isfinite(rel)) or meas.timestamp_us < self._last_meas_us:
            return False
        scaled = rel[:2] * np.array([self.settings.scale_x, self.settings.scale_y])
        r_var = meas.std_m**2 if math.isfinite(meas.std_m) else self.settings.meas_unc * max(float(rel[2]) ** 2, 1.0)
        if not self._timed_out(meas.timestamp_us):
            self._advance(meas.timestamp_us)
        if self._timed_out(meas.timestamp_us) or self._rejected_in_row >= RESET_AFTER_REJECTS:
            v0 = np.zeros(2) if vehicle_vel_ned_m_s is None else -np.asarray(vehicle_vel_ned_m_s, dtype=float)[:2]
            self._axes = [_axis_filter(float(p), float(v), self.settings) for p, v in zip(scaled, v0)]
            self._t_us = meas.timestamp_us
        elif not self._gate(scaled, r_var):
            self.rejected_count += 1
            self._rejected_in_row += 1
            return False
        else:
            assert self._axes is not None  # (not timed out: the filters exist)
            for kf, z in zip(self._axes, scaled):
                kf.update(np.array([[z]]), R=np.array([[r_var]]))
        self._rejected_in_row = 0
        self._last_meas_us = meas.timestamp_us
        self._rel_down_m = float(rel[2])
        return True

    def _gate(self, z_ne: np.ndarray, r_var: float) -> bool:
        assert self._axes is not None
        for kf, z in zip(self._axes, z_ne):
            innov = z - float(kf.x[0, 0])
            s = float(kf.P[0, 0]) + r_var
            if innov * innov / s > CHI2_GATE_1DOF:
                return False
        return True

    def estimate(self, timestamp_us: int, vehicle_vel_ned_m_s: np.ndarray | None = None) -> LandingTargetEstimate:
        """The state predicted to ``timestamp_us`` (the filter itself is not advanced)."""
        if self._timed_out(timestamp_us):
            zero = np.zeros(3)
            return LandingTargetEstimate(timestamp_us, zero, zero.copy(), False, self.settings.static)
        assert self._axes is not None
        dt = max(0.0, (timestamp_us - self._t_us) * 1e-6)
        pos = np.array([kf.x[0, 0] + kf.x[1, 0] * dt - 0.5 * a * dt * dt for kf, a in zip(self._axes, self._accel_ne)])
        vel = np.array([kf.x[1, 0] - a * dt for kf, a in zip(self._axes, self._accel_ne)])
        rel_pos = np.array([pos[0], pos[1], self._rel_down_m])
        rel_vel = np.array([vel[0], vel[1], 0.0])
        target_vel = None
        if vehicle_vel_ned_m_s is not None:
            target_vel = rel_vel + np.asarray(vehicle_vel_ned_m_s, dtype=float)
            target_vel[2] = 0.0
        var = np.array([kf.P[0, 0] for kf in self._axes])
        return LandingTargetEstimate(timestamp_us, rel_pos, rel_vel, True, self.settings.static, target_vel, var)
