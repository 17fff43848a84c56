"""Rate-loop design and stability margins of one body axis of a multirotor (pure numpy/scipy).

The plant of one body axis, as the rate controller sees it (its output is an angular
acceleration setpoint, the caller multiplies by the inertia)::

    rate(s) / alpha_sp(s) = b exp(-s d) / (s (tau s + 1))        rad/s per rad/s^2

with ``b`` the effectiveness (1 when the vehicle file's inertia and rotor constants are
right), ``tau`` the motor lag (s) and ``d`` a pure delay (s).  The controller runs at
``sample_hz`` and holds its output for one period (zero-order hold); it flies on the
gyro low-passed by a second-order Butterworth filter (``gyro_cutoff_hz``, PX4's
IMU_GYRO_CUTOFF) and its derivative term (on the measured rate) is low-passed again at
``d_cutoff_hz`` -- exactly as :mod:`autopilot.control.rate_control` and
:mod:`autopilot.control.gyro_filter` do.  :func:`rate_loop_margins` evaluates that whole
discrete loop (the plant discretised with the zero-order hold, the filters' own z-domain
coefficients, the PID as coded: forward-Euler integrator, backward-difference derivative)
on the unit circle; ``delay_s`` is *extra* pure delay beyond the hold (0 for the simulator
in lockstep: a gyro sample at t is answered by a command held over [t, t + 1/sample_hz]).

Design (:func:`design_rate_pid`): **pole placement** on the reduced model
b / (s (T s + 1)), where T lumps the motor lag, the delay, half a sample (the hold) and
the gyro filter's low-frequency group delay (sqrt(2) / (2 pi f_c) for the Butterworth).
PID on it gives the characteristic polynomial T s^3 + (1 + b D) s^2 + b P s + b I, set
equal to T (s^2 + 2 zeta w s + w^2)(s + w / n): a pair of damping ``zeta`` at ``w`` and
the integrator's real pole at ``w / n``.  The one free number ``w`` is then chosen on the
*full* model: the largest ``w`` whose loop has the asked phase margin (and at least
:data:`MIN_GAIN_MARGIN_DB`), or the ``w`` that puts the crossover at ``crossover_hz``.

Units: gains are those of :class:`autopilot.control.rate_control.RateGains`:
P in (rad/s^2)/(rad/s) = 1/s, I in 1/s^2, D unitless.  Frequencies in Hz at the API,
rad/s inside.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mavsim_core.butterworth import lowpass2

MIN_GAIN_MARGIN_DB = 6.0  # a design never goes below this gain margin
RATE_ZETAS = (0.5, 0.7, 0.85, 1.0, 1.2, 1.4, 1.7, 2.0)  # dampings of the placed pair the design tries
RATE_INTEGRATOR_RATIO = 4.0  # the integrator's pole sits this many times below the pair's frequency
_N_FREQ = 3000


@dataclass(frozen=True, slots=True)
class RatePlant:
    """One body axis: rate(s)/alpha_sp(s) = effectiveness * exp(-s delay_s) / (s (motor_tau_s s + 1))."""

    effectiveness: float  # unitless, 1.0 = the vehicle file's inertia and rotor constants are right
    motor_tau_s: float  # first-order motor (thrust) lag, s
    delay_s: float  # pure delay beyond the controller's zero-order hold and its own filters, s


@dataclass(frozen=True, slots=True)
class PidGains:
    """The rate controller's units (autopilot.control.rate_control.RateGains): P 1/s, I 1/s^2, D unitless."""

    p: float
    i: float
    d: float


@dataclass(frozen=True, slots=True)
class Margins:
    """Stability margins of a loop broken at the plant input."""

    gain_margin_db: float  # inf if the phase never reaches -180 deg below the Nyquist frequency
    phase_margin_deg: float
    crossover_hz: float  # where the loop gain is 1 (NaN if it never is)


@dataclass(frozen=True, slots=True)
class LoopFilters:
    """The rate controller's sampling and filters (defaults: this project's 250 Hz, 30 Hz, 30 Hz)."""

    sample_hz: float = 250.0
    d_cutoff_hz: float = 30.0
    gyro_cutoff_hz: float = 30.0


# --------------------------------------------------------------------------- frequency responses


def freq_grid_hz(sample_hz: float, lo_hz: float = 0.005, n: int = _N_FREQ) -> np.ndarray:
    """Log-spaced frequencies (Hz) from ``lo_hz`` to just below the Nyquist frequency."""
    return np.logspace(math.log10(lo_hz), math.log10(0.499 * sample_hz), n)


