"""Sensor checks: an accelerometer, gyro or barometer fails when its data stops or repeats exactly.

PX4 validates every sensor instance with a DataValidator (``src/lib/data_validator``) in its sensors
module: a sensor whose data stops is flagged TIMEOUT, one whose value repeats exactly too many times in
a row STALE ("Accel #0 fail: STALE!"), and with no healthy instance left the sensor is failed.  The same
two checks here, one instance of each sensor, run at 50 Hz on the latest sample:

* TIMEOUT: no finite reading for ``TIMEOUT_S`` (HIL_SENSOR without the sensor's ``fields_updated``
  bits: the flight controller's side reads those fields as NaN);
* STALE: the reading exactly the same for ``STALE_S`` (a real sensor's noise always changes it).

A failed sensor is healthy again after ``RECOVER_S`` of good data.  Each change is queued as a
(severity name, text) event for the ground station.  The estimator acts on :attr:`SensorChecks.failed`:
a failed accelerometer or gyro makes the attitude invalid (the commander's attitude failsafe, the
pre-arm check and SYS_STATUS say so), a failed barometer is not fused.  The magnetometer has its own
checks (:mod:`autopilot.estimation.mag_health`).  Times are the samples' time stamps, µs.
"""

from __future__ import annotations

import math

from autopilot.topics import ImuSample

TIMEOUT_S = 0.1
STALE_S = 1.0
RECOVER_S = 1.0
ACCEL, GYRO, BARO = "accelerometer", "gyro", "barometer"


class _Check:
    """One sensor's timeout and stale checks."""

    def __init__(self, name: str) -> None:
        self.name = name
        self.last: tuple[float, ...] | None = None
        self.last_good_us: int | None = None  # last finite reading
        self.changed_us: int | None = None  # when the reading last changed
        self.good_since_us: int | None = None  # healthy readings since (while failed)
        self.failed = ""  # why it is failed ("" healthy)

    def update(self, now_us: int, reading: tuple[float, ...]) -> str | None:
        """One reading; the event text when the state changes, else None."""
        finite = math.isfinite(sum(reading))
        if finite:
            self.last_good_us = now_us
            if reading != self.last:
                self.changed_us = now_us
        self.last = reading if finite else None
        if self.last_good_us is None:
            self.last_good_us = self.changed_us = now_us  # (the first sample: nothing to judge yet)
        reason = ""
        if now_us - self.last_good_us >= TIMEOUT_S * 1e6:
            reason = "no data"
        elif self.changed_us is not None and now_us - self.changed_us >= STALE_S * 1e6:
            reason = "stale data (readings repeat)"
        if reason:
            self.good_since_us = None
            if not self.failed:
                self.failed = reason
                return f"{self.name.capitalize()} failed: {reason}"
            return None
        if self.failed:
            if self.good_since_us is None:
                self.good_since_us = now_us
            elif now_us - self.good_since_us >= RECOVER_S * 1e6:
                self.failed = ""
                return f"{self.name.capitalize()} healthy again"
        return None


class SensorChecks:
    """The checks of the accelerometer, gyro and barometer (see the module docstring)."""

    def __init__(self, events: list[tuple[str, str]]) -> None:
        self.events = events  # (severity name, text), shared with the estimator
        self._accel, self._gyro, self._baro = _Check(ACCEL), _Check(GYRO), _Check(BARO)
        self._checks = {ACCEL: self._accel, GYRO: self._gyro, BARO: self._baro}

    def update(self, s: ImuSample) -> None:
        """One sample (call at 50 Hz)."""
        now = s.timestamp_us
        for check, reading in (
            (self._accel, tuple(s.accel_frd_m_s2.tolist())),
            (self._gyro, tuple(s.gyro_frd_rad_s.tolist())),
            (self._baro, (s.pressure_hpa,)),
        ):
            text = check.update(now, reading)
            if text is not None:
                self.events.append(("CRITICAL" if check.failed else "INFO", text))

    @property
    def failed(self) -> dict[str, str]:
        """The failed sensors and why (empty: all healthy)."""
        return {name: c.failed for name, c in self._checks.items() if c.failed}

    def ok(self, name: str) -> bool:
        return not self._checks[name].failed

    @property
    def imu_ok(self) -> bool:
        """Both the accelerometer and the gyro are healthy (the attitude can be trusted)."""
        return self.ok(ACCEL) and self.ok(GYRO)
