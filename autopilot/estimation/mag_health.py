"""Magnetometer health: when the EKF stops (and resumes) fusing the magnetometer's heading.

A magnetometer is declared faulty, as PX4's EKF2 does, when

* its readings repeat exactly (``MAG_STUCK_SAMPLES`` in a row: a stuck sensor or bus),
* its field strength is more than ``MAG_FIELD_TOL`` from the World Magnetic Model's at
  the origin (interference: motors, power wires, steel), or
* its heading keeps failing the EKF's innovation gate (``MAG_REJECT_FAULT_S``: the
  heading disagrees with what the gyros carried).

It is fused again after ``MAG_RECOVER_S`` of healthy readings.  Each change is queued
as a (severity, text) event for the ground station.  Readings are in gauss, FRD; times
are the samples' time stamps in microseconds (no clock).
"""

from __future__ import annotations

import math

import numpy as np

from mavsim_core.constants import MAGNETIC_MODEL_EPOCH_YEAR

MAG_FIELD_TOL = 0.35  # |B| more than this fraction from the model's strength: magnetometer fault
MAG_STUCK_SAMPLES = 50  # identical readings in a row (0.2 s at 250 Hz): magnetometer stuck
MAG_REJECT_FAULT_S = 2.0  # heading failing its gate this long: magnetometer fault
MAG_RECOVER_S = 5.0  # healthy this long: fused again


def heading_from_mag(roll: float, pitch: float, mag_frd: np.ndarray, declination_rad: float) -> float:
    """True heading (rad) from a magnetometer reading (any unit, FRD), tilt-compensated (roll, pitch in rad)."""
    cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    mx = mag_frd[0] * cp + mag_frd[1] * sr * sp + mag_frd[2] * cr * sp
    my = mag_frd[1] * cr - mag_frd[2] * sr
    return math.atan2(-my, mx) + declination_rad


def magnetic_field(lat_deg: float, lon_deg: float, alt_amsl_m: float) -> tuple[float, float]:
    """(declination in rad, total field strength in gauss) of the World Magnetic Model at a place."""
    from pygeomag import GeoMag

    res = GeoMag().calculate(glat=lat_deg, glon=lon_deg, alt=alt_amsl_m / 1000.0, time=MAGNETIC_MODEL_EPOCH_YEAR)
    return math.radians(res.d), res.f / 1e5  # nT -> gauss


def magnetic_field_ned(lat_deg: float, lon_deg: float, alt_amsl_m: float) -> np.ndarray:
    """The World Magnetic Model's field vector at a place: gauss, NED."""
    from pygeomag import GeoMag

    res = GeoMag().calculate(glat=lat_deg, glon=lon_deg, alt=alt_amsl_m / 1000.0, time=MAGNETIC_MODEL_EPOCH_YEAR)
    return np.array([res.x, res.y, res.z]) / 1e5  # nT -> gauss


def _values(v: np.ndarray) -> list:
    """The components as a list (what np.array_equal compared, for the 3-vectors here)."""
    return v.tolist() if isinstance(v, np.ndarray) else list(v)


class MagHealth:
    """Fault detection of one magnetometer; ``fault`` says whether its heading may be fused."""

    def __init__(self, events: list[tuple[str, str]]) -> None:
        self.events = events  # (severity name, text), shared with the estimator
        self.strength_gauss: float | None = None  # World Magnetic Model total intensity at the origin
        self.field_ned_gauss: np.ndarray | None = None  # ... its field vector (gauss, NED)
        self.fault = False
        self.fault_reason = ""
        self.last: np.ndarray | None = None  # the latest reading, gauss FRD
        self._repeat = 0
        self._bad_since_us: int | None = None
        self._good_since_us: int | None = None

    def check(self, now_us: int, mag: np.ndarray | None) -> None:
        """One reading (gauss, FRD; None: no data) at the estimator's 50 Hz filter run."""
        reason = ""
        if mag is None:
            reason = "no magnetometer data"
        else:
            if self.last is not None and _values(mag) == _values(self.last):  # (np.array_equal costs more)
                self._repeat += 1
            else:
                self._repeat = 0
            self.last = mag
            if self._repeat >= MAG_STUCK_SAMPLES:
                reason = "magnetometer stuck (readings repeat)"
            elif self.strength_gauss:
                strength = math.sqrt(float(mag @ mag))
                if abs(strength / self.strength_gauss - 1.0) > MAG_FIELD_TOL:
                    reason = f"magnetometer field {strength:.2f} G, expected {self.strength_gauss:.2f} G"
        if reason:
            self._good_since_us = None
            if not self.fault:
                self._declare_fault(reason)
        elif self.fault and self._bad_since_us is None:
            if self._good_since_us is None:
                self._good_since_us = now_us
            elif now_us - self._good_since_us >= MAG_RECOVER_S * 1e6:
                self.fault, self.fault_reason = False, ""
                self.events.append(("INFO", "EKF: magnetometer healthy again, heading fusion resumed"))

    def gate_result(self, now_us: int, ok: bool) -> None:
        """Whether the EKF accepted the heading it just tried to fuse."""
        if ok:
            self._bad_since_us = None
            return
        if self._bad_since_us is None:
            self._bad_since_us = now_us
        elif now_us - self._bad_since_us >= MAG_REJECT_FAULT_S * 1e6:
            self._declare_fault("heading inconsistent with the gyros")
            self._bad_since_us = None

    def _declare_fault(self, reason: str) -> None:
        self.fault, self.fault_reason = True, reason
        self._good_since_us = None
        self.events.append(("WARNING", f"EKF: {reason}: heading fusion stopped"))