def _z(f_hz: np.ndarray, sample_hz: float) -> np.ndarray:
    return np.exp(1j * 2 * math.pi * f_hz / sample_hz)


def plant_response(plant: RatePlant, f_hz: np.ndarray, sample_hz: float) -> np.ndarray:
    """Rate per alpha_sp of the plant behind a zero-order hold at ``sample_hz``, with its extra delay."""
    tau = max(plant.motor_tau_s, 1e-6)
    a = np.array([[0.0, 1.0], [0.0, -1.0 / tau]])  # x = (rate, angular acceleration delivered)
    b = np.array([[0.0], [plant.effectiveness / tau]])
    from scipy.signal import cont2discrete  # (here: importing scipy.signal costs every process 0.8 CPU s)

    ad, bd, cd, _, _ = cont2discrete((a, b, np.array([[1.0, 0.0]]), np.zeros((1, 1))), 1.0 / sample_hz, "zoh")
    z = _z(f_hz, sample_hz)
    # C (zI - A)^-1 B for a 2x2 A, written out: adj(zI - A) / det(zI - A).
    a11, a12, a21, a22 = ad[0, 0], ad[0, 1], ad[1, 0], ad[1, 1]
    det = (z - a11) * (z - a22) - a12 * a21
    num = cd[0, 0] * ((z - a22) * bd[0, 0] + a12 * bd[1, 0]) + cd[0, 1] * (a21 * bd[0, 0] + (z - a11) * bd[1, 0])
    return num / det * np.exp(-1j * 2 * math.pi * f_hz * plant.delay_s)


def lowpass2_response(cutoff_hz: float, f_hz: np.ndarray, sample_hz: float) -> np.ndarray:
    """The gyro filter's response: scipy's 2nd-order Butterworth at ``sample_hz`` (1 when it is off)."""
    if cutoff_hz <= 0.0 or cutoff_hz >= 0.45 * sample_hz:
        return np.ones_like(f_hz, dtype=complex)
    bb, aa = lowpass2(cutoff_hz, sample_hz)
    zi = 1.0 / _z(f_hz, sample_hz)
    return (bb[0] + bb[1] * zi + bb[2] * zi**2) / (aa[0] + aa[1] * zi + aa[2] * zi**2)


def pid_responses(
    gains: PidGains, f_hz: np.ndarray, sample_hz: float, d_cutoff_hz: float
) -> tuple[np.ndarray, np.ndarray]:
    """(P + I, D) parts of the discrete PID as coded: the setpoint path and the derivative on the measurement.

    Integrator: forward Euler, added after the output (I T z^-1 / (1 - z^-1)); derivative: backward
    difference through a first-order low-pass a = T / (T + 1 / (2 pi f_d)).  A ``d_cutoff_hz`` of 0 means
    an unfiltered derivative."""
    t = 1.0 / sample_hz
    zi = 1.0 / _z(f_hz, sample_hz)
    pi_part = gains.p + gains.i * t * zi / (1.0 - zi)
    a = 1.0 if d_cutoff_hz <= 0 else t / (t + 1.0 / (2 * math.pi * d_cutoff_hz))
    d_part = gains.d * a * (1.0 - zi) / (t * (1.0 - (1.0 - a) * zi))
    return pi_part, d_part


def rate_loop_response(
    plant: RatePlant, gains: PidGains, f_hz: np.ndarray, filters: LoopFilters = LoopFilters()
) -> tuple[np.ndarray, np.ndarray]:
    """(open loop L at the plant input, closed loop rate / rate_sp) of the rate loop at ``f_hz``."""
    g = plant_response(plant, f_hz, filters.sample_hz)
    h = lowpass2_response(filters.gyro_cutoff_hz, f_hz, filters.sample_hz)
    c_pi, c_d = pid_responses(gains, f_hz, filters.sample_hz, filters.d_cutoff_hz)
    loop = (c_pi + c_d) * h * g
    return loop, c_pi * g / (1.0 + loop)


# --------------------------------------------------------------------------- margins and bandwidth


def unwrapped_phase_deg(loop: np.ndarray) -> np.ndarray:
    """Phase of a loop over an increasing frequency grid, unwrapped, its first value in (-270, 90] deg."""
    ph = np.degrees(np.unwrap(np.angle(loop)))
    return ph - 360.0 * math.ceil((ph[0] - 90.0) / 360.0)


