"""Aerodynamic forces of [F 4.3]: rotor drag, rolling moment, body drag.

Frame: everything here is in MuJoCo's body frame FLU (x forward, y left, z up),
metres, newtons, N m; the rotor disc plane is the body x-y plane, r_3 = (0, 0, 1).

- Relative wind V_a = V_wind - V_n (4.11) is given in the body frame; its
  projection on the rotor disc is V_a_perp = V_a - (V_a . r_3) r_3 = (V_ax, V_ay, 0).
- Rotor i: drag F_d,i = w_i k_d V_a_perp (4.12) applied at the rotor (so it also
  gives the moment r_i x F_d,i about the centre of mass) and rolling moment
  M_r,i = w_i k_r V_a_perp (4.13); summed over rotors (4.14)-(4.15).
- Body (not in [F]): F_b = 1/2 rho (Cd A)_j |V_a| V_a,j per body axis j.

Plain floats: :meth:`Aerodynamics.wrench_flu` runs every 4 ms of simulated time.
"""

from __future__ import annotations

import math

from mavsim_core.frames import frd_to_flu
from params.vehicle import VehicleSpec

AIR_DENSITY_KG_M3 = 1.225  # ISA sea level


class Aerodynamics:
    def __init__(self, spec: VehicleSpec) -> None:
        self.k_d = spec.rotor_drag_k_d
        self.k_r = spec.rolling_moment_k_r
        self.positions_flu = [tuple(float(c) for c in frd_to_flu(r.position_frd_m)) for r in spec.rotors]
        cx, cy, cz = spec.body_drag_cd_area_m2  # FRD axes; the same magnitudes along FLU axes
        self.half_rho_cda = (0.5 * AIR_DENSITY_KG_M3 * cx, 0.5 * AIR_DENSITY_KG_M3 * cy, 0.5 * AIR_DENSITY_KG_M3 * cz)

    def wrench_flu(self, rotor_speeds_rad_s, v_air_flu_m_s) -> tuple[float, float, float, float, float, float]:
        """Force (N) and moment (N m) about the centre of mass, body FLU, for relative wind ``v_air_flu_m_s``.

        ``v_air_flu_m_s`` is V_a = V_wind - V_n expressed in the body frame.
        """
        ax, ay, az = v_air_flu_m_s
        # Rotor drag (4.12) and rolling moment (4.13): every rotor sees the same V_a_perp = (ax, ay, 0).
        fx = fy = 0.0
        mx = my = mz = 0.0
        kd = self.k_d
        for w, (px, py, pz) in zip(rotor_speeds_rad_s, self.positions_flu):
            dfx, dfy = w * kd * ax, w * kd * ay
            fx += dfx
            fy += dfy
            # r_i x F_d,i with F_d,i = (dfx, dfy, 0)
            mx -= pz * dfy
            my += pz * dfx
            mz += px * dfy - py * dfx
        w_sum = sum(rotor_speeds_rad_s)
        mx += w_sum * self.k_r * ax
        my += w_sum * self.k_r * ay
        # Body drag.
        speed = math.sqrt(ax * ax + ay * ay + az * az)
        hx, hy, hz = self.half_rho_cda
        fx += hx * speed * ax
        fy += hy * speed * ay
        fz = hz * speed * az
        return fx, fy, fz, mx, my, mz
