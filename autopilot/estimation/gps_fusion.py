"""GPS fusion: the local origin, delayed fusion into both position estimators, glitch rejection and reset.

The local origin is set at the first good fix once the filters are aligned (latitude,
longitude, GPS altitude; the barometer's reading then becomes the height reference).
Each later fix is fused at the time it describes, ``EKF2_GPS_DELAY`` before its time
stamp: against the EKF's and the linear filter's states of that time.

A GPS position that fails the EKF's gate is rejected (a glitch).  If GPS velocity keeps
passing while position is rejected for ``GPS_RESET_S``, the position is reset to GPS
(PX4's behaviour); the jump is published as a reset delta so the position setpoint moves
with it and the vehicle does not.  If GPS velocity itself keeps failing its gate for
``VEL_RESET_S``, the inertial solution has gone wrong: velocity and position are reset to
GPS and the tilt uncertainty widened (PX4 resets on a fusion timeout).  Fixes that repeat
exactly (``GPS_STALE_FIXES`` in a row: a frozen receiver, PX4's DataValidator STALE rule) are
not fused: the GPS times out, as if silent, until a fix differs; nor are fixes with a NaN or
describing a time older than the EKF's history.  Also kept here: the low-passed derivative of
GPS velocity that the Mahony filter's gravity reference uses.  NED metres, m/s; times are
time stamps in microseconds (no clock).
"""

from __future__ import annotations

import math
from collections import deque
from collections.abc import Callable

import numpy as np

from autopilot.estimation.ekf import (
    P_GPS_P_GATE,
    P_GPS_P_NOISE,
    P_GPS_V_GATE,
    P_GPS_V_NOISE,
    ErrorStateEkf,
)
from autopilot.estimation.position_kf import P_GPS_DELAY, PositionVelocityFilter
from autopilot.estimation.state_history import state_at
from autopilot.parameters import ParamDef
from autopilot.topics import GpsSample
from mavsim_core.geodesy import geodetic_to_ned

GPS_MIN_SATS = 6
GPS_TIMEOUT_US = 500_000
GPS_RESET_S = 7.0  # GPS position rejected this long (velocity passing): reset to GPS (PX4: 7 s)
VEL_RESET_S = 1.0  # GPS velocity rejected this long (and it is not stale): reset velocity and position to GPS
TILT_RESET_STD_DEG = 3.0  # roll/pitch uncertainty (1 sigma) after such a reset
GPS_ACCEL_TAU_S = 0.5  # low-pass of the GPS velocity derivative given to the Mahony filter
GPS_STALE_FIXES = 5  # fixes in a row exactly the same (position and velocity): the receiver is stuck


def finite3(v: np.ndarray) -> bool:
    """All three components finite (cheaper than np.all(np.isfinite(v)) on a 3-vector)."""
    return math.isfinite(float(v[0]) + float(v[1]) + float(v[2]))


def _finite_fix(g: GpsSample) -> bool:
    """Latitude, longitude, altitude and the velocity all finite (a NaN must never reach the filters)."""
    return math.isfinite(g.lat_deg + g.lon_deg + g.alt_amsl_m) and finite3(np.asarray(g.vel_ned_m_s, dtype=float))