def margins_of(loop: np.ndarray, f_hz: np.ndarray) -> Margins:
    """Gain margin (at the first -180 deg crossing above the crossover), phase margin and crossover.

    The crossover is the first frequency where |L| falls through 1; a loop that never reaches 1
    gets NaN there and its phase margin is +inf."""
    mag = np.abs(loop)
    ph = unwrapped_phase_deg(loop)
    down = np.nonzero((mag[:-1] >= 1.0) & (mag[1:] < 1.0))[0]
    if down.size == 0:
        return Margins(_gain_margin(mag, ph, 0), math.inf, math.nan)
    k = int(down[0])
    fr = (math.log(mag[k])) / (math.log(mag[k]) - math.log(mag[k + 1]))  # log-linear interpolation
    fc = math.exp(math.log(f_hz[k]) + fr * (math.log(f_hz[k + 1]) - math.log(f_hz[k])))
    pm = 180.0 + ph[k] + fr * (ph[k + 1] - ph[k])
    return Margins(_gain_margin(mag, ph, k), float(pm), float(fc))


def _gain_margin(mag: np.ndarray, ph: np.ndarray, start: int) -> float:
    below = np.nonzero((ph[start:-1] > -180.0) & (ph[start + 1 :] <= -180.0))[0]
    if below.size == 0:
        return math.inf
    k = start + int(below[0])
    fr = (ph[k] + 180.0) / (ph[k] - ph[k + 1])
    m = math.exp(math.log(mag[k]) + fr * (math.log(mag[k + 1]) - math.log(mag[k])))
    return -20.0 * math.log10(m)


def bandwidth_hz(closed: np.ndarray, f_hz: np.ndarray) -> float:
    """-3 dB bandwidth of a closed loop: the first frequency where |T| falls below 1/sqrt(2) (NaN if never)."""
    below = np.nonzero(np.abs(closed) < 1.0 / math.sqrt(2.0))[0]
    return float(f_hz[below[0]]) if below.size else math.nan


def rate_loop_margins(
    plant: RatePlant,
    gains: PidGains,
    sample_hz: float = 250.0,
    d_cutoff_hz: float = 30.0,
    gyro_cutoff_hz: float = 30.0,
) -> Margins:
    """Margins of the discrete rate loop (module docstring) broken at the plant input."""
    f = freq_grid_hz(sample_hz)
    loop, _ = rate_loop_response(plant, gains, f, LoopFilters(sample_hz, d_cutoff_hz, gyro_cutoff_hz))
    return margins_of(loop, f)


# --------------------------------------------------------------------------- design


def lumped_lag_s(plant: RatePlant, filters: LoopFilters = LoopFilters()) -> float:
    """T of the reduced model b / (s (T s + 1)): motor lag + delay + half a sample + the gyro filter's delay."""
    t = plant.motor_tau_s + plant.delay_s + 0.5 / filters.sample_hz
    fc = filters.gyro_cutoff_hz
    if 0.0 < fc < 0.45 * filters.sample_hz:
        t += math.sqrt(2.0) / (2 * math.pi * fc)  # low-frequency group delay of a 2nd-order Butterworth
    return t


def placed_pid(plant: RatePlant, w_rad_s: float, zeta: float, filters: LoopFilters = LoopFilters()) -> PidGains:
    """PID placing the reduced model's poles at a pair (``zeta``, ``w``) and a real pole at w / n."""
    t, b, n = lumped_lag_s(plant, filters), plant.effectiveness, RATE_INTEGRATOR_RATIO
    d = max((t * (2 * zeta + 1.0 / n) * w_rad_s - 1.0) / b, 0.0)
    p = t * w_rad_s**2 * (1.0 + 2 * zeta / n) / b
    i = t * w_rad_s**3 / (n * b)
    return PidGains(p=p, i=i, d=d)


class _RateLoopEvaluator:
    """The loop's fixed parts evaluated once; the PID's three basis responses scaled per candidate."""

    def __init__(self, plant: RatePlant, filters: LoopFilters) -> None:
        self.f = freq_grid_hz(filters.sample_hz, n=1500)
        g = plant_response(plant, self.f, filters.sample_hz)
        h = lowpass2_response(filters.gyro_cutoff_hz, self.f, filters.sample_hz)
        _, c_d = pid_responses(PidGains(0.0, 0.0, 1.0), self.f, filters.sample_hz, filters.d_cutoff_hz)
        c_i, _ = pid_responses(PidGains(0.0, 1.0, 0.0), self.f, filters.sample_hz, filters.d_cutoff_hz)
        self.g, self.ig = g, c_i * g
        self.basis = (g * h, c_i * g * h, c_d * g * h)

    def loop(self, gains: PidGains) -> np.ndarray:
        gh, igh, dgh = self.basis
        return gains.p * gh + gains.i * igh + gains.d * dgh

    def margins(self, gains: PidGains) -> Margins:
        return margins_of(self.loop(gains), self.f)

    def bandwidth_hz(self, gains: PidGains) -> float:
        """-3 dB bandwidth of rate / rate_sp (the setpoint enters through P and I only)."""
        return bandwidth_hz((gains.p * self.g + gains.i * self.ig) / (1.0 + self.loop(gains)), self.f)


