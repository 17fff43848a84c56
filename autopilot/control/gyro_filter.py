"""Low-pass filter of the body rates the rate controller flies on (PX4's IMU_GYRO_CUTOFF).

A real flight controller never feeds raw gyro samples to its rate loop: frame
vibration and blade-pass noise would drive the motors.  PX4 low-passes the angular
velocity with a second-order Butterworth filter (IMU_GYRO_CUTOFF; its v1.9 default
went down to 30 Hz because medium and large frames vibrate low).  The filter's phase
lag is also what a rate gain that is too high turns into a growing oscillation, as on
a real vehicle: without it the rate loop here is the motors' first-order lag alone
and stays stable far beyond any sensible gain.

The filter is designed as ``scipy.signal.butter`` designs it (mavsim_core/butterworth.py) for the 250 Hz control
rate and run per axis on Python floats (three axes: cheaper than numpy calls).
The estimators use the unfiltered gyro; only the rate controller sees this output.
Rates in rad/s, FRD.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from mavsim_core.butterworth import lowpass2
from mavsim_core.constants import LOCKSTEP_DT_S

CONTROL_RATE_HZ = 1.0 / LOCKSTEP_DT_S  # 250 Hz: one sample per lockstep period


@dataclass(frozen=True, slots=True)
class GyroFilterSettings:
    """The filter's design: cutoff (Hz; 0, or at or above 0.45 x the sample rate: no filter)."""

    cutoff_hz: float
    sample_rate_hz: float = CONTROL_RATE_HZ


class GyroFilter:
    def __init__(self, settings: GyroFilterSettings) -> None:
        self.set_gains(settings)

    def set_gains(self, settings: GyroFilterSettings) -> None:
        """A new design; the filter restarts settled on the next sample."""
        self.settings = settings
        self.fs = settings.sample_rate_hz
        self._design(settings.cutoff_hz)

    def _design(self, cutoff_hz: float) -> None:
        """Coefficients for a cutoff; 0, or one at or above 0.45 x the sample rate, passes rates through."""
        self.cutoff_hz = cutoff_hz
        self._state: list[float] | None = None  # per axis: the two delay states, flat
        self._coef: tuple[float, float, float, float, float] | None = None
        if cutoff_hz <= 0.0 or cutoff_hz >= 0.45 * self.fs:
            return
        b, a = lowpass2(cutoff_hz, self.fs)
        self._coef = (float(b[0]), float(b[1]), float(b[2]), float(a[1]), float(a[2]))

    def apply(self, rate: np.ndarray | Sequence[float]) -> list[float]:
        """One sample (3 rates, rad/s, FRD) in, the filtered rates out (runs at 250 Hz: written out per axis)."""
        x0, x1, x2 = rate.tolist() if isinstance(rate, np.ndarray) else rate
        coef = self._coef
        if coef is None or not math.isfinite(x0 + x1 + x2):
            return [x0, x1, x2]  # NaN never enters the filter's state; the rate controller rejects it
        b0, b1, b2, a1, a2 = coef
        s = self._state
        if s is None:  # start settled on the first sample: no start-up transient
            gain = (b0 + b1 + b2) / (1.0 + a1 + a2)  # DC gain (1 for this low-pass)
            s = self._state = []
            for v in (x0, x1, x2):  # direct form II transposed, steady state for a constant input v
                y = gain * v
                s2 = b2 * v - a2 * y
                s += [b1 * v - a1 * y + s2, s2]
        y0 = b0 * x0 + s[0]
        s[0] = b1 * x0 - a1 * y0 + s[1]
        s[1] = b2 * x0 - a2 * y0
        y1 = b0 * x1 + s[2]
        s[2] = b1 * x1 - a1 * y1 + s[3]
        s[3] = b2 * x1 - a2 * y1
        y2 = b0 * x2 + s[4]
        s[4] = b1 * x2 - a1 * y2 + s[5]
        s[5] = b2 * x2 - a2 * y2
        return [y0, y1, y2]
