"""The identification signal: a pseudo-random binary sequence (PRBS) added to one axis' rate setpoint.

A maximal-length 9-bit LFSR (x^9 + x^5 + 1, period 511 bits) chooses the sign of each bit; a bit lasts
``bit_samples`` control periods, so the signal's power is spread from about 1/(511 bit) to 1/(2 bit)
(0.2-40 Hz at 250 Hz with 3-sample bits): the band the rate loop's crossover lives in.  Amplitude
``amp_rad_s`` (rad/s of body rate, FRD); the sign is forced back towards zero whenever the signal's own
integral (the attitude it would command open-loop, rad) would leave +-``angle_bound_rad``, so the
excitation can never walk the attitude away: |r| <= amp and |integral r dt| <= bound at every sample.

Pure and deterministic: the same settings give the same sequence, no clock, ``dt_s`` is an input.
"""

from __future__ import annotations

ANGLE_BOUND_RAD = 0.035  # the excitation's own integral stays within +-2 degrees


class Prbs:
    """One axis' excitation: :meth:`next` returns the value (rad/s) for the next control period."""

    def __init__(self, amp_rad_s: float, dt_s: float, bit_samples: int = 3, angle_bound_rad: float = ANGLE_BOUND_RAD):
        if amp_rad_s <= 0 or dt_s <= 0 or bit_samples < 1:
            raise ValueError("PRBS needs a positive amplitude, period and bit length")
        self.amp_rad_s = amp_rad_s
        self.dt_s = dt_s
        self.bit_samples = bit_samples
        self.bound_rad = angle_bound_rad
        self._lfsr = 0x1FF  # any non-zero 9-bit state
        self._left = 0  # samples left in the current bit
        self._sign = 1.0
        self.integral_rad = 0.0  # integral of the signal so far, rad

    def _next_bit(self) -> float:
        bit = ((self._lfsr >> 8) ^ (self._lfsr >> 4)) & 1  # taps 9 and 5
        self._lfsr = ((self._lfsr << 1) | bit) & 0x1FF
        return 1.0 if bit else -1.0

    def next(self) -> float:
        """The signal for the next period (rad/s), bounded in amplitude and integral."""
        if self._left == 0:
            self._sign = self._next_bit()
            self._left = self.bit_samples
        self._left -= 1
        step = self._sign * self.amp_rad_s * self.dt_s
        if abs(self.integral_rad + step) > self.bound_rad:
            self._sign = -self._sign  # back towards zero: the bound holds
            step = -step
        self.integral_rad += step
        return self._sign * self.amp_rad_s
