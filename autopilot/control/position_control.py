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

from autopilot.control.thrust_cone import AxisCone, horizontal_share
from mavsim_core.constants import GRAVITY_M_S2
from mavsim_core.floats import floats3

Axes3 = tuple[float, float, float]  # north, east, down
Flags3 = tuple[bool, bool, bool]
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
    acceleration feed-forward (m/s^2, NED; a trajectory's own acceleration; None or NaN = none).

    ``int_band_m_s``: the horizontal velocity integrator learns only while the horizontal velocity
    error is under this (m/s; inf, the default: always).  A chase of a moving target sets it, so that
    the chase's transient is not stored and given back later as a slow lag behind the target.
    ``axis_cone``: the vehicle's down axis kept inside this cone by shortening the horizontal thrust (after the
    tilt limit; :mod:`autopilot.control.thrust_cone`), e.g. so that a camera keeps the landing target in view.
    ``yaw_rate_rad_s``: the yaw setpoint's own rate (rad/s about NED down), fed forward to the rate loop as PX4's
    yawspeed setpoint, so that a turning heading is flown without the attitude loop's lag.
    ``acc_slew_m_s3``: the horizontal thrust per unit mass (m/s^2) changes at most this fast (m/s^3; inf, the
    default: no limit), so that the attitude setpoint swings no faster than the vehicle turns (a chase whose
    target reverses its turn asked for 35 deg of tilt in 0.16 s; the motors saturated on roll and pitch, the
    collective fell to half and the vehicle lost 1 m of height)."""

    pos_ned_m: np.ndarray
    vel_ned_m_s: np.ndarray
    yaw_rad: float
    acc_ned_m_s2: np.ndarray | None = None
    int_band_m_s: float = math.inf
    axis_cone: AxisCone | None = None
    yaw_rate_rad_s: float = 0.0
    acc_slew_m_s3: float = math.inf


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
    """The loops run on Python floats per axis (numpy's per-call cost on 3-vectors would be most of the work);
    the state (``vel_int``, ``d_filt``, ``acc_ff``: m/s^2, NED) and the outputs stay arrays."""

    def __init__(self, gains: PositionGains, mass_kg: float, max_total_thrust_n: float) -> None:
        self.mass_kg = mass_kg
        self.max_total_thrust_n = max_total_thrust_n
        self.vel_int = np.zeros(3)  # m/s^2
        self.prev_vel: list[float] | None = None  # the latest step's velocity estimate, m/s
        self.d_filt = np.zeros(3)  # low-passed velocity derivative, m/s^2
        self.vel_sp = np.zeros(3)
        self.acc_sp = np.zeros(3)
        self.acc_ff = np.zeros(3)  # the trajectory's acceleration as fed forward, jerk-limited, m/s^2
        self._prev_h: tuple[float, float] | None = None  # the latest step's horizontal thrust per mass, m/s^2
        self.output: PositionControlOutput | None = None  # the latest step's
        self.set_gains(gains)

    def set_gains(self, gains: PositionGains) -> None:
        """New gains and limits from the next update on."""
        self.gains = gains
        self._pos_p = floats3(gains.pos_p_per_s)
        self._vel_p = floats3(gains.vel_p_per_s)
        self._vel_i = floats3(gains.vel_i_per_s2)
        self._vel_d = floats3(gains.vel_d_unitless)
        self._int_lim = floats3(gains.vel_int_lim_m_s2)
        self._thr_min_n = gains.thrust_min_frac * self.max_total_thrust_n
        self._thr_max_n = gains.thrust_max_frac * self.max_total_thrust_n

    def reset(self) -> None:
        self.vel_int[:] = 0.0
        self.prev_vel = None
        self.d_filt[:] = 0.0
        self.acc_ff[:] = 0.0
        self._prev_h = None

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
        isfinite = math.isfinite
        acc_in = sp.acc_ned_m_s2
        acc_want = floats3(acc_in) if acc_in is not None else [0.0, 0.0, 0.0]
        vel_f, pos_f = floats3(vel), floats3(pos)
        sp_pos, sp_vel = floats3(sp.pos_ned_m), floats3(sp.vel_ned_m_s)
        acc_given, pos_ctrl, vel_given, vel_ctrl = [False] * 3, [False] * 3, [False] * 3, [False] * 3
        for i in (0, 1, 2):
            vel_ok = isfinite(vel_f[i])
            if not vel_ok:
                vel_f[i] = math.nan  # infinities as NaN: no inf - inf below
            acc_given[i] = ag = acc_in is not None and isfinite(acc_want[i])
            pos_ctrl[i] = pc = vel_ok and isfinite(sp_pos[i]) and isfinite(pos_f[i])
            vel_given[i] = vg = isfinite(sp_vel[i])
            # The velocity loop runs (a NaN velocity setpoint: toward zero, holding) unless the axis is
            # left to a given acceleration setpoint alone.
            vel_ctrl[i] = (pc or vg or not ag) and vel_ok

        vel_sp = self._velocity_setpoint(pos_f, sp_pos, sp_vel, pos_ctrl, vel_given)
        all_vel = all(vel_ctrl)
        self.vel_sp = np.array(vel_sp if all_vel else [v if c else math.nan for v, c in zip(vel_sp, vel_ctrl)])

        # Velocity PID (derivative on the measurement, clamped); nothing on an axis without velocity control.
        vel_err = [vs - v if c else 0.0 for vs, v, c in zip(vel_sp, vel_f, vel_ctrl)]
        acc_sp = self._velocity_pid(vel_f, vel_err, dt)
        if not all_vel:
            acc_sp = [a if c else 0.0 for a, c in zip(acc_sp, vel_ctrl)]
        # The trajectory's acceleration, fed forward at most MPC_JERK_AUTO faster per second: the
        # moves' speed profile is trapezoidal, and a step in it would be a step of the attitude
        # setpoint that saturates the motors.
        step = self.gains.jerk_max_m_s3 * dt if _dt_ok(dt) else 0.0
        ff = self.acc_ff.tolist()
        for i in (0, 1, 2):
            change = (acc_want[i] if acc_given[i] else 0.0) - ff[i]
            ff[i] += _clamp(change, step)
        self.acc_ff = np.array(ff)
        acc_sp = [a + f for a, f in zip(acc_sp, ff)]
        if disturbance_ned_m_s2 is not None and _finite(disturbance_ned_m_s2):
            acc_sp = [a - d for a, d in zip(acc_sp, floats3(disturbance_ned_m_s2))]

        thrust, sat = self._thrust(acc_sp, vel_err)
        if sp.axis_cone is not None and (k := horizontal_share((thrust[0], thrust[1], thrust[2]), sp.axis_cone)) < 1.0:
            thrust[0], thrust[1] = thrust[0] * k, thrust[1] * k
            sat[0] = sat[1] = True
        self._slew_limit(thrust, sat, sp.acc_slew_m_s3, dt)
        self._integrate(vel_err, acc_sp, sat, dt, sp.int_band_m_s)
        self.acc_sp = np.array(acc_sp)
        self.output = out = PositionControlOutput(
            thrust_ned_n=np.array(thrust),
            vel_sp_ned_m_s=self.vel_sp,
            acc_sp_ned_m_s2=self.acc_sp,
            pos_controlled=(pos_ctrl[0], pos_ctrl[1], pos_ctrl[2]),
            vel_controlled=(vel_ctrl[0], vel_ctrl[1], vel_ctrl[2]),
            saturated=(sat[0], sat[1], sat[2]),
        )
        return out

    def _velocity_setpoint(
        self, pos: list[float], sp_pos: list[float], sp_vel: list[float], pos_ctrl: list[bool], vel_given: list[bool]
    ) -> list[float]:
        """Position P with velocity feed-forward, then the velocity limits (m/s, NED)."""
        g = self.gains
        vel_sp = [v if given else 0.0 for v, given in zip(sp_vel, vel_given)]
        for i in (0, 1, 2):
            if pos_ctrl[i]:
                vel_sp[i] += self._pos_p[i] * (sp_pos[i] - pos[i])
        h = math.hypot(vel_sp[0], vel_sp[1])
        if h > g.vel_xy_max_m_s:
            k = g.vel_xy_max_m_s / h
            vel_sp[0] *= k
            vel_sp[1] *= k
        vel_sp[2] = min(max(vel_sp[2], -g.vel_up_max_m_s), g.vel_down_max_m_s)
        return vel_sp

    def _velocity_pid(self, vel: list[float], vel_err: list[float], dt: float) -> list[float]:
        """P and I on the velocity error, D on the measured velocity (low-passed, clamped); m/s^2."""
        g = self.gains
        dt_ok = _dt_ok(dt)
        d_filt = self.d_filt.tolist()
        prev = self.prev_vel
        d_raw = [0.0, 0.0, 0.0] if prev is None or not dt_ok else [-(v - p) / dt for v, p in zip(vel, prev)]
        # A NaN velocity leaves the filter as it was.
        d_raw = [r if math.isfinite(r) else d for r, d in zip(d_raw, d_filt)]
        self.prev_vel = vel
        if g.vel_d_lowpass_hz > 0 and dt_ok:
            k = dt / (dt + 1.0 / (2.0 * math.pi * g.vel_d_lowpass_hz))
            d_filt = [d + k * (r - d) for r, d in zip(d_raw, d_filt)]
        else:
            d_filt = d_raw
        self.d_filt = np.array(d_filt)
        lim = g.vel_d_lim_m_s2
        kp, ki, kd = self._vel_p, self.vel_int.tolist(), self._vel_d
        return [kp[i] * vel_err[i] + ki[i] + kd[i] * _clamp(d_filt[i], lim) for i in (0, 1, 2)]

    def _thrust(self, acc_sp: list[float], vel_err: list[float]) -> tuple[list[float], list[bool]]:
        """Thrust vector with hover feed-forward, T = m (a - g) in N, NED, within the thrust and tilt
        limits; and per axis whether a limit cut it (in the direction the velocity error asks for)."""
        m = self.mass_kg
        tx, ty, tz = m * acc_sp[0], m * acc_sp[1], m * (acc_sp[2] - GRAVITY_M_S2)
        sat = [False, False, False]
        thr_min, thr_max = self._thr_min_n, self._thr_max_n
        # Vertical thrust limits (up is -z).
        up = -tz
        if up > thr_max:
            tz, sat[2] = -thr_max, vel_err[2] < 0
        elif up < thr_min:
            tz, sat[2] = -thr_min, vel_err[2] > 0
        # Tilt limit: keep the vertical component, shorten the horizontal one.
        h_max = -tz * math.tan(self.gains.tilt_max_rad)
        h_max = min(h_max, math.sqrt(max(thr_max**2 - tz**2, 0.0)))
        h = math.hypot(tx, ty)
        if h > h_max:
            k = h_max / h
            tx, ty = tx * k, ty * k
            sat[0] = sat[1] = True
        return [tx, ty, tz], sat

    def _slew_limit(self, thrust: list[float], sat: list[bool], slew_m_s3: float, dt: float) -> None:
        """Hold the horizontal thrust's change (per unit mass) to ``slew_m_s3 dt`` from the last step's, in place;
        a limited step counts as saturated on both horizontal axes (their integrators hold)."""
        m = self.mass_kg
        prev = self._prev_h
        if prev is not None and math.isfinite(slew_m_s3) and _dt_ok(dt):
            dx, dy = thrust[0] / m - prev[0], thrust[1] / m - prev[1]
            n, lim = math.hypot(dx, dy), slew_m_s3 * dt
            if n > lim:
                thrust[0], thrust[1] = m * (prev[0] + dx * lim / n), m * (prev[1] + dy * lim / n)
                sat[0] = sat[1] = True
        self._prev_h = (thrust[0] / m, thrust[1] / m)

    def _integrate(self, vel_err: list[float], acc_sp: list[float], sat: list[bool], dt: float, band: float) -> None:
        """Integrate unless that would push further into saturation (anti-windup), the horizontal velocity
        error is outside ``band`` (m/s; horizontal axes only) or ``dt`` is not usable; clamp."""
        if not _dt_ok(dt):
            return
        vel_int = self.vel_int.tolist()
        chase = band < math.inf and math.hypot(vel_err[0], vel_err[1]) > band
        for i in (0, 1, 2):
            grow = self._vel_i[i] * vel_err[i] * dt
            if (sat[2] if i == 2 else chase or sat[0] and grow * acc_sp[i] > 0) or not math.isfinite(grow):
                grow = 0.0  # (NaN never reaches the integrator)
            lim = self._int_lim[i]
            vel_int[i] = _clamp(vel_int[i] + grow, lim)
        self.vel_int = np.array(vel_int)


def _dt_ok(dt: float) -> bool:
    """A step that may be integrated: 0 < dt <= MAX_DT_S (not NaN, not time going back, not a gap)."""
    return 0.0 < dt <= MAX_DT_S


def _finite(v: np.ndarray) -> bool:
    """All three components finite (cheaper than np.all(np.isfinite(v)) on a 3-vector)."""
    return math.isfinite(float(v[0]) + float(v[1]) + float(v[2]))


def _clamp(x: float, lim: float) -> float:
    """x limited to [-lim, lim] (NaN passes, as numpy's minimum/maximum let it)."""
    return -lim if x < -lim else (lim if x > lim else x)


def attitude_from_thrust(thrust_ned_n: np.ndarray, yaw_rad: float) -> np.ndarray:
    """Attitude (3x3, FRD->NED) whose -z axis points along the thrust (N, NED), with the given yaw (rad)."""
    tx, ty, tz = floats3(thrust_ned_n)
    n = math.sqrt(tx * tx + ty * ty + tz * tz)
    zx, zy, zz = (-tx / n, -ty / n, -tz / n) if n > 1e-6 else (0.0, 0.0, 1.0)
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    # y_b = z_b x (cos yaw, sin yaw, 0), normalised; x_b = y_b x z_b.
    yx, yy, yz = zy * 0.0 - zz * s, zz * c - zx * 0.0, zx * s - zy * c
    ny = math.sqrt(yx * yx + yy * yy + yz * yz)
    yx, yy, yz = (yx / ny, yy / ny, yz / ny) if ny > 1e-6 else (-s, c, 0.0)
    xx, xy, xz = yy * zz - yz * zy, yz * zx - yx * zz, yx * zy - yy * zx
    return np.array(((xx, yx, zx), (xy, yy, zy), (xz, yz, zz)))
