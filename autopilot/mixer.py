"""Mixer: body torque and collective thrust -> motor commands, built from geometry.

The effectiveness matrix B (rows: roll, pitch, yaw torque in N m, FRD, and
collective thrust in N) comes from the vehicle file's rotor positions and spin
directions (:meth:`params.vehicle.VehicleSpec.effectiveness_matrix`); for the
quadcopter X it is seed 000's mixing table, for the hexacopter seed 001's
eq (4.10).  Rotor thrusts are its pseudo-inverse applied to the wanted wrench.

Saturation (ArduPilot/PX4 style priorities): roll and pitch first, then
collective thrust, then yaw.  If roll and pitch alone do not fit between zero
and full thrust they are scaled down; the collective is then shifted to fit;
yaw gets what is left.  Which axes were cut, and in which direction, is
reported so integrators stop winding up.  Motor command = sqrt(T / T_max)
because the simulator (like PX4's) maps the 0..1 command linearly to rotor speed
and thrust goes as speed squared (seed 001 eq 4.8).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from params.vehicle import VehicleSpec


@dataclass(frozen=True, slots=True)
class MixerOutput:
    commands: np.ndarray  # 0..1 per motor
    thrusts_n: np.ndarray  # per rotor
    sat_pos: np.ndarray  # per axis (roll, pitch, yaw): more positive torque was not delivered
    sat_neg: np.ndarray
    thrust_saturated: bool


class Mixer:
    def __init__(self, spec: VehicleSpec) -> None:
        self.b = spec.effectiveness_matrix()
        self.b_pinv = np.linalg.pinv(self.b)
        self.t_max = spec.max_thrust_per_rotor_n
        self.n = self.b.shape[1]
        self.idle_command = 0.0

    def mix(self, torque_frd_nm: np.ndarray, thrust_n: float, min_thrust_n: float = 0.0) -> MixerOutput:
        """Rotor commands for a body torque (N m, FRD) and collective thrust (N)."""
        lo = max(0.0, min_thrust_n / self.n)
        hi = self.t_max
        m_rp = self.b_pinv[:, 0:2] @ torque_frd_nm[0:2]
        m_y = self.b_pinv[:, 2] * torque_frd_nm[2]
        m_t = self.b_pinv[:, 3] * thrust_n
        sat_pos = np.zeros(3, dtype=bool)
        sat_neg = np.zeros(3, dtype=bool)
        thrust_sat = False

        # 1. Roll/pitch must fit inside the range on their own.
        span = m_rp.max() - m_rp.min()
        if span > hi - lo:
            m_rp *= (hi - lo) / span
            sat_pos[:2] = torque_frd_nm[:2] > 0
            sat_neg[:2] = torque_frd_nm[:2] < 0
        u = m_t + m_rp
        # 2. Shift the collective to fit (changes thrust, keeps attitude authority).
        if u.min() < lo:
            u += lo - u.min()
            thrust_sat = True
        if u.max() > hi:
            u -= u.max() - hi
            thrust_sat = True
        # 3. Yaw gets what is left.
        scale = 1.0
        for ui, yi in zip(u, m_y):
            if yi > 1e-12:
                scale = min(scale, (hi - ui) / yi)
            elif yi < -1e-12:
                scale = min(scale, (lo - ui) / yi)
        scale = max(0.0, scale)
        if scale < 1.0:
            sat_pos[2] = torque_frd_nm[2] > 0
            sat_neg[2] = torque_frd_nm[2] < 0
        u = np.clip(u + scale * m_y, 0.0, hi)
        return MixerOutput(np.sqrt(u / self.t_max), u, sat_pos, sat_neg, thrust_sat)

    def wrench(self, thrusts_n: np.ndarray) -> np.ndarray:
        """(roll, pitch, yaw torque, collective thrust) produced by rotor thrusts."""
        return self.b @ thrusts_n
