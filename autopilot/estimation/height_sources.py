"""Height sources: the barometer checked against the GPS height, and the GPS height as the fallback.

The barometer is the height reference (as PX4's ``EKF2_HGT_REF`` 0, barometric); the GPS height is
its check and its fallback, as PX4's EKF2 falls back to another height source when the reference
fails.  At each good GPS fix (origin set) the barometer's height then (its 50 Hz samples, kept for
half a second, at the time the fix describes: ``EKF2_GPS_DELAY`` earlier) is compared with the GPS
height, both metres down from the origin::

    d          = baro_down - gps_down
    innovation = d - bias                       (bias: d low-passed over BIAS_TAU_S while consistent)
    ratio      = innovation^2 / (EKF2_BARO_GATE^2 (EKF2_BARO_NOISE^2 + epv^2))

The bias takes up a slow, honest disagreement (weather, the GPS's own slow wander) and nothing fast.
It starts as the running mean of the comparisons so far (a low-pass started from one fix would carry
that fix's GPS noise, 0.2-0.3 m, for minutes, and a failed barometer would then not be found
consistent again), and becomes the BIAS_TAU_S low-pass once that is the slower of the two.
``FAIL_FIXES`` ratios above 1 in a row mean one of the two is wrong.  The GPS vertical velocity,
summed from fix to fix, is a third height that cannot jump: whichever of the barometer and the GPS
height moved further from it since they last agreed (both low-passed over ``SMOOTH_TAU_S`` while
consistent) is the one at fault.

* The barometer (drifting, frozen at a wrong value, reading garbage that still changes): "Barometer
  failed: inconsistent with GPS height (x.x m)" (CRITICAL).  It is no longer fused, the SYS_STATUS
  barometer bit is cleared (:attr:`HeightSources.failed`, via the estimator's failed sensors) and
  the filters fly on the GPS height in the barometer's frame, the GPS height plus the bias learnt
  while the two agreed (the height frame stays the one the vehicle flew in: a barometer frozen at
  the right height moves nothing; without the bias a GPS height 0.7 m off the barometer's, in one
  seed's noise, sank the vehicle 0.9 m at the switch): the EKF's height is reset to it at once (not
  published as a reset: the setpoint stays, so the vehicle climbs back to where it was told to be),
  then each fix is fused (``EKF2_GPS_P_NOISE`` or the fix's epv, whichever is larger; gate
  ``EKF2_GPS_P_GATE``).
  The same fallback flies whenever the barometer is failed for another reason
  (:mod:`autopilot.estimation.sensor_checks`: no data, stale data).  Once the innovation, low-passed
  over ``SMOOTH_TAU_S``, stays within a third of the gate for ``RECOVER_S``: "Barometer healthy
  again", and it is the reference again.
* The GPS height (a vertical glitch): "GPS height inconsistent with the barometer" (WARNING); the
  barometer stays the reference, and "GPS height consistent again" when it is.

Times are sample time stamps, µs; heights metres down, from the estimator origin.
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass

from autopilot.estimation.ekf import (
    P_BARO_GATE,
    P_BARO_NOISE,
    P_GPS_P_GATE,
    P_GPS_P_NOISE,
    ErrorStateEkf,
)
from autopilot.estimation.position_kf import PositionVelocityFilter
from autopilot.estimation.state_history import state_at
from autopilot.parameters import ParamDef

# The linear filter and its (time, position, velocity) history, for fusion at the time a fix describes.
Lkf = tuple[PositionVelocityFilter, deque]

BIAS_TAU_S = 100.0  # the barometer's offset from the GPS height may change this slowly
FAIL_FIXES = 3  # ratios above 1 in a row (0.6 s at 5 Hz) fail the barometer
RECOVER_S = 5.0  # consistent again (ratio below RECOVER_RATIO) this long: healthy again
RECOVER_RATIO = 1.0 / 9.0  # the low-passed innovation within a third of the gate
SMOOTH_TAU_S = 1.0  # the low-pass of the recovery test and of the references
FIX_S = 0.2  # the GPS fix period the low-passes assume (5 Hz)
BARO_KEEP_US = 500_000  # barometer samples kept for the comparison at the fix's time


@dataclass(frozen=True, slots=True)
class GpsHeight:
    """A good fix's vertical part: at ``then_us`` (the time it describes), m and m/s down, epv 1-sigma m."""

    then_us: int
    down_m: float
    vel_down_m_s: float
    epv_m: float


