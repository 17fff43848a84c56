"""Position and velocity control (PX4's PositionControl structure, seed 000 2.10).

Position P -> velocity setpoint (limited) -> velocity PID -> acceleration
setpoint -> thrust vector.  Seed 000 section 3.4 clamps the integrators, the
derivative and the outputs; here those are the MPC_*_INT_LIM, MPC_ACC_*_MAX and
MPC_TILTMAX_AIR parameters.  The thrust vector is in newtons, NED, and carries
the hover feed-forward m g from the vehicle file.  Integration stops on an axis
whose output is saturated (thrust or tilt limit) in the direction that would
make it worse.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from autopilot.parameters import ParamDef, ParameterStore, param
from mavsim_core.quaternion import cross
from mavsim_core.constants import GRAVITY_M_S2


# The parameters this module reads (listed in autopilot/param_catalogue.py).
PARAMS: tuple[ParamDef, ...] = (
    param("MPC_XY_P", 0.95, 0.0, 2.0, "1/s", "Horizontal position proportional gain"),
    param("MPC_Z_P", 1.0, 0.0, 2.0, "1/s", "Vertical position proportional gain"),
    param("MPC_XY_VEL_P_ACC", 2.2, 0.0, 10.0, "1/s", "Horizontal velocity proportional gain (acceleration per velocity error)"),
    param("MPC_XY_VEL_I_ACC", 0.8, 0.0, 10.0, "1/s^2", "Horizontal velocity integral gain"),
    param("MPC_XY_VEL_D_ACC", 0.2, 0.0, 2.0, "-", "Horizontal velocity derivative gain"),
    param("MPC_Z_VEL_P_ACC", 4.0, 0.0, 15.0, "1/s", "Vertical velocity proportional gain"),
    param("MPC_Z_VEL_I_ACC", 2.0, 0.0, 10.0, "1/s^2", "Vertical velocity integral gain"),
    param("MPC_Z_VEL_D_ACC", 0.0, 0.0, 2.0, "-", "Vertical velocity derivative gain"),
    param("MPC_XY_VEL_MAX", 5.0, 0.0, 20.0, "m/s", "Maximum horizontal velocity"),
    param("MPC_Z_VEL_MAX_UP", 3.0, 0.5, 8.0, "m/s", "Maximum ascent velocity"),
    param("MPC_Z_VEL_MAX_DN", 1.5, 0.5, 4.0, "m/s", "Maximum descent velocity"),
    param("MPC_TILTMAX_AIR", 35.0, 20.0, 89.0, "deg", "Maximum tilt in air"),
    param("MPC_THR_MIN", 0.12, 0.05, 0.5, "norm", "Minimum collective thrust in flight (fraction of maximum)"),
    param("MPC_THR_MAX", 1.0, 0.5, 1.0, "norm", "Maximum collective thrust (fraction of maximum)"),
    param("MPC_XY_INT_LIM", 3.0, 0.0, 10.0, "m/s^2", "Horizontal velocity integrator clamp (seed 000 3.4)"),
    param("MPC_Z_INT_LIM", 4.0, 0.0, 10.0, "m/s^2", "Vertical velocity integrator clamp (seed 000 3.4)"),
    param("MPC_JERK_AUTO", 4.0, 1.0, 80.0, "m/s^3",
            "Jerk limit of automatic moves: how fast their acceleration feed-forward may change"),
    param("MPC_ACC_D_LIM", 10.0, 0.0, 100.0, "m/s^2", "Clamp of the velocity derivative term (seed 000 3.4)"),
    param("MPC_VELD_LP", 5.0, 0.0, 10.0, "Hz",
            "Low-pass cut-off of the velocity derivative (0 = unfiltered): GPS corrections step the velocity estimate"),
)


@dataclass(frozen=True, slots=True)
class PositionSetpoint:
    """Position (m, NED; NaN = not controlled), velocity feed-forward (m/s), yaw (rad) and
    acceleration feed-forward (m/s^2, NED; a trajectory's own acceleration)."""

    pos_ned_m: np.ndarray
    vel_ned_m_s: np.ndarray
    yaw_rad: float
    acc_ned_m_s2: np.ndarray | None = None


class PositionControl:
    def __init__(self, params: ParameterStore, mass_kg: float, max_total_thrust_n: float) -> None:
        self.params = params
        self.mass_kg = mass_kg
        self.max_total_thrust_n = max_total_thrust_n
        self.vel_int = np.zeros(3)  # m/s^2
        self.prev_vel = None
        self.d_filt = np.zeros(3)  # low-passed velocity derivative, m/s^2
        self.vel_sp = np.zeros(3)
        self.acc_sp = np.zeros(3)
        self.acc_ff = np.zeros(3)  # the trajectory's acceleration as fed forward, jerk-limited, m/s^2
        self._load()
        params.subscribe(lambda name, value: self._load() if name.startswith("MPC_") else None)

    def _load(self) -> None:
        g = self.params.get
        self.xy_p, self.z_p = g("MPC_XY_P"), g("MPC_Z_P")
        self.vel_p = np.array([g("MPC_XY_VEL_P_ACC")] * 2 + [g("MPC_Z_VEL_P_ACC")])
        self.vel_i = np.array([g("MPC_XY_VEL_I_ACC")] * 2 + [g("MPC_Z_VEL_I_ACC")])
        self.vel_d = np.array([g("MPC_XY_VEL_D_ACC")] * 2 + [g("MPC_Z_VEL_D_ACC")])
        self.xy_vel_max = g("MPC_XY_VEL_MAX")
        self.z_vel_up, self.z_vel_dn = g("MPC_Z_VEL_MAX_UP"), g("MPC_Z_VEL_MAX_DN")
        self.tilt_max = math.radians(g("MPC_TILTMAX_AIR"))
        self.thr_min = g("MPC_THR_MIN") * self.max_total_thrust_n
        self.thr_max = g("MPC_THR_MAX") * self.max_total_thrust_n
        self.int_lim = np.array([g("MPC_XY_INT_LIM")] * 2 + [g("MPC_Z_INT_LIM")])
        self.d_lim = g("MPC_ACC_D_LIM")
        self.d_lp_hz = g("MPC_VELD_LP")
        self.jerk_max = g("MPC_JERK_AUTO")

    def reset(self) -> None:
        self.vel_int[:] = 0.0
        self.prev_vel = None
        self.d_filt[:] = 0.0
        self.acc_ff[:] = 0.0

    def update(self, pos: np.ndarray, vel: np.ndarray, sp: PositionSetpoint, dt: float) -> np.ndarray:
        """Return the thrust vector (N, NED) for this step."""
        # Position P with velocity feed-forward, then velocity limits.
        err = sp.pos_ned_m - pos
        vel_sp = sp.vel_ned_m_s.copy()
        ctrl = np.isfinite(err)
        gains = np.array([self.xy_p, self.xy_p, self.z_p])
        vel_sp[ctrl] += gains[ctrl] * err[ctrl]
        vel_sp = np.where(np.isfinite(vel_sp), vel_sp, 0.0)
        h = math.hypot(vel_sp[0], vel_sp[1])
        if h > self.xy_vel_max:
            vel_sp[:2] *= self.xy_vel_max / h
        vel_sp[2] = min(max(vel_sp[2], -self.z_vel_up), self.z_vel_dn)
        self.vel_sp = vel_sp

        # Velocity PID (derivative on the measurement, clamped).
        vel_err = vel_sp - vel
        d_raw = np.zeros(3) if self.prev_vel is None or dt <= 0 else -(vel - self.prev_vel) / dt
        self.prev_vel = vel.copy()
        if self.d_lp_hz > 0 and dt > 0:
            self.d_filt += dt / (dt + 1.0 / (2.0 * math.pi * self.d_lp_hz)) * (d_raw - self.d_filt)
        else:
            self.d_filt[:] = d_raw
        d_term = np.minimum(np.maximum(self.d_filt, -self.d_lim), self.d_lim)
        acc_sp = self.vel_p * vel_err + self.vel_int + self.vel_d * d_term
        # The trajectory's acceleration, fed forward at most MPC_JERK_AUTO faster per second: the
        # moves' speed profile is trapezoidal, and a step in it would be a step of the attitude
        # setpoint that saturates the motors.
        want = sp.acc_ned_m_s2 if sp.acc_ned_m_s2 is not None else np.zeros(3)
        step = self.jerk_max * dt
        self.acc_ff += np.clip(np.where(np.isfinite(want), want, 0.0) - self.acc_ff, -step, step)
        acc_sp = acc_sp + self.acc_ff

        # Thrust vector with hover feed-forward: T = m (a - g), NED.
        thrust = self.mass_kg * (acc_sp - np.array([0.0, 0.0, GRAVITY_M_S2]))
        sat = np.zeros(3, dtype=bool)
        # Vertical thrust limits (up is -z).
        up = -thrust[2]
        if up > self.thr_max:
            thrust[2], sat[2] = -self.thr_max, vel_err[2] < 0
        elif up < self.thr_min:
            thrust[2], sat[2] = -self.thr_min, vel_err[2] > 0
        # Tilt limit: keep the vertical component, shorten the horizontal one.
        h_max = -thrust[2] * math.tan(self.tilt_max)
        h_max = min(h_max, math.sqrt(max(self.thr_max**2 - thrust[2] ** 2, 0.0)))
        h = math.hypot(thrust[0], thrust[1])
        if h > h_max:
            thrust[:2] *= h_max / h
            sat[:2] = True

        # Integrate unless that would push further into saturation (anti-windup).
        grow = self.vel_i * vel_err * dt
        if sat[2]:
            grow[2] = 0.0
        if sat[0]:
            grow[:2] = np.where(grow[:2] * acc_sp[:2] > 0, 0.0, grow[:2])
        self.vel_int += grow
        self.vel_int = np.minimum(np.maximum(self.vel_int, -self.int_lim), self.int_lim)
        self.acc_sp = acc_sp
        return thrust


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
