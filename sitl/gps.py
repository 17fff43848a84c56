"""The GPS receiver model: fix timing, latency, noise, wander, satellites and outages.

Inputs are ground truth in MAVLink frames (position in m NED from home, velocity
in m/s NED); outputs are fixes in geodetic coordinates (degrees, m AMSL) and m/s
NED.  Every error figure comes from a :class:`~sitl.sim_settings.SensorSettings`
read on every call, so a ``SIM_GPS_*`` parameter set in flight acts on the next
fix.  :class:`sitl.sensors.SensorSuite` owns one :class:`GpsReceiver` and gives
it two of its random streams.

One fix per period 1/SIM_GPS_HZ, sent at the caller's call nearest to each
multiple of the period, i.e. rounded to the 4 ms step.  A fix sent at time t
describes the truth at t - SIM_GPS_LAG_MS (linearly interpolated in a ring
buffer of the truth given at every call); the caller stamps it with t.  Per fix,
with dt_f the time since the previous fix, tau = 60 s and n ~ N(0, 1) a fresh
standard normal draw per axis and per use::

    z[j]   = a * z[j-1] + sqrt(1 - a^2) * n,   a = exp(-dt_f / tau)   (unit Gauss-Markov, N/E/D; z0 ~ N(0,1))
    e_N    = SIM_GPS_NOISE * n + SIM_GPS_DRIFT * z_N + SIM_GPS_GLITCH_N     (m; E likewise)
    e_D    = SIM_GPS_VNOISE * n + 1.5 * SIM_GPS_DRIFT * z_D + SIM_GPS_GLITCH_D
    v_err  = SIM_GPS_VELNOISE * n                                   (m/s, each NED axis)
    eph    = max(0.01, sqrt(SIM_GPS_NOISE^2 + SIM_GPS_DRIFT^2))       (1-sigma, per horizontal axis)
    epv    = max(0.01, sqrt(SIM_GPS_VNOISE^2 + (1.5 SIM_GPS_DRIFT)^2))

The glitch is not in eph/epv (the receiver does not know of it).  Healthy
fixes have fix_type SIM_GPS_FIXTYPE (3, a 3D fix; 6 for an RTK fixed solution, whose smaller
errors are set by the same SIM_GPS_* parameters: ``sitl --scenario rtk_gps``) and 12-14 satellites
(a slow random walk).  Outages
start as a Poisson process of rate SIM_GPS_DROP_RT per minute while the
receiver has lock and last SIM_GPS_DROP_S; so the long-run fraction of time
without a fix is r*d / (60 + r*d).  During an outage fixes are still sent at
the normal rate, with fix_type 1, 0 satellites, eph = epv = 99.99 m, the last
good position and zero velocity.  SIM_GPS_DISABLE = 1 silences the receiver:
:meth:`GpsReceiver.update` returns None.  SIM_GPS_STUCK = 1 freezes it: each fix is the last one
sent before, repeated (a fix is still computed, so the random draws stay the same).

Randomness: two generators, one for the fixes (a fixed 10 standard normals per
fix, so a run is reproducible whatever the settings) and one for the outages.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from mavsim_core.constants import LOCKSTEP_DT_US
from mavsim_core.geodesy import ned_to_geodetic
from sitl.sim_settings import SensorSettings

CALL_PERIOD_US = LOCKSTEP_DT_US  # the caller's period; fix times are rounded to it
GPS_DRIFT_TAU_S = 60.0  # correlation time of the GPS wander
GPS_VERTICAL_DRIFT_FACTOR = 1.5  # vertical wander RMS / horizontal
GPS_MIN_ERROR_M = 0.01  # floor of the reported eph/epv
GPS_NO_FIX_ERROR_M = 99.99  # eph/epv reported without lock
GPS_SATS_MIN, GPS_SATS_MAX = 12, 14
GPS_SATS_STEP_Z = 2.326  # |n| beyond this (2 % per fix) moves the satellite count by one
FIX_TYPE_NO_FIX = 1
HISTORY_LEN = 1024  # truth samples kept for the GPS latency (>= 500 ms at calls down to 0.5 ms apart)

_GPS_DRAWS = 10  # per fix: position white 3, Gauss-Markov 3, velocity 3, satellites 1
_HALF_CALL_US = CALL_PERIOD_US / 2

Vec3 = tuple[float, float, float]


@dataclass(frozen=True, slots=True)
class GpsReading:
    """One GPS fix as the receiver reports it (position and velocity of SIM_GPS_LAG_MS ago)."""

    lat_deg: float
    lon_deg: float
    alt_amsl_m: float
    vel_ned_m_s: Vec3
    eph_m: float  # 1-sigma error per horizontal axis
    epv_m: float  # 1-sigma vertical error
    satellites: int
    fix_type: int  # GPS_FIX_TYPE: 1 no fix, 3 3D fix, ... 6 RTK fixed


def _vec(v) -> tuple | list:
    """A 3-vector as plain Python floats (numpy arrays converted, sequences copied)."""
    return v.tolist() if type(v) is np.ndarray else tuple(v)


def course_over_ground_deg(vel_ned_m_s) -> float:
    """Direction of the horizontal velocity (m/s, NED), degrees clockwise from North, 0..360."""
    return math.degrees(math.atan2(vel_ned_m_s[1], vel_ned_m_s[0])) % 360.0


class GpsReceiver:
    """Turns the truth given at every call into GPS fixes with the errors of ``settings`` (read on every call).

    ``home`` is (lat deg, lon deg, alt m AMSL), the origin of the NED positions;
    ``fix_rng`` draws the per-fix noise, ``outage_rng`` the outage process.
    """

    def __init__(
        self,
        home: tuple[float, float, float],
        settings: SensorSettings,
        fix_rng: np.random.Generator,
        outage_rng: np.random.Generator,
    ) -> None:
        self.home = home
        self.settings = settings
        self._fix_rng = fix_rng
        self._outage_rng = outage_rng
        self._hist: deque = deque(maxlen=HISTORY_LEN)
        self._rate_hz = settings.gps_rate_hz
        self._next_us = 0.0  # the first call at or after time 0 sends a fix
        self._last_fix_us: int | None = None
        self._gm = fix_rng.standard_normal(3).tolist()  # stationary start: RMS right from the first fix
        self._gm_time_us: int | None = None
        self._sats = 13
        self._last_lla = home
        self._hazard_time_s: float | None = None
        self._hazard = 0.0
        self._hazard_target = float(outage_rng.standard_exponential())
        self._outage_start_s = -math.inf
        self.outage = False  # whether the last fix was sent during an outage
        self._last_fix: GpsReading | None = None  # the last fix sent (what SIM_GPS_STUCK repeats)

    def update(self, time_us: int, pos_ned_m, vel_ned_m_s) -> GpsReading | None:
        """Call every period with the truth at ``time_us``; a fix when one is due to be sent, else None.

        The fix describes the truth SIM_GPS_LAG_MS before ``time_us``.
        """
        self._hist.append((time_us, _vec(pos_ned_m), _vec(vel_ned_m_s)))
        s = self.settings
        if s.gps_rate_hz != self._rate_hz:  # a new rate: the next multiple of the new period
            self._rate_hz = s.gps_rate_hz
            last = self._last_fix_us
            self._next_us = 0.0 if last is None else self._next_due_us(last)
        if time_us + _HALF_CALL_US < self._next_us:
            return None
        self._next_us = self._next_due_us(time_us)
        self._last_fix_us = time_us
        if s.gps_disable:
            return None
        fix = self._fix(time_us, s)
        if s.gps_stuck and self._last_fix is not None:
            return self._last_fix
        self._last_fix = fix
        return fix

    def _next_due_us(self, time_us: float) -> float:
        period_us = 1e6 / self._rate_hz
        return (math.floor((time_us + _HALF_CALL_US) / period_us) + 1) * period_us

    def _truth_at(self, t_us: float):
        """(pos, vel) at ``t_us``, interpolated in the history (the oldest sample if it does not reach)."""
        newer = None
        for entry in reversed(self._hist):
            t0 = entry[0]
            if t0 <= t_us:
                if newer is None or t0 == t_us:
                    return entry[1], entry[2]
                f = (t_us - t0) / (newer[0] - t0)
                p0, v0, p1, v1 = entry[1], entry[2], newer[1], newer[2]
                return (
                    [p0[j] + f * (p1[j] - p0[j]) for j in range(3)],
                    [v0[j] + f * (v1[j] - v0[j]) for j in range(3)],
                )
            newer = entry
        return newer[1], newer[2]

    def _in_outage(self, t_s: float, s: SensorSettings) -> bool:
        """Advance the outage process to ``t_s``; whether the receiver has no lock then."""
        if self._hazard_time_s is None:
            self._hazard_time_s = t_s
        rate_s = s.gps_dropout_per_min / 60.0
        while True:
            end = self._outage_start_s + s.gps_dropout_s
            if t_s < end:
                return True
            t0 = max(self._hazard_time_s, end)  # the clock runs only while the receiver has lock
            if rate_s <= 0.0:
                self._hazard_time_s = t_s
                return False
            start = t0 + (self._hazard_target - self._hazard) / rate_s
            if start > t_s:
                self._hazard += rate_s * (t_s - t0)
                self._hazard_time_s = t_s
                return False
            self._outage_start_s = start
            self._hazard = 0.0
            self._hazard_target = float(self._outage_rng.standard_exponential())
            self._hazard_time_s = start

    def _fix(self, time_us: int, s: SensorSettings) -> GpsReading:
        n = self._fix_rng.standard_normal(_GPS_DRAWS).tolist()  # always the same count: reproducible
        # Gauss-Markov wander, unit variance; scaled by the current SIM_GPS_DRIFT
        if self._gm_time_us is not None:
            a = math.exp(-(time_us - self._gm_time_us) * 1e-6 / GPS_DRIFT_TAU_S)
            b = math.sqrt(max(0.0, 1.0 - a * a))
            gm = self._gm
            self._gm = [a * gm[0] + b * n[3], a * gm[1] + b * n[4], a * gm[2] + b * n[5]]
        self._gm_time_us = time_us
        if n[9] > GPS_SATS_STEP_Z and self._sats < GPS_SATS_MAX:
            self._sats += 1
        elif n[9] < -GPS_SATS_STEP_Z and self._sats > GPS_SATS_MIN:
            self._sats -= 1

        self.outage = self._in_outage(time_us * 1e-6, s)
        if self.outage:
            lat, lon, alt = self._last_lla
            return GpsReading(
                lat, lon, alt, (0.0, 0.0, 0.0), GPS_NO_FIX_ERROR_M, GPS_NO_FIX_ERROR_M, 0, FIX_TYPE_NO_FIX
            )

        p, v = self._truth_at(time_us - s.gps_lag_ms * 1000)
        hn, vn, dr = s.gps_noise_m, s.gps_vnoise_m, s.gps_drift_m
        drv = GPS_VERTICAL_DRIFT_FACTOR * dr
        gm = self._gm
        reported = (
            p[0] + hn * n[0] + dr * gm[0] + s.gps_glitch_n_m,
            p[1] + hn * n[1] + dr * gm[1] + s.gps_glitch_e_m,
            p[2] + vn * n[2] + drv * gm[2] + s.gps_glitch_d_m,
        )
        lat, lon, alt = self._last_lla = ned_to_geodetic(reported, *self.home)
        sv = s.gps_vel_noise_m_s
        vel = (v[0] + sv * n[6], v[1] + sv * n[7], v[2] + sv * n[8])
        return GpsReading(
            lat,
            lon,
            alt,
            vel,
            max(GPS_MIN_ERROR_M, math.hypot(hn, dr)),
            max(GPS_MIN_ERROR_M, math.hypot(vn, drv)),
            self._sats,
            s.gps_fix_type,
        )
