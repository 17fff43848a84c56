"""The source document's alternative predictor: a 4th-order polynomial fit of the target's
absolute track, per NED axis, used to predict where it will be a given time ahead.

Samples are the target's absolute position (NED metres, e.g. vehicle position plus a
measured relative position) with their timestamps (microseconds).  With fewer than
``min_samples`` (at least 100) in the window the prediction is invalid.  The output is
the same :class:`LandingTargetEstimate` as the Kalman estimator's, so the two are
interchangeable.  Pure numpy; time is an input.
"""

from __future__ import annotations

from collections import deque

import numpy as np
from numpy.polynomial import Polynomial

from autopilot.topics import LandingTargetEstimate

DEGREE = 4
MIN_SAMPLES = 100


class PolynomialTargetPredictor:
    """Keeps the last ``window`` samples; :meth:`predict` fits and extrapolates."""

    def __init__(self, window: int = 150, min_samples: int = MIN_SAMPLES) -> None:
        if min_samples < MIN_SAMPLES or window < min_samples:
            raise ValueError("need min_samples >= 100 and window >= min_samples")
        self.min_samples = min_samples
        self._t_us: deque[int] = deque(maxlen=window)
        self._pos: deque[np.ndarray] = deque(maxlen=window)
        self.last_acc_ned_m_s2 = np.zeros(3)  # acceleration of the latest prediction (m/s^2, NED)

    def add_sample(self, timestamp_us: int, target_pos_ned_m: np.ndarray) -> None:
        p = np.asarray(target_pos_ned_m, dtype=float)
        if p.shape == (3,) and np.all(np.isfinite(p)) and (not self._t_us or timestamp_us > self._t_us[-1]):
            self._t_us.append(int(timestamp_us))
            self._pos.append(p.copy())

    def reset(self) -> None:
        self._t_us.clear()
        self._pos.clear()

    def predict(
        self,
        timestamp_us: int,
        ahead_s: float,
        vehicle_pos_ned_m: np.ndarray,
        vehicle_vel_ned_m_s: np.ndarray | None = None,
    ) -> LandingTargetEstimate:
        """The target at ``timestamp_us + ahead_s``, relative to the vehicle's position now."""
        if len(self._t_us) < self.min_samples:
            zero = np.zeros(3)
            return LandingTargetEstimate(timestamp_us, zero, zero.copy(), False)
        t = (np.array(self._t_us, dtype=float) - self._t_us[-1]) * 1e-6
        t_pred = (timestamp_us - self._t_us[-1]) * 1e-6 + ahead_s
        pos_hist = np.array(self._pos)
        fits = [Polynomial.fit(t, pos_hist[:, i], DEGREE) for i in range(3)]
        target_pos = np.array([f(t_pred) for f in fits])
        target_vel = np.array([f.deriv()(t_pred) for f in fits])
        self.last_acc_ned_m_s2 = np.array([f.deriv(2)(t_pred) for f in fits])  # the fit's own acceleration
        resid_var = np.array([np.mean((f(t) - pos_hist[:, i]) ** 2) for i, f in enumerate(fits[:2])])
        v_vel = np.zeros(3) if vehicle_vel_ned_m_s is None else np.asarray(vehicle_vel_ned_m_s, dtype=float)
        rel_pos = target_pos - np.asarray(vehicle_pos_ned_m, dtype=float)
        tv = None if vehicle_vel_ned_m_s is None else target_vel
        return LandingTargetEstimate(timestamp_us, rel_pos, target_vel - v_vel, True, False, tv, resid_var)
