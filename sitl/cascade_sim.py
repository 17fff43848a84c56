"""Predicted step response of the linear cascade of one axis: a discrete-time simulation (numpy/scipy).

One horizontal axis, small angles, as the flight controller runs it: every 4 ms (250 Hz) the
gyro goes through the 2nd-order Butterworth (IMU_GYRO_CUTOFF), the attitude P makes a rate
setpoint (limited to the maximum rate), the rate PID (derivative on the measurement through its
own low-pass, forward-Euler integrator) an angular acceleration held for the period; every 20 ms
(50 Hz) the position P makes a velocity setpoint limited to the maximum speed and the velocity
PI an acceleration setpoint limited by the tilt limit (a = g tan(tilt)), flown as a tilt
setpoint from the next 4 ms step.  The plant (position, velocity, tilt, rate, delivered angular
acceleration through the motor lag) is discretised exactly with a zero-order hold
(``scipy.signal.cont2discrete``).  The vertical axis is the same without the attitude loops:
the acceleration setpoint goes through the motors' lag.  Units: m, m/s, rad, s.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from mavsim_core.butterworth import lowpass2
from mavsim_core.constants import GRAVITY_M_S2
from mavsim_core.loop_design import LoopFilters, PidGains, RatePlant

SETTLE_BAND_M = 0.1


@dataclass(frozen=True, slots=True)
class StepResult:
    """A position step: rise time 10-90 % (s), overshoot (% of the step), settling time to within the band."""

    step_m: float
    rise_s: float
    overshoot_pct: float
    settle_s: float  # NaN if it never settles within the simulated time


@dataclass(frozen=True, slots=True)
class OuterGains:
    """Position P (1/s) and velocity PI (1/s, 1/s^2) with their limits."""

    pos_p: float
    vel_p: float
    vel_i: float
    vel_max_m_s: float
    acc_max_m_s2: float


def step_metrics(t: np.ndarray, pos: np.ndarray, step_m: float, band_m: float = SETTLE_BAND_M) -> StepResult:
    """Rise 10-90 %, overshoot and settling time of a position trace answering a step of ``step_m``."""
    frac = pos / step_m
    t10 = t[np.argmax(frac >= 0.1)] if np.any(frac >= 0.1) else math.nan
    t90 = t[np.argmax(frac >= 0.9)] if np.any(frac >= 0.9) else math.nan
    over = max(float(frac.max()) - 1.0, 0.0) * 100.0
    outside = np.nonzero(np.abs(pos - step_m) > band_m)[0]
    if outside.size == 0:
        settle = 0.0
    elif outside[-1] == len(t) - 1:
        settle = math.nan
    else:
        settle = float(t[outside[-1] + 1])
    return StepResult(step_m, float(t90 - t10), over, settle)


def _discrete(a: np.ndarray, b: np.ndarray, dt: float) -> tuple[np.ndarray, np.ndarray]:
    from scipy.signal import cont2discrete  # here: scipy.signal costs ~0.8 s of imports, and few callers need it

    ad, bd, _, _, _ = cont2discrete((a, b, np.eye(a.shape[0]), np.zeros((a.shape[0], 1))), dt, "zoh")
    return ad, bd[:, 0]


def simulate_xy_step(
    plant: RatePlant,
    rate: PidGains,
    att_p: float,
    outer: OuterGains,
    rate_max_rad_s: float,
    step_m: float = 10.0,
    duration_s: float = 20.0,
    filters: LoopFilters = LoopFilters(),
) -> tuple[np.ndarray, np.ndarray]:
    """(time s, position m) of a horizontal position step from rest (see the module docstring)."""
    dt = 1.0 / filters.sample_hz
    tau = max(plant.motor_tau_s, 1e-6)
    g = GRAVITY_M_S2
    # x = (position, velocity, tilt, rate, delivered angular acceleration); input: alpha_sp.
    a = np.zeros((5, 5))
    a[0, 1], a[1, 2], a[2, 3], a[3, 4], a[4, 4] = 1.0, g, 1.0, 1.0, -1.0 / tau
    b = np.zeros((5, 1))
    b[4, 0] = plant.effectiveness / tau
    ad, bd = _discrete(a, b, dt)
    fb, fa = lowpass2(filters.gyro_cutoff_hz, filters.sample_hz)
    a_d = dt / (dt + 1.0 / (2 * math.pi * filters.d_cutoff_hz))
    delay = [0.0] * max(round(plant.delay_s / dt), 0)
    every = round(filters.sample_hz / 50.0)
    x = np.zeros(5)
    fz = [0.0, 0.0]  # gyro filter (direct form II transposed)
    integ = d_filt = prev = vel_int = tilt_sp = 0.0
    n = round(duration_s / dt)
    t_out, p_out = np.arange(n) * dt, np.empty(n)
    for k in range(n):
        p_out[k] = x[0]
        if k % every == 0:  # the 50 Hz loops; their tilt setpoint applies from the next step
            vel_sp = min(max(outer.pos_p * (step_m - x[0]), -outer.vel_max_m_s), outer.vel_max_m_s)
            err = vel_sp - x[1]
            acc = outer.vel_p * err + vel_int
            sat = abs(acc) > outer.acc_max_m_s2
            acc = min(max(acc, -outer.acc_max_m_s2), outer.acc_max_m_s2)
            if not (sat and err * acc > 0):
                vel_int += outer.vel_i * err * 0.02
            next_tilt_sp = math.atan(acc / g)
        y = fb[0] * x[3] + fz[0]  # filtered gyro
        fz[0] = fb[1] * x[3] - fa[1] * y + fz[1]
        fz[1] = fb[2] * x[3] - fa[2] * y
        rate_sp = min(max(att_p * (tilt_sp - x[2]), -rate_max_rad_s), rate_max_rad_s)
        if k > 0:
            d_filt += a_d * (-(y - prev) / dt - d_filt)
        prev = y
        e = rate_sp - y
        u = rate.p * e + integ + rate.d * d_filt
        integ += rate.i * e * dt
        if delay:
            delay.append(u)
            u = delay.pop(0)
        x = ad @ x + bd * u
        if k % every == 0:
            tilt_sp = next_tilt_sp
    return t_out, p_out


def simulate_z_step(
    motor_tau_s: float, outer: OuterGains, step_m: float = 10.0, duration_s: float = 20.0, sample_hz: float = 250.0
) -> tuple[np.ndarray, np.ndarray]:
    """(time s, height m) of a vertical step up: velocity PI -> collective thrust -> motor lag -> height."""
    dt = 1.0 / sample_hz
    tau = max(motor_tau_s, 1e-6)
    a = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, 1.0], [0.0, 0.0, -1.0 / tau]])  # height, climb rate, acceleration
    ad, bd = _discrete(a, np.array([[0.0], [0.0], [1.0 / tau]]), dt)
    every = round(sample_hz / 50.0)
    x = np.zeros(3)
    vel_int = acc_sp = 0.0
    n = round(duration_s / dt)
    t_out, p_out = np.arange(n) * dt, np.empty(n)
    for k in range(n):
        p_out[k] = x[0]
        if k % every == 0:
            vel_sp = min(max(outer.pos_p * (step_m - x[0]), -outer.vel_max_m_s), outer.vel_max_m_s)
            err = vel_sp - x[1]
            acc = outer.vel_p * err + vel_int
            sat = abs(acc) > outer.acc_max_m_s2
            if not (sat and err * acc > 0):
                vel_int += outer.vel_i * err * 0.02
            next_acc = min(max(acc, -outer.acc_max_m_s2), outer.acc_max_m_s2)
        x = ad @ x + bd * acc_sp
        if k % every == 0:
            acc_sp = next_acc
    return t_out, p_out
