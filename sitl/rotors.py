"""Rotor model of [F]: T_i = k_T w_i^2 (4.8), M_i = +-k_M T_i (4.9), motor lag.

Motor commands u_i in 0..1 map linearly to the commanded rotor speed
w_cmd = u_i * w_max (rad/s); the rotor speed follows with a first-order lag whose
time constant differs when speeding up and slowing down (RotorS' motor model).
A motor at efficiency e (0..1, a failure) only reaches sqrt(e) of the commanded
speed, so it gives e times the thrust, and its drag and power follow from that speed.
"""

from __future__ import annotations

import math

import numpy as np

from params.vehicle import VehicleSpec


class RotorModel:
    """Rotor speeds (rad/s) and thrusts (N) of all rotors of one vehicle.

    The lag runs on Python floats (a handful of rotors; numpy's per-call cost would
    dominate), exactly integrated: w += (1 - exp(-dt/tau)) (w_cmd - w).
    """

    def __init__(self, spec: VehicleSpec) -> None:
        self.n = len(spec.rotors)
        self.k_thrust = spec.k_thrust
        self.k_moment = spec.k_moment
        self.max_speed_rad_s = spec.max_speed_rad_s
        self.tau_up_s = spec.time_constant_up_s
        self.tau_down_s = spec.time_constant_down_s
        self.speeds: list[float] = [0.0] * self.n
        self.efficiency: list[float] = [1.0] * self.n  # thrust scale per rotor (1 = healthy, 0 = stopped)
        self._alpha_dt: float | None = None

    @property
    def speed_rad_s(self) -> np.ndarray:
        return np.array(self.speeds)

    def commanded_speed(self, commands) -> list[float]:
        """Motor command 0..1 (clipped) -> commanded rotor speed, rad/s."""
        w = self.max_speed_rad_s
        return [
            (0.0 if c < 0.0 else w if c > 1.0 else c * w) * (e if e == 1.0 else math.sqrt(max(e, 0.0)))
            for c, e in zip(commands, self.efficiency)
        ]

    def step(self, commands, dt_s: float) -> list[float]:
        """Advance the motor lag by dt_s toward the commands; return thrusts (N)."""
        if self._alpha_dt != dt_s:
            self._alpha_up = 1.0 - math.exp(-dt_s / self.tau_up_s)
            self._alpha_down = 1.0 - math.exp(-dt_s / self.tau_down_s)
            self._alpha_dt = dt_s
        up, down = self._alpha_up, self._alpha_down
        w_max, k = self.max_speed_rad_s, self.k_thrust
        speeds: list[float] = []
        thrusts: list[float] = []
        for w, c, e in zip(self.speeds, commands, self.efficiency):  # one loop: commanded_speed, lag, T = k w^2
            c = 0.0 if c < 0.0 else w_max if c > 1.0 else c * w_max
            if e != 1.0:  # (x 1.0 is exact: skipping it changes no bit)
                c *= math.sqrt(max(e, 0.0))
            w += (up if c > w else down) * (c - w)
            speeds.append(w)
            thrusts.append(k * w * w)
        self.speeds = speeds
        return thrusts

    def thrust_n(self) -> np.ndarray:
        """T_i = k_T w_i^2 ([F eq. 4.8]."""
        k = self.k_thrust
        return np.array([k * w * w for w in self.speeds])

    def drag_torque_nm(self) -> np.ndarray:
        """|M_i| = k_M T_i ([F eq. 4.9]; the sign comes from the spin direction."""
        return self.k_moment * self.thrust_n()

    def shaft_power_w(self) -> float:
        """Mechanical power the rotors absorb: sum of M_i w_i (W)."""
        kk = self.k_moment * self.k_thrust
        return sum([kk * w * w * w for w in self.speeds])  # a list: cheaper than a generator, the same sum
