"""filterpy's unscented Kalman filter with its per-sigma-point Python loops done on whole arrays.

:class:`RowsUKF` is filterpy's ``UnscentedKalmanFilter`` (its predict, update and the IMM that drives it unchanged)
with four of its steps computed on all sigma points at once:

* the process model: ``fx_rows(sigmas, dt)`` moves every sigma point (rows) in one call, where filterpy calls
  ``fx`` once per point;
* the cross variance of state and measurement: one weighted matrix product, where filterpy sums an outer product
  per point;
* the log-likelihood of the latest measurement: the Gaussian's closed form on the innovation ``y`` and its
  covariance ``S`` (a Cholesky factor), where filterpy builds a ``scipy.stats.multivariate_normal`` each time;
* the sigma points (:class:`RowsMerweSigmaPoints`): Van der Merwe's scaled points from a NumPy Cholesky factor,
  added in one step, where filterpy loops over the state's dimensions and calls SciPy's Cholesky.

The same filter to rounding: ``tests/test_fast_ukf.py`` runs both side by side.  Issue 38: the deck's IMM
(:mod:`autopilot.navigation.deck_turn_filter`) cost the flight controller 1.2 ms a camera fix, in the 50 Hz outer
loop that the simulator's next step waits for.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter

_LOG_2PI = math.log(2.0 * math.pi)


def upper_cholesky(a: np.ndarray) -> np.ndarray:
    """``U`` with ``U.T @ U == a`` (what filterpy's sigma points take from SciPy's ``cholesky``), from NumPy's
    lower factor; LinAlgError if ``a`` is not positive definite."""
    return np.linalg.cholesky(a).T


class RowsMerweSigmaPoints(MerweScaledSigmaPoints):
    """Van der Merwe's scaled sigma points (filterpy's weights and ordering: the mean, then ``x + U[k]``, then
    ``x - U[k]``), computed in one step from a NumPy Cholesky factor."""

    def __init__(self, n: int, alpha: float, beta: float, kappa: float) -> None:
        super().__init__(n, alpha, beta, kappa, sqrt_method=upper_cholesky)

    def sigma_points(self, x, P) -> np.ndarray:
        x = np.asarray(x, dtype=float).reshape(-1)
        n = self.n
        if x.size != n:
            raise ValueError(f"expected a state of {n}, got {x.size}")
        lambda_ = self.alpha**2 * (n + self.kappa) - n
        u = upper_cholesky((lambda_ + n) * np.atleast_2d(P))
        return np.vstack((x, x + u, x - u))


class RowsUKF(UnscentedKalmanFilter):
    """filterpy's UKF whose process model ``fx_rows(sigmas, dt)`` moves all sigma points at once (rows of a
    ``(2n + 1, n)`` array); ``points`` must be :class:`RowsMerweSigmaPoints`'s kind (see the module docstring).
    ``hx`` is called per sigma point, as filterpy does."""

    x: np.ndarray  # (filterpy's state and covariance, declared for the type checker)
    P: np.ndarray
    _log_likelihood: float | None

    def __init__(
        self,
        dim_x: int,
        dim_z: int,
        dt: float,
        hx: Callable,
        fx_rows: Callable[[np.ndarray, float], np.ndarray],
        points: MerweScaledSigmaPoints,
    ) -> None:
        self.fx_rows = fx_rows
        super().__init__(dim_x, dim_z, dt, hx, self._fx_one, points)

    def _fx_one(self, x: np.ndarray, dt: float) -> np.ndarray:
        """One point through ``fx_rows`` (filterpy's ``fx``, for whoever calls it directly)."""
        return self.fx_rows(np.atleast_2d(x), dt)[0]

    def compute_process_sigmas(self, dt, fx=None, **fx_args) -> None:
        sigmas = self.points_fn.sigma_points(self.x, self.P)
        if fx is None or fx == self._fx_one:
            self.sigmas_f = self.fx_rows(sigmas, dt)
        else:  # (another model for this call: filterpy's way)
            self.sigmas_f = np.array([fx(s, dt, **fx_args) for s in sigmas])

    def update(self, z, R=None, UT=None, hx=None, **hx_args) -> None:
        """filterpy's update (the same posterior, innovation, its covariance and gain, kept under the same names) in a
        few array operations, with plain means and residuals; ``hx`` may carry ``hx.rows(sigmas, **hx_args)``, the
        measurement of all sigma points at once.  Anything else (no measurement, another unscented transform, custom
        means or residuals) is filterpy's own update."""
        plain = self.x_mean is None and self.z_mean is None and self.residual_z is np.subtract
        if z is None or UT is not None or not plain or self.residual_x is not np.subtract:
            super().update(z, R, UT, hx, **hx_args)
            return
        hx = self.hx if hx is None else hx
        if R is None:
            R = self.R
        elif np.isscalar(R):
            R = np.eye(self._dim_z) * float(R)  # type: ignore[arg-type]  # (a scalar: np.isscalar said so)
        sigmas = self.sigmas_f
        rows = getattr(hx, "rows", None)
        h = rows(sigmas, **hx_args) if rows is not None else np.array([hx(s, **hx_args) for s in sigmas])
        self.sigmas_h = h = np.atleast_2d(h).reshape(len(sigmas), -1)
        zp = self.Wm @ h
        dz = h - zp
        wdz = self.Wc[:, None] * dz
        self.S = s_cov = dz.T @ wdz + R
        self.SI = self.inv(s_cov)
        pxz = (sigmas - self.x).T @ wdz
        self.K = k = pxz @ self.SI
        self.y = y = np.asarray(z, dtype=float).reshape(-1) - zp
        self.x = self.x + k @ y
        self.P = self.P - k @ (s_cov @ k.T)
        self.z = np.array(z, dtype=float, copy=True)
        self.x_post, self.P_post = self.x.copy(), self.P.copy()
        self._log_likelihood = self._likelihood = self._mahalanobis = None

    def cross_variance(self, x, z, sigmas_f, sigmas_h) -> np.ndarray:
        """``sum_i Wc[i] (sigmas_f[i] - x) (sigmas_h[i] - z)^T`` (plain differences: this filter's residuals)."""
        return (self.Wc[:, None] * (sigmas_f - x)).T @ (sigmas_h - z)

    @property
    def log_likelihood(self) -> float:
        """The log-density of the latest innovation ``y`` under N(0, S) (filterpy's, from its closed form)."""
        if self._log_likelihood is None:
            self._log_likelihood = gaussian_log_density(np.asarray(self.y, dtype=float).reshape(-1), self.S)
        return self._log_likelihood


def gaussian_log_density(y: np.ndarray, cov) -> float:
    """log N(y; 0, cov), for an innovation of any size (of 1 or 2, the usual ones here, in plain floats); -inf when
    ``cov`` is not positive definite (filterpy then floors the likelihood at the smallest float)."""
    c = np.atleast_2d(cov)
    if y.size == 1:
        var = float(c[0, 0])
        return -0.5 * (_LOG_2PI + math.log(var) + float(y[0]) ** 2 / var) if var > 0.0 else -math.inf
    if y.size == 2:
        a, b, d = float(c[0, 0]), 0.5 * (float(c[0, 1]) + float(c[1, 0])), float(c[1, 1])
        det = a * d - b * b
        if a <= 0.0 or det <= 0.0:
            return -math.inf
        y0, y1 = float(y[0]), float(y[1])
        return -0.5 * (2.0 * _LOG_2PI + math.log(det) + (d * y0 * y0 - 2.0 * b * y0 * y1 + a * y1 * y1) / det)
    try:
        low = np.linalg.cholesky(c)
    except np.linalg.LinAlgError:
        return -math.inf
    w = np.linalg.solve(low, y)
    return -0.5 * (y.size * _LOG_2PI + float(w @ w)) - float(np.log(np.diag(low)).sum())
