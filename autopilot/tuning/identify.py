"""Identify one axis' body-rate plant from logged (alpha_sp, rate) samples.

The rate controller outputs an angular-acceleration setpoint ``alpha_sp`` (rad/s^2); the mixer and the
motors turn it into torque, so per FRD axis the plant is

    rate(s) / alpha_sp(s) = b e^{-s d} / (s (tau s + 1))

with ``b`` the effectiveness (1 when the model's inertia and rotor constants are right), ``tau`` the
motor lag (s) and ``d`` the transport delay (a whole number of control periods here).  Sampled with a
zero-order hold at period T (phi = e^{-T/tau}), the rate's first difference dy[k] = y[k] - y[k-1]
(angular acceleration x T) obeys the discrete ARX model

    dy[k] = phi dy[k-1] + b (b1 u[k-1-n] + b2 u[k-2-n]) + c,
    b1 = T - tau (1 - phi),  b2 = tau (1 - phi) - T phi,

where ``c`` takes in a constant disturbance torque.  For each delay n and motor lag tau the model's
response to u is a regressor in which b and c are linear, so they come from one least-squares solve
(numpy.linalg.lstsq); tau is found by a grid then a golden-section search, n by trying 0..``max_delay``.
Fitting the simulated response (output error) rather than the one-step prediction keeps gyro noise out
of the regressors, so the estimate is not biased by it.

Pure: arrays in, a frozen record out; no clock.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mavsim_core.butterworth import lowpass2

TAU_MIN_S = 0.002
TAU_MAX_S = 0.5
_GRID = 40  # log-spaced motor lags tried before the golden-section refinement
_GOLDEN_STEPS = 30
PREFILTER_HZ = 40.0  # both sides of the fit are low-passed here (2nd-order Butterworth at SAMPLE_HZ) ...
SAMPLE_HZ = 250.0  # ... which leaves the model's relation unchanged and the gyro noise mostly out
_PREFILTER = lowpass2(PREFILTER_HZ, SAMPLE_HZ)


def lfilter(b, a, x: np.ndarray) -> np.ndarray:
    """``scipy.signal.lfilter``, imported when an autotune first identifies a plant: importing scipy.signal
    costs 0.8 CPU s, which every flight controller paid at start-up (mavsim_core/butterworth.py)."""
    from scipy.signal import lfilter as scipy_lfilter

    return scipy_lfilter(b, a, x)


@dataclass(frozen=True, slots=True)
class IdentifiedPlant:
    """One axis' rate plant: rate/alpha_sp = b e^{-s d} / (s (tau s + 1))."""

    effectiveness: float  # b, rad/s^2 of angular acceleration per rad/s^2 of alpha_sp (no unit)
    motor_tau_s: float  # tau, s
    delay_s: float  # d, s (delay_samples x the sample period)
    delay_samples: int
    fit: float  # 1 - |residual| / |dy - mean(dy)| (prefiltered): 1 is a perfect fit, 0 explains nothing
    effectiveness_spread: float  # |b of the first half - b of the second half| / b: how repeatable b is
    samples: int


def _response(u: np.ndarray, dt_s: float, tau_s: float, delay: int) -> np.ndarray:
    """The model's dy[k] for b = 1 (rad/s per period) to the input u (rad/s^2), zero initial state."""
    phi = math.exp(-dt_s / tau_s)
    b1 = dt_s - tau_s * (1.0 - phi)
    b2 = tau_s * (1.0 - phi) - dt_s * phi
    num = np.zeros(delay + 3)
    num[delay + 1], num[delay + 2] = b1, b2
    return lfilter(num, [1.0, -phi], u)


def _fit(u: np.ndarray, dy: np.ndarray, dt_s: float, tau_s: float, delay: int, sl: slice) -> tuple:
    """Least squares of the prefiltered dy ~ b * response + c over ``sl``: (solution, regressors, residual)."""
    x = lfilter(*_PREFILTER, _response(u, dt_s, tau_s, delay))[sl]
    a = np.column_stack((x, lfilter(*_PREFILTER, np.ones_like(u))[sl]))
    yf = lfilter(*_PREFILTER, dy)[sl]
    sol, *_ = np.linalg.lstsq(a, yf, rcond=None)
    return sol, a, yf - a @ sol