class GpsFusion:
    """Fuses GPS fixes into the EKF and the linear position filter; owns the local origin."""

    def __init__(
        self,
        ekf: ErrorStateEkf,
        lkf: PositionVelocityFilter,
        events: list[tuple[str, str]],
        p: Callable[[ParamDef], float],
    ) -> None:
        self.ekf = ekf
        self.lkf = lkf
        self.events = events  # (severity name, text), shared with the estimator
        self._p = p  # a parameter's current value
        self.delay_us = int(P_GPS_DELAY.default * 1000)
        self.last_us: int | None = None  # time stamp of the latest good fix
        self.first_us: int | None = None  # ... of the fix that set the origin
        self.origin: tuple[float, float, float] | None = None  # latitude, longitude (deg), altitude AMSL (m)
        self.baro_offset_m = 0.0  # barometric altitude at the origin
        self.accel_ned = np.zeros(3)  # low-passed GPS velocity derivative, m/s^2
        self._vels: deque[tuple[int, np.ndarray]] = deque(maxlen=2)
        # The linear filter's (time, position, velocity) of the last 32 runs, for delayed fusion.
        self.history: deque[tuple[int, np.ndarray, np.ndarray]] = deque(maxlen=32)
        self.last_pos_fused_us: int | None = None
        self.pos_rejected_since_us: int | None = None
        self.vel_rejected_since_us: int | None = None
        self.old_fixes = 0  # fixes describing a time older than the EKF's history: not fused
        self.glitch = False
        self.reset_count = 0
        self.reset_delta_ned_m = np.zeros(3)  # the latest position reset's jump
        self.stale = False  # the fixes repeat exactly: not fused
        self._last_fix: tuple[float, ...] | None = None
        self._repeats = 0

    def ok(self, now_us: int) -> bool:
        """A good fix arrived within GPS_TIMEOUT_US."""
        return self.last_us is not None and now_us - self.last_us < GPS_TIMEOUT_US

    def velocities_known(self) -> int:
        """How many of the last two fixes' velocities the GPS acceleration is built from."""
        return len(self._vels)

    def fuse(self, g: GpsSample, baro_alt_m: float | None, filters_ready: bool) -> bool:
        """One fix; True when it set the origin (the caller then looks up the magnetic field there)."""
        if g.fix_type < 3 or g.satellites < GPS_MIN_SATS or not _finite_fix(g) or self._stale(g):
            return False
        self.last_us = g.timestamp_us
        vel = np.asarray(g.vel_ned_m_s, dtype=float)
        self._update_accel(g.timestamp_us, vel)
        if self.origin is None:
            if baro_alt_m is None or not filters_ready:
                return False
            self.origin = (g.lat_deg, g.lon_deg, g.alt_amsl_m)
            self.baro_offset_m = baro_alt_m
            self.first_us = g.timestamp_us
            self.lkf.reset(np.zeros(3), vel)
            self.ekf.reset_position(np.zeros(3), self._p(P_GPS_P_NOISE) ** 2)
            self.ekf.reset_velocity(vel, self._p(P_GPS_V_NOISE) ** 2)
            self.last_pos_fused_us = g.timestamp_us
            return True
        pos = geodetic_to_ned(g.lat_deg, g.lon_deg, g.alt_amsl_m, *self.origin)
        then_us = g.timestamp_us - self.delay_us
        pos_then, vel_then = state_at(self.history, then_us)
        self.lkf.fuse_gps(pos, vel, pos_then, vel_then)
        self._fuse_ekf(g, pos, vel, then_us)
        return False

    def _stale(self, g: GpsSample) -> bool:
        """Whether this fix and the GPS_STALE_FIXES - 1 before it are exactly the same (reported once)."""
        fix = (g.lat_deg, g.lon_deg, g.alt_amsl_m, *np.asarray(g.vel_ned_m_s, dtype=float).tolist())
        self._repeats = self._repeats + 1 if fix == self._last_fix else 0
        self._last_fix = fix
        stale = self._repeats >= GPS_STALE_FIXES - 1
        if stale != self.stale:
            self.stale = stale
            text = "GPS failed: stale data (fixes repeat)" if stale else "GPS healthy again"
            self.events.append(("CRITICAL" if stale else "INFO", text))
        return stale

    def _fuse_ekf(self, g: GpsSample, pos: np.ndarray, vel: np.ndarray, then_us: int) -> None:
        """Velocity, then horizontal position against the EKF's state at ``then_us``; glitch and reset."""
        ekf = self.ekf
        pos_then, vel_then = ekf.state_at(then_us)
        if pos_then is None or vel_then is None:  # (both or neither)
            if ekf.history and then_us < ekf.history[0][0]:
                self.old_fixes += 1  # older than the filter remembers: not comparable with anything, not fused
                return
            pos_then, vel_then = ekf.p, ekf.v  # (no history yet)
        vn = max(self._p(P_GPS_V_NOISE), 0.0)
        pn = max(self._p(P_GPS_P_NOISE), g.eph_m if math.isfinite(g.eph_m) else 0.0)
        now = g.timestamp_us
        if ekf.fuse_vector(3, vel, vel_then, vn * vn, self._p(P_GPS_V_GATE), "vel") == 0:
            self.vel_rejected_since_us = None
        elif self.vel_rejected_since_us is None:
            self.vel_rejected_since_us = now
        elif now - self.vel_rejected_since_us >= VEL_RESET_S * 1e6:
            self._reset_inertial(now, pos, vel, pos_then, vel_then, vn, pn)
            return
        lag_s = max(0.0, (ekf.time_us - then_us) * 1e-6) if ekf.time_us is not None else 0.0
        rejected = ekf.fuse_vector(0, pos[:2], pos_then[:2], pn * pn, self._p(P_GPS_P_GATE), "pos", lag_s)
        if rejected == 0:
            self.last_pos_fused_us = now
            self.pos_rejected_since_us = None
            if self.glitch:
                self.glitch = False
                self.events.append(("INFO", "EKF: GPS position consistent again"))
            return
        if self.pos_rejected_since_us is None:
            self.pos_rejected_since_us = now
        if not self.glitch:
            self.glitch = True
            jump = math.hypot(*(pos[:2] - pos_then[:2]))
            self.events.append(("WARNING", f"EKF: GPS position rejected ({jump:.1f} m from the estimate)"))
        if now - self.pos_rejected_since_us >= GPS_RESET_S * 1e6 and ekf.ratio["vel"] <= 1.0:
            self._reset_to_gps(now, pos, pos_then, pn)

    def _reset_inertial(self, now: int, pos, vel, pos_then, vel_then, vn: float, pn: float) -> None:
        """GPS velocity has disagreed for VEL_RESET_S: the inertial solution is wrong (PX4 resets velocity and
        position when their fusion times out).  Velocity and position are reset to GPS (carried to now by
        the inertial change since the fix's time) and the tilt uncertainty widened: a tilt error is the
        likely cause, and the next fixes then correct it."""
        self.ekf.reset_velocity(vel + (self.ekf.v - vel_then), vn * vn, math.radians(TILT_RESET_STD_DEG))
        self.vel_rejected_since_us = None
        self.events.append(("WARNING", "EKF: GPS velocity rejected, velocity reset to GPS"))
        self._reset_to_gps(now, pos, pos_then, pn)

    def _reset_to_gps(self, now: int, pos: np.ndarray, pos_then: np.ndarray, pn: float) -> None:
        """GPS has disagreed for long while its velocity agrees: believe it (a persistent glitch)."""
        ekf = self.ekf
        target = ekf.p.copy()
        target[:2] += pos[:2] - pos_then[:2]
        delta = ekf.reset_position(target, pn * pn, slice(0, 2))
        self.lkf.x[:2, 0] += delta[:2]
        for _, p, _ in self.history:
            p[:2] += delta[:2]
        self.reset_count += 1
        self.reset_delta_ned_m = delta
        self.pos_rejected_since_us = None
        self.last_pos_fused_us = now
        self.glitch = False
        self.events.append(("WARNING", f"EKF: position reset to GPS ({math.hypot(delta[0], delta[1]):.1f} m)"))

    def _update_accel(self, time_us: int, vel_ned: np.ndarray) -> None:
        """Low-pass (GPS_ACCEL_TAU_S) the derivative of GPS velocity between fixes."""
        if not finite3(vel_ned):
            return
        last = self._vels[-1] if self._vels else None
        self._vels.append((time_us, vel_ned))
        if last is None:
            return
        dt = (time_us - last[0]) * 1e-6
        if 0.0 < dt < 1.0:
            accel = (vel_ned - last[1]) / dt
            self.accel_ned += dt / (dt + GPS_ACCEL_TAU_S) * (accel - self.accel_ned)
        else:
            self.accel_ned[:] = 0.0
