"""Mixer: body torque and collective thrust -> motor commands, built from geometry.

The effectiveness matrix B (rows: roll, pitch, yaw torque in N m, FRD, and
collective thrust in N) comes from the vehicle file's rotor positions and spin
directions (:meth:`params.vehicle.VehicleSpec.effectiveness_matrix`); for the
quadcopter X it is [Q]'s mixing table, for the hexacopter [F]'s
eq (4.10).  Rotor thrusts are its pseudo-inverse applied to the wanted wrench.

Saturation (ArduPilot/PX4 style priorities): roll and pitch first, then
collective thrust, then yaw.  If roll and pitch alone do not fit between zero
and full thrust they are scaled down; the collective is then shifted to fit;
yaw gets what is left.  Which axes were cut, and in which direction, is
reported so integrators stop winding up.  Motor command = sqrt(T / T_max)
because the simulator (like PX4's) maps the 0..1 command linearly to rotor speed
and thrust goes as speed squared ([F eq. 4.8].
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Protocol

import numpy as np


class RotorGeometry(Protocol):
    """What the mixer needs of a vehicle (:class:`params.vehicle.VehicleSpec` has it)."""

    @property
    def max_thrust_per_rotor_n(self) -> float: ...

    def effectiveness_matrix(self) -> np.ndarray:
        """4 x n: roll, pitch, yaw torque (N m, FRD) and collective thrust (N) per unit rotor thrust (N)."""
        ...


@dataclass(frozen=True, slots=True)
class MixerOutput:
    commands: np.ndarray  # 0..1 per motor
    thrusts_n: np.ndarray  # per rotor
    sat_pos: np.ndarray  # per axis (roll, pitch, yaw): more positive torque was not delivered
    sat_neg: np.ndarray
    thrust_saturated: bool


class Mixer:
    """Allocation from the vehicle's geometry.  The per-step arithmetic runs on Python
    floats (:meth:`mix_floats`): with 4-8 rotors that is several times faster than numpy's
    per-call cost, and this runs at the IMU rate."""

    def __init__(self, spec: RotorGeometry) -> None:
        self.b = spec.effectiveness_matrix()
        self.b_pinv = np.linalg.pinv(self.b)
        self.t_max = spec.max_thrust_per_rotor_n
        self.n = self.b.shape[1]
        # Columns of the pseudo-inverse: rotor thrust per unit roll, pitch, yaw torque and thrust.
        self._roll, self._pitch, self._yaw, self._thrust = (self.b_pinv[:, k].tolist() for k in range(4))
        self._roll_pitch = tuple(zip(self._roll, self._pitch))  # per rotor: (roll, pitch) column entries
        self._yaw_thrust = tuple(zip(self._yaw, self._thrust))  # per rotor: (yaw, thrust) column entries

    def mix(self, torque_frd_nm: np.ndarray, thrust_n: float, min_thrust_n: float = 0.0) -> MixerOutput:
        """Rotor commands for a body torque (N m, FRD) and collective thrust (N)."""
        tr, tp, ty = float(torque_frd_nm[0]), float(torque_frd_nm[1]), float(torque_frd_nm[2])
        commands, thrusts, sat_pos, sat_neg, thrust_sat = self.mix_floats(tr, tp, ty, thrust_n, min_thrust_n)
        return MixerOutput(np.array(commands), np.array(thrusts), np.array(sat_pos), np.array(sat_neg), thrust_sat)

    def mix_floats(
        self, tr: float, tp: float, ty: float, thrust_n: float, min_thrust_n: float = 0.0
    ) -> tuple[list[float], list[float], tuple[bool, bool, bool], tuple[bool, bool, bool], bool]:
        """:meth:`mix` on Python floats: roll, pitch, yaw torque (N m, FRD) and collective thrust (N) in;
        (commands 0..1, rotor thrusts N, sat_pos, sat_neg per axis, thrust saturated) out."""
        lo = min_thrust_n / self.n if min_thrust_n > 0.0 else 0.0
        hi = self.t_max
        rp = [r * tr + p * tp for r, p in self._roll_pitch]
        sat_rp = False
        # 1. Roll/pitch must fit inside the range on their own.
        span = max(rp) - min(rp)
        if span > hi - lo:
            k = (hi - lo) / span
            rp = [x * k for x in rp]
            sat_rp = True
        u = [t * thrust_n + x for (_, t), x in zip(self._yaw_thrust, rp)]
        # 2. Shift the collective to fit (changes thrust, keeps attitude authority).
        thrust_sat = False
        u_min = min(u)
        if u_min < lo:
            thrust_sat, shift = True, lo - u_min
        else:
            u_max = max(u)
            thrust_sat, shift = u_max > hi, hi - u_max
        if thrust_sat:
            u = [x + shift for x in u]
        # 3. Yaw gets what is left.
        scale = 1.0
        if ty != 0.0:  # (no yaw torque: nothing to scale)
            for ui, (yc, _) in zip(u, self._yaw_thrust):
                yi = yc * ty
                if yi > 1e-12:
                    room = (hi - ui) / yi
                    scale = room if room < scale else scale
                elif yi < -1e-12:
                    room = (lo - ui) / yi
                    scale = room if room < scale else scale
            scale = max(0.0, scale)
        sat_y = scale < 1.0
        inv_max = 1.0 / hi
        sqrt = math.sqrt
        thrusts = []
        for ui, (yc, _) in zip(u, self._yaw_thrust):
            t = ui + scale * yc * ty
            t = 0.0 if t < 0.0 else t  # (NaN passes, as min/max let it)
            thrusts.append(hi if t > hi else t)
        commands = [sqrt(t * inv_max) for t in thrusts]
        sat_pos = (sat_rp and tr > 0, sat_rp and tp > 0, sat_y and ty > 0)
        sat_neg = (sat_rp and tr < 0, sat_rp and tp < 0, sat_y and ty < 0)
        return commands, thrusts, sat_pos, sat_neg, thrust_sat

    def wrench(self, thrusts_n: np.ndarray) -> np.ndarray:
        """(roll, pitch, yaw torque, collective thrust) produced by rotor thrusts."""
        wrench: np.ndarray = self.b @ thrusts_n
        return wrench