def design_rate_pid(
    plant: RatePlant,
    crossover_hz: float | None = None,
    phase_margin_deg: float = 55.0,
    filters: LoopFilters = LoopFilters(),
    p_max: float = math.inf,
) -> PidGains:
    """Rate PID by pole placement (module docstring), the pattern's ``zeta`` and ``w`` set on the full loop.

    ``crossover_hz`` None: of the placements (``zeta`` in RATE_ZETAS, any ``w``) whose loop has at least
    ``phase_margin_deg`` and MIN_GAIN_MARGIN_DB, the one whose closed loop (rate / rate_sp; the derivative
    acts on the measurement only) has the widest -3 dB bandwidth.  Given: for each
    ``zeta`` the ``w`` that crosses over at ``crossover_hz``, and of those the one with the largest phase
    margin (its margins are what they are: check them with :func:`rate_loop_margins`).  ``p_max`` bounds P
    (an axis with little authority, as a multirotor's yaw: its P times a small error must stay within reach)."""
    if not (plant.effectiveness > 0 and plant.motor_tau_s >= 0 and plant.delay_s >= 0):
        raise ValueError(f"not a plant: {plant}")
    ev = _RateLoopEvaluator(plant, filters)
    ws = np.logspace(0.0, math.log10(2 * math.pi * 0.45 * filters.sample_hz), 80)
    best: tuple[float, PidGains] | None = None
    for zeta in RATE_ZETAS:
        if crossover_hz is None:
            found = _fastest_placement(plant, zeta, ws, ev, (phase_margin_deg, p_max), filters)
        else:
            found = _placement_at(plant, zeta, ws, ev, crossover_hz, filters)
        if found is not None and (best is None or found[0] > best[0]):
            best = found
    if best is None:
        raise ValueError(f"no rate loop meets the specification for {plant}")
    return best[1]


def _fastest_placement(plant, zeta, ws, ev, spec, filters) -> tuple[float, PidGains] | None:
    """(closed-loop bandwidth, gains) of the widest-bandwidth ``w`` meeting spec = (phase margin, P limit)."""
    pm_deg, p_max = spec

    def ok(w: float) -> bool:
        g = placed_pid(plant, w, zeta, filters)
        if g.p > p_max:
            return False
        m = ev.margins(g)
        return m.phase_margin_deg >= pm_deg and m.gain_margin_db >= MIN_GAIN_MARGIN_DB

    good = [(ev.bandwidth_hz(placed_pid(plant, w, zeta, filters)), k) for k, w in enumerate(ws) if ok(w)]
    good = [(bw, k) for bw, k in good if math.isfinite(bw)]
    if not good:
        return None
    k = max(good)[1]
    lo, hi = ws[k], ws[min(k + 1, len(ws) - 1)]
    for _ in range(25):
        mid = math.sqrt(lo * hi)
        lo, hi = (mid, hi) if ok(mid) else (lo, mid)
    gains = placed_pid(plant, lo, zeta, filters)
    return ev.bandwidth_hz(gains), gains


def _placement_at(plant, zeta, ws, ev, crossover_hz, filters) -> tuple[float, PidGains] | None:
    """(phase margin, gains) of the ``w`` whose loop crosses over at ``crossover_hz`` (bisection)."""
    fc = [ev.margins(placed_pid(plant, w, zeta, filters)).crossover_hz for w in ws]
    above = [k for k, c in enumerate(fc) if c >= crossover_hz]
    if not above or above[0] == 0:
        return None
    lo, hi = ws[above[0] - 1], ws[above[0]]
    for _ in range(40):
        mid = math.sqrt(lo * hi)
        c = ev.margins(placed_pid(plant, mid, zeta, filters)).crossover_hz
        lo, hi = (mid, hi) if not c >= crossover_hz else (lo, mid)
    g = placed_pid(plant, hi, zeta, filters)
    return ev.margins(g).phase_margin_deg, g
