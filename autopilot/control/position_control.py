"""Position and velocity control (PX4's PositionControl structure, [Q 2.10]).

Position P -> velocity setpoint (limited) -> velocity PID -> acceleration setpoint (plus the
trajectory's acceleration, minus an estimated disturbance) -> thrust vector.  [Q 3.4] clamps the
integrators, the derivative and the outputs; here those are :class:`PositionGains` fields (PX4's
MPC_*_INT_LIM, MPC_ACC_*_MAX and MPC_TILTMAX_AIR parameters, mapped by
:mod:`autopilot.control.gains_from_params`).  The thrust vector is in newtons, NED,
and carries the hover feed-forward m g from the vehicle file.  Integration stops on
an axis whose output is saturated (thrust or tilt limit) in the direction that
would make it worse.

NaN in a setpoint means "not controlled" on that axis, as in PX4: a NaN position
component leaves the axis to its velocity setpoint; a NaN velocity too leaves it
to its acceleration setpoint (no velocity loop on the axis); with all three NaN
the axis holds (velocity setpoint zero).  A NaN estimate component takes its axis
out of the loops it feeds.  NaN never reaches an integrator or the thrust, and
:class:`PositionControlOutput` says which axes were controlled.  A ``dt`` that is not in
(0, :data:`MAX_DT_S`] (time going back, a gap) integrates nothing: no integrator growth, no
derivative (it starts again from the step's velocity), no jerk-limited feed-forward change.

Pure: no I/O, no clock; ``dt`` is an input.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mavsim_core.constants import GRAVITY_M_S2
from mavsim_core.quaternion import cross

Axes3 = tuple[float, float, float]  # north, east, down
Flags3 = tuple[bool, bool, bool]
_GRAVITY_NED = np.array([0.0, 0.0, GRAVITY_M_S2])
MAX_DT_S = 0.1  # the longest step integrated, s (the loop runs every 20 ms)


@dataclass(frozen=True, slots=True)
class PositionGains:
    """Gains and limits of the position and velocity loops (NED; per-axis tuples are north, east, down)."""

    pos_p_per_s: Axes3  # velocity setpoint (m/s) per m of position error
    vel_p_per_s: Axes3  # acceleration (m/s^2) per m/s of velocity error
    vel_i_per_s2: Axes3  # integrator growth (m/s^2 per s) per m/s of velocity error
    vel_d_unitless: Axes3  # acceleration (m/s^2) per m/s^2 of (filtered) measured acceleration
    vel_int_lim_m_s2: Axes3  # velocity integrator clamp
    vel_d_lim_m_s2: float  # clamp of the derivative term (before its gain)
    vel_d_lowpass_hz: float  # low-pass cut-off of the velocity derivative; 0: unfiltered
    vel_xy_max_m_s: float  # horizontal speed limit
    vel_up_max_m_s: float  # ascent speed limit
    vel_down_max_m_s: float  # descent speed limit
    tilt_max_rad: float  # tilt limit of the thrust vector
    thrust_min_frac: float  # least collective thrust in flight, fraction of the vehicle's maximum
    thrust_max_frac: float  # most collective thrust, fraction of the vehicle's maximum
    jerk_max_m_s3: float  # how fast the acceleration feed-forward may change


@dataclass(frozen=True, slots=True)
class PositionSetpoint:
    """Position (m, NED; NaN = not controlled), velocity feed-forward (m/s; NaN = none), yaw (rad) and
    acceleration feed-forward (m/s^2, NED; a trajectory's own acceleration; None or NaN = none)."""

    pos_ned_m: np.ndarray
    vel_ned_m_s: np.ndarray
    yaw_rad: float
    acc_ned_m_s2: np.ndarray | None = None


@dataclass(frozen=True, slots=True)
class PositionControlOutput:
    """One step of position control: the thrust vector and what it was made of (NED)."""

    thrust_ned_n: np.ndarray  # wanted thrust vector, N (finite)
    vel_sp_ned_m_s: np.ndarray  # velocity setpoint flown, m/s (NaN on an axis without velocity control)
    acc_sp_ned_m_s2: np.ndarray  # acceleration setpoint before the thrust limits, m/s^2 (finite)
    pos_controlled: Flags3  # the axis flew to a position setpoint
    vel_controlled: Flags3  # the axis ran the velocity loop (position, velocity or hold)
    saturated: Flags3  # thrust or tilt limit reached on the axis (its integrator held)


class PositionControl:
    def __init__(self, gains: PositionGains, mass_kg: float, max_total_thrust_n: float) -> None:
        self.mass_kg = mass_kg
        self.max_total_thrust_n = max_total_thrust_n
        self.vel_int = np.zeros(3)  # m/s^2
        self.prev_vel: np.ndarray | None = None
        self.d_filt = np.zeros(3)  # low-passed velocity derivative, m/s^2
        self.vel_sp = np.zeros(3)
        self.acc_sp = np.zeros(3)
        self.acc_ff = np.zeros(3)  # the trajectory's acceleration as fed forward, jerk-limited, m/s^2
        self.output: PositionControlOutput | None = None  # the latest step's
        self.set_gains(gains)

    def set_gains(self, gains: PositionGains) -> None:
        """New gains and limits from the next update on."""
        self.gains = gains
        self._pos_p = np.array(gains.pos_p_per_s)
        self._vel_p = np.array(gains.vel_p_per_s)
        self._vel_i = np.array(gains.vel_i_per_s2)
        self._vel_d = np.array(gains.vel_d_unitless)
        self._int_lim = np.array(gains.vel_int_lim_m_s2)
        self._thr_min_n = gains.thrust_min_frac * self.max_total_thrust_n
        self._thr_max_n = gains.thrust_max_frac * self.max_total_thrust_n

    def reset(self) -> None:
        self.vel_int[:] = 0.0
        self.prev_vel = None
        self.d_filt[:] = 0.0
        self.acc_ff[:] = 0.0

    def update(self, pos: np.ndarray, vel: np.ndarray, sp: PositionSetpoint, dt: float) -> np.ndarray:
        """The thrust vector (N, NED) for this step; :meth:`control` gives the whole record."""
        return self.control(pos, vel, sp, dt).thrust_ned_n

    def control(
        self,
        pos: np.ndarray,
        vel: np.ndarray,
        sp: PositionSetpoint,
        dt: float,
        disturbance_ned_m_s2: np.ndarray | None = None,
    ) -> PositionControlOutput:
        """One step from the position and velocity estimates (m, m/s, NED) and the setpoint.

        ``disturbance_ned_m_s2``: an estimated external acceleration (m/s^2, NED; a disturbance
        observer's), cancelled by feeding it forward with the opposite sign (non-finite: ignored)."""
        g = self.gains
        acc_want = sp.acc_ned_m_s2 if sp.acc_ned_m_s2 is not None else np.zeros(3)
        acc_given = np.isfinite(acc_want) if sp.acc_ned_m_s2 is not None else np.zeros(3, dtype=bool)
        vel_ok = np.isfinite(vel)
        if not _finite(vel):
            vel = np.where(vel_ok, vel, math.nan)  # infinities as NaN: no inf - inf below
        pos_ok = np.isfinite(pos)
        if not _finite(pos):
            pos = np.where(pos_ok, pos, math.nan)
        pos_ctrl = np.isfinite(sp.pos_ned_m) & pos_ok & vel_ok
        vel_given = np.isfinite(sp.vel_ned_m_s)
        # The velocity loop runs (a NaN velocity setpoint: toward zero, holding) unless the axis is
        # left to a given acceleration setpoint alone.
        vel_ctrl = (pos_ctrl | vel_given | ~acc_given) & vel_ok

        # Position P with velocity feed-forward, then velocity limits.
        vel_sp = np.where(vel_given, sp.vel_ned_m_s, 0.0)
        err = sp.pos_ned_m - pos
        vel_sp[pos_ctrl] += self._pos_p[pos_ctrl] * err[pos_ctrl]
        h = math.hypot(vel_sp[0], vel_sp[1])
        if h > g.vel_xy_max_m_s:
            vel_sp[:2] *= g.vel_xy_max_m_s / h
        vel_sp[2] = min(max(vel_sp[2], -g.vel_up_max_m_s), g.vel_down_max_m_s)
        all_vel = bool(vel_ctrl.all())
        self.vel_sp = vel_sp if all_vel else np.where(vel_ctrl, vel_sp, math.nan)

        # Velocity PID (derivative on the measurement, clamped); nothing on an axis without velocity control.
        vel_err = vel_sp - vel if all_vel else np.where(vel_ctrl, vel_sp - vel, 0.0)
        acc_sp = self._velocity_pid(vel, vel_err, dt)
        if not all_vel:
            acc_sp = np.where(vel_ctrl, acc_sp, 0.0)
        # The trajectory's acceleration, fed forward at most MPC_JERK_AUTO faster per second: the
        # moves' speed profile is trapezoidal, and a step in it would be a step of the attitude
        # setpoint that saturates the motors.
        step = g.jerk_max_m_s3 * dt if _dt_ok(dt) else 0.0  # (a negative step would swap the clip's bounds)
        self.acc_ff += np.clip(np.where(acc_given, acc_want, 0.0) - self.acc_ff, -step, step)
        acc_sp = acc_sp + self.acc_ff
        if disturbance_ned_m_s2 is not None and _finite(disturbance_ned_m_s2):
            acc_sp = acc_sp - disturbance_ned_m_s2

        thrust, sat = self._thrust(acc_sp, vel_err)
        self._integrate(vel_err, acc_sp, sat, dt)
        self.acc_sp = acc_sp
        self.output = out = PositionControlOutput(
            thrust_ned_n=thrust,
            vel_sp_ned_m_s=self.vel_sp,
            acc_sp_ned_m_s2=acc_sp,
            pos_controlled=_flags(pos_ctrl),
            vel_controlled=_flags(vel_ctrl),
            saturated=_flags(sat),
        )
        return out

    def _velocity_pid(self, vel: np.ndarray, vel_err: np.ndarray, dt: float) -> np.ndarray:
        """P and I on the velocity error, D on the measured velocity (low-passed, clamped); m/s^2."""
        g = self.gains
        dt_ok = _dt_ok(dt)
        d_raw = np.zeros(3) if self.prev_vel is None or not dt_ok else -(vel - self.prev_vel) / dt
        if not _finite(d_raw):
            d_raw = np.where(np.isfinite(d_raw), d_raw, self.d_filt)  # a NaN velocity leaves the filter as it was
        self.prev_vel = vel.copy()
        if g.vel_d_lowpass_hz > 0 and dt_ok:
            self.d_filt += dt / (dt + 1.0 / (2.0 * math.pi * g.vel_d_lowpass_hz)) * (d_raw - self.d_filt)
        else:
            self.d_filt[:] = d_raw
        d_term = np.minimum(np.maximum(self.d_filt, -g.vel_d_lim_m_s2), g.vel_d_lim_m_s2)
        acc: np.ndarray = self._vel_p * vel_err + self.vel_int + self._vel_d * d_term
        return acc

    def _thrust(self, acc_sp: np.ndarray, vel_err: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Thrust vector with hover feed-forward, T = m (a - g) in N, NED, within the thrust and tilt
        limits; and per axis whether a limit cut it (in the direction the velocity error asks for)."""
        thrust = self.mass_kg * (acc_sp - _GRAVITY_NED)
        sat = np.zeros(3, dtype=bool)
        thr_min, thr_max = self._thr_min_n, self._thr_max_n
        # Vertical thrust limits (up is -z).
        up = -thrust[2]
        if up > thr_max:
            thrust[2], sat[2] = -thr_max, vel_err[2] < 0
        elif up < thr_min:
            thrust[2], sat[2] = -thr_min, vel_err[2] > 0
        # Tilt limit: keep the vertical component, shorten the horizontal one.
        h_max = -thrust[2] * math.tan(self.gains.tilt_max_rad)
        h_max = min(h_max, math.sqrt(max(thr_max**2 - thrust[2] ** 2, 0.0)))
        h = math.hypot(thrust[0], thrust[1])
        if h > h_max:
            thrust[:2] *= h_max / h
            sat[:2] = True
        return thrust, sat

    def _integrate(self, vel_err: np.ndarray, acc_sp: np.ndarray, sat: np.ndarray, dt: float) -> None:
        """Integrate unless that would push further into saturation (anti-windup) or ``dt`` is not usable; clamp."""
        if not _dt_ok(dt):
            return
        grow = self._vel_i * vel_err * dt
        if sat[2]:
            grow[2] = 0.0
        if sat[0]:
            grow[:2] = np.where(grow[:2] * acc_sp[:2] > 0, 0.0, grow[:2])
        if not _finite(grow):
            grow = np.where(np.isfinite(grow), grow, 0.0)  # NaN never reaches the integrator
        self.vel_int += grow
        self.vel_int = np.minimum(np.maximum(self.vel_int, -self._int_lim), self._int_lim)


def _dt_ok(dt: float) -> bool:
    """A step that may be integrated: 0 < dt <= MAX_DT_S (not NaN, not time going back, not a gap)."""
    return 0.0 < dt <= MAX_DT_S


def _finite(v: np.ndarray) -> bool:
    """All three components finite (cheaper than np.all(np.isfinite(v)) on a 3-vector)."""
    return math.isfinite(float(v[0]) + float(v[1]) + float(v[2]))


def _flags(mask: np.ndarray) -> Flags3:
    a, b, c = mask.tolist()
    return (bool(a), bool(b), bool(c))


def attitude_from_thrust(thrust_ned_n: np.ndarray, yaw_rad: float) -> np.ndarray:
    """Attitude (3x3, FRD->NED) whose -z axis points along the thrust, with the given yaw."""
    n = np.linalg.norm(thrust_ned_n)
    z_b = -thrust_ned_n / n if n > 1e-6 else np.array([0.0, 0.0, 1.0])
    x_c = np.array([math.cos(yaw_rad), math.sin(yaw_rad), 0.0])
    y_b = cross(z_b, x_c)
    ny = np.linalg.norm(y_b)
    y_b = y_b / ny if ny > 1e-6 else np.array([-math.sin(yaw_rad), math.cos(yaw_rad), 0.0])
    x_b = cross(y_b, z_b)
    return np.column_stack((x_b, y_b, z_b))
