"""How much angular acceleration each axis has at hover: the excitation must stay inside it.

A PRBS that asks for more torque than the mixer can give is clipped (yaw first: it has the lowest
priority), and a clipped input is not the input the identification sees, so the excitation of each axis
is scaled to a fraction of that axis' authority (:func:`excitation_amplitudes`).  The quadcopter's yaw,
driven by rotor drag only, has about 0.5 rad/s^2 at hover against some 25 rad/s^2 in roll.

Pure: the mixer (built from the vehicle file), the inertia and the hover thrust in; rad/s^2 out.
"""

from __future__ import annotations

import numpy as np

from autopilot.control.mixer import Mixer

AUTHORITY_FRACTION = 0.5  # the excitation's proportional part asks at most this share of an axis' authority


def hover_authority(mixer: Mixer, inertia_kg_m2: np.ndarray, hover_thrust_n: float) -> tuple[float, float, float]:
    """Per FRD axis, the largest angular acceleration (rad/s^2) the mixer delivers unclipped at hover."""
    out = []
    for axis in range(3):
        lo, hi = 0.0, 1.0  # N m: bisection on the torque that still mixes without saturation
        while True:
            torque = np.zeros(3)
            torque[axis] = hi
            m = mixer.mix(torque, hover_thrust_n)
            if m.sat_pos[axis] or m.thrust_saturated or hi > 1e4:
                break
            lo, hi = hi, hi * 2
        for _ in range(30):
            mid = (lo + hi) / 2
            torque = np.zeros(3)
            torque[axis] = mid
            m = mixer.mix(torque, hover_thrust_n)
            lo, hi = (lo, mid) if (m.sat_pos[axis] or m.thrust_saturated) else (mid, hi)
        out.append(lo / float(np.asarray(inertia_kg_m2)[axis]))
    return out[0], out[1], out[2]


def excitation_amplitude(amp_rad_s: float, p_gain: float, authority_rad_s2: float) -> float:
    """The PRBS amplitude for one axis (rad/s): MC_AT_SYSID_AMP, or less if P x amplitude would exceed
    AUTHORITY_FRACTION of the axis' authority."""
    if p_gain <= 0:
        return amp_rad_s
    return min(amp_rad_s, AUTHORITY_FRACTION * authority_rad_s2 / p_gain)