class HeightSources:
    """The barometer's consistency with the GPS height and the GPS-height fallback (see the module doc)."""

    def __init__(self, events: list[tuple[str, str]], p: Callable[[ParamDef], float]) -> None:
        self.events = events  # (severity name, text), shared with the estimator
        self._p = p
        self._baro: deque[tuple[int, float]] = deque()
        self.bias_m: float | None = None  # barometer minus GPS height, slowly tracked
        self._bias_n = 0  # consistent comparisons in the bias so far (its running mean at first)
        self.innovation_m = 0.0
        self.ratio = 0.0
        self.failed = ""  # why the barometer is inconsistent ("": it is not)
        self.gps_blamed = False  # the GPS height jumped, not the barometer: not used as the fallback
        self._fails = 0
        self._good_since_us: int | None = None
        self._smooth_m = 0.0  # the innovation low-passed over SMOOTH_TAU_S (recovery)
        self.on_gps_height = False  # the filters fly on the GPS height now
        self._vel_height_m = 0.0  # the GPS vertical velocity integrated (m down, from anywhere)
        self._last_vel: tuple[int, float] | None = None
        self._ref: tuple[float, float] | None = None  # (baro, GPS) minus that, low-passed while consistent

    def on_baro(self, time_us: int, baro_down_m: float) -> None:
        """A barometer sample (m down from the origin) that passed the sensor checks."""
        self._baro.append((time_us, baro_down_m))
        while self._baro and time_us - self._baro[0][0] > BARO_KEEP_US:
            self._baro.popleft()

    @property
    def baro_ok(self) -> bool:
        return not self.failed

    def on_gps(self, fix: GpsHeight, baro_usable: bool, ekf: ErrorStateEkf, lkf: Lkf) -> None:
        """A good fix: check the barometer; when it cannot be used (``baro_usable`` False: the sensor checks
        failed it; or inconsistent), fuse the GPS height into both filters (``lkf``: the linear filter and
        its history of (time, position, velocity))."""
        self._integrate(fix)
        baro = self._baro_at(fix.then_us)
        if baro is not None and baro_usable:
            self._check(fix, baro)
        if baro_usable and self.baro_ok:
            self.on_gps_height = False
            return
        noise = max(self._p(P_GPS_P_NOISE), fix.epv_m if math.isfinite(fix.epv_m) else 0.0)
        pos_then, _ = ekf.state_at(fix.then_us)
        ekf_then = float(ekf.p[2] if pos_then is None else pos_then[2])
        lkf_pos_then, _ = state_at(lkf[1], fix.then_us)
        lkf_then = float(lkf[0].x[2, 0] if lkf_pos_then is None else lkf_pos_then[2])
        down_m = fix.down_m + (self.bias_m or 0.0)  # the GPS height in the barometer's frame (see the module doc)
        if self.on_gps_height:
            ekf.fuse_state(2, down_m - ekf_then, noise * noise, self._p(P_GPS_P_GATE), "hgt")
            lkf[0].fuse_height(down_m, lkf_then, noise)
            return
        self.on_gps_height = True  # the switch: take the GPS height now (both filters)
        target = ekf.p.copy()
        target[2] += down_m - ekf_then
        ekf.reset_position(target, noise * noise, slice(2, 3))
        lkf[0].x[2, 0] += down_m - lkf_then

    def _integrate(self, fix: GpsHeight) -> None:
        """The GPS vertical velocity summed from fix to fix (trapezoids): a height that cannot jump."""
        last, self._last_vel = self._last_vel, (fix.then_us, fix.vel_down_m_s)
        if last is not None and 0 < fix.then_us - last[0] < 1_000_000 and math.isfinite(fix.vel_down_m_s):
            self._vel_height_m += 0.5 * (last[1] + fix.vel_down_m_s) * (fix.then_us - last[0]) * 1e-6

    def _baro_at(self, time_us: int) -> float | None:
        if not self._baro:
            return None
        t, value = min(self._baro, key=lambda item: abs(item[0] - time_us))
        return value if abs(t - time_us) <= 60_000 else None

    def _check(self, fix: GpsHeight, baro_m: float) -> None:
        """One comparison of the barometer (``baro_m``, m down then) with the GPS height: the innovation test,
        the bias, which of the two moved, recovery."""
        d = baro_m - fix.down_m
        if self.bias_m is None:
            self.bias_m = d
        self.innovation_m = innov = d - self.bias_m
        epv = fix.epv_m if math.isfinite(fix.epv_m) else 0.0
        gate2 = self._p(P_BARO_GATE) ** 2 * (self._p(P_BARO_NOISE) ** 2 + epv * epv)
        self.ratio = innov * innov / gate2
        moved = (baro_m - self._vel_height_m, fix.down_m - self._vel_height_m)
        if self.failed:
            self._recover(fix.then_us, innov, gate2)
        elif self.ratio <= 1.0:
            self._consistent(innov, moved)
        else:
            self._fails += 1
            ref = self._ref or moved
            if self._fails >= FAIL_FIXES and abs(moved[0] - ref[0]) >= abs(moved[1] - ref[1]):
                self.failed = f"inconsistent with GPS height ({innov:+.1f} m)"
                self._smooth_m, self._good_since_us = innov, None
                self.events.append(("CRITICAL", f"Barometer failed: {self.failed}"))
            elif self._fails >= FAIL_FIXES and not self.gps_blamed:
                self.gps_blamed = True  # the GPS height jumped away from its own velocity: the barometer stays
                self.events.append(("WARNING", f"GPS height inconsistent with the barometer ({-innov:+.1f} m)"))

    def _consistent(self, innov: float, moved: tuple[float, float]) -> None:
        """A fix within the gate: the bias and the references follow slowly."""
        self._fails = 0
        self._bias_n += 1
        self.bias_m = (self.bias_m or 0.0) + max(1.0 / self._bias_n, FIX_S / (FIX_S + BIAS_TAU_S)) * innov
        if self._ref is None:
            self._ref = moved
        k = FIX_S / (FIX_S + SMOOTH_TAU_S)
        self._ref = (self._ref[0] + k * (moved[0] - self._ref[0]), self._ref[1] + k * (moved[1] - self._ref[1]))
        if self.gps_blamed:
            self.gps_blamed = False
            self.events.append(("INFO", "GPS height consistent again"))

    def _recover(self, now_us: int, innov: float, gate2: float) -> None:
        """Failed: healthy again once the low-passed innovation stays within a third of the gate."""
        self._smooth_m += FIX_S / (FIX_S + SMOOTH_TAU_S) * (innov - self._smooth_m)
        if self._smooth_m**2 > RECOVER_RATIO * gate2:
            self._good_since_us = None
            return
        self._good_since_us = now_us if self._good_since_us is None else self._good_since_us
        if now_us - self._good_since_us >= RECOVER_S * 1e6:
            self.failed, self._fails, self._ref = "", 0, None
            self.events.append(("INFO", "Barometer healthy again"))
