"""The second-order Butterworth low-pass of a sampled signal, in closed form.

``scipy.signal.butter(2, cutoff_hz, fs=sample_hz)`` gives the same coefficients (tests/test_butterworth.py
checks it), but importing ``scipy.signal`` takes about 0.8 s of CPU (it pulls in ``scipy.stats``), which every
flight-controller process paid at start-up for the three numbers of its gyro filter.  The design here is
the bilinear transform of the analogue prototype with the cutoff pre-warped, which is what scipy does.

Frequencies in Hz; the coefficients are for ``y[n] = b0 x[n] + b1 x[n-1] + b2 x[n-2] - a1 y[n-1] - a2 y[n-2]``
(``a0`` = 1), as ``scipy.signal.lfilter(b, a, x)`` takes them.
"""

from __future__ import annotations

import math


def lowpass2(cutoff_hz: float, sample_hz: float) -> tuple[tuple[float, float, float], tuple[float, float, float]]:
    """``(b, a)`` of the 2nd-order Butterworth low-pass; ValueError unless 0 < cutoff < sample_hz / 2."""
    if not 0.0 < cutoff_hz < 0.5 * sample_hz:
        raise ValueError(f"cutoff {cutoff_hz} Hz must be above 0 and below half the sample rate {sample_hz} Hz")
    k = math.tan(math.pi * cutoff_hz / sample_hz)  # the pre-warped cutoff, bilinear transform with T = 2
    k2 = k * k
    norm = 1.0 / (1.0 + math.sqrt(2.0) * k + k2)
    b0 = k2 * norm
    return (b0, 2.0 * b0, b0), (1.0, 2.0 * (k2 - 1.0) * norm, (1.0 - math.sqrt(2.0) * k + k2) * norm)