def _solve(u: np.ndarray, dy: np.ndarray, dt_s: float, tau_s: float, delay: int, sl: slice) -> tuple[float, float]:
    """(b, sum of squared residuals) of the least-squares fit (:func:`_fit`)."""
    sol, _, res = _fit(u, dy, dt_s, tau_s, delay, sl)
    return float(sol[0]), float(res @ res)


def _quality(u: np.ndarray, dy: np.ndarray, dt_s: float, tau_s: float, delay: int, skip: int) -> tuple[float, float]:
    """(fit, spread of b between the two halves of the samples / b) of the final model."""
    sol, a, res = _fit(u, dy, dt_s, tau_s, delay, slice(skip, None))
    meas = a @ sol + res
    spread = meas - meas.mean()
    fit = 1.0 - float(np.linalg.norm(res) / np.linalg.norm(spread)) if spread.any() else 0.0
    mid = (skip + len(u)) // 2
    b1 = _solve(u, dy, dt_s, tau_s, delay, slice(skip, mid))[0]
    b2 = _solve(u, dy, dt_s, tau_s, delay, slice(mid, None))[0]
    return fit, float(abs(b1 - b2) / abs(sol[0])) if sol[0] != 0 else math.inf


def _best_tau(u: np.ndarray, dy: np.ndarray, dt_s: float, delay: int, skip: int) -> tuple[float, float, float]:
    """(tau, b, sse) minimising the residual for one delay: a log grid, then golden section around its best."""
    sl = slice(skip, None)
    grid = np.geomspace(TAU_MIN_S, TAU_MAX_S, _GRID)
    sse = [_solve(u, dy, dt_s, t, delay, sl)[1] for t in grid]
    i = int(np.argmin(sse))
    lo, hi = math.log(grid[max(i - 1, 0)]), math.log(grid[min(i + 1, _GRID - 1)])
    g = (math.sqrt(5.0) - 1.0) / 2.0
    a, b = hi - g * (hi - lo), lo + g * (hi - lo)
    fa, fb = (_solve(u, dy, dt_s, math.exp(x), delay, sl)[1] for x in (a, b))
    for _ in range(_GOLDEN_STEPS):
        if fa < fb:
            hi, b, fb = b, a, fa
            a = hi - g * (hi - lo)
            fa = _solve(u, dy, dt_s, math.exp(a), delay, sl)[1]
        else:
            lo, a, fa = a, b, fb
            b = lo + g * (hi - lo)
            fb = _solve(u, dy, dt_s, math.exp(b), delay, sl)[1]
    tau = math.exp((lo + hi) / 2.0)
    eff, err = _solve(u, dy, dt_s, tau, delay, sl)
    return tau, eff, err


def identify_rate_plant(
    alpha_sp_rad_s2: np.ndarray, rate_rad_s: np.ndarray, dt_s: float, max_delay: int = 3
) -> IdentifiedPlant:
    """Fit b, tau and the delay (0..``max_delay`` periods) to one axis' samples taken every ``dt_s`` s.

    ``alpha_sp_rad_s2[k]`` is the controller's output at step k, ``rate_rad_s[k]`` the body rate measured
    at step k (same axis, FRD).  ValueError if there are too few samples or they hold no excitation.
    """
    u = np.asarray(alpha_sp_rad_s2, dtype=float)
    y = np.asarray(rate_rad_s, dtype=float)
    if u.shape != y.shape or u.ndim != 1 or len(u) < 50 + max_delay:
        raise ValueError("identification needs two equally long 1-D sample series of at least 50 samples")
    if not (np.all(np.isfinite(u)) and np.all(np.isfinite(y))):
        raise ValueError("identification samples must be finite")
    u = u - u.mean()  # the hover's trim torque is the constant c's job
    dy = np.diff(y, prepend=y[0])
    if float(np.ptp(u)) == 0.0 or float(np.ptp(dy)) == 0.0:
        raise ValueError("no excitation in the samples")
    skip = max_delay + 3
    best: tuple[float, float, float, int] | None = None
    for delay in range(max_delay + 1):
        tau, eff, err = _best_tau(u, dy, dt_s, delay, skip)
        if best is None or err < best[2]:
            best = (tau, eff, err, delay)
    assert best is not None
    tau, eff, _, delay = best
    fit, spread = _quality(u, dy, dt_s, tau, delay, skip)
    return IdentifiedPlant(eff, tau, delay * dt_s, delay, fit, spread, len(u))
