"""The outer loops of the multirotor cascade, each designed on the closed loop inside it (pure numpy/scipy).

The cascade (PX4's, :mod:`autopilot.control`): rate PID (250 Hz, :mod:`mavsim_core.loop_design`)
<- attitude P (250 Hz) <- velocity PID (50 Hz) <- position P (50 Hz).  Per axis, small angles:

- attitude: angle = integral of the rate; plant = (closed rate loop) / s;
- horizontal velocity: the acceleration setpoint becomes a tilt setpoint (a = g tan(tilt), so
  unity at small angles), held for one 50 Hz period and applied from the next 250 Hz step;
  plant = (closed attitude loop) * hold / s;
- vertical velocity: the acceleration setpoint is a collective thrust through the motors' lag;
  plant = 1 / ((tau s + 1) s) * hold;
- position: plant = (closed velocity loop) / s.

Design, every outer loop: **pole placement** with one free number.  The outer controller is P
(attitude, position) or PI with the integrator's zero at K / 8 (velocity: Ki = K^2 / 8, the
PI's slow pole then nearly cancels on its zero; no D: the velocity estimate's noise would be
fed straight to the attitude).  On the reduced model (inner loop = its bandwidth w_i as a first
order lag) the dominant closed-loop pole is near K; K is set on the *full* frequency response
(the inner closed loop exactly, holds and delays included) so that the loop's closed-loop
-3 dB bandwidth is the inner loop's divided by ``ratio`` (at least 4: the cascade's
separation).  Each loop's margins are those of its full open loop.

Frequencies in Hz at the API; gains in the controllers' units (1/s, 1/s^2).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from mavsim_core.loop_design import Margins, bandwidth_hz, margins_of

VEL_I_RATIO = 1.0 / 8.0  # Ki = VEL_I_RATIO * Kp^2 (the PI's zero at Kp / 8)
OUTER_HZ = 50.0  # velocity and position loops
INNER_HZ = 250.0  # rate and attitude loops


@dataclass(frozen=True, slots=True)
class OuterLoop:
    """One designed outer loop: its gains, its closed-loop response and its margins."""

    name: str
    p: float  # proportional gain (1/s)
    i: float  # integral gain (1/s^2; 0 for a P loop)
    margins: Margins
    bandwidth_hz: float  # -3 dB of the closed loop
    inner_bandwidth_hz: float  # -3 dB of the loop inside it
    closed: np.ndarray  # closed-loop response on the design grid (setpoint -> output)


def outer_grid_hz(n: int = 1200) -> np.ndarray:
    """Design frequencies (Hz): below the 50 Hz loops' Nyquist frequency."""
    return np.logspace(math.log10(0.002), math.log10(0.49 * OUTER_HZ), n)


def integrator(f_hz: np.ndarray) -> np.ndarray:
    return 1.0 / (1j * 2 * math.pi * f_hz)


def hold(f_hz: np.ndarray, rate_hz: float = OUTER_HZ, extra_delay_s: float = 1.0 / INNER_HZ) -> np.ndarray:
    """A setpoint held for one period of ``rate_hz`` (zero-order hold) and applied ``extra_delay_s`` later."""
    jw = 1j * 2 * math.pi * f_hz
    t = 1.0 / rate_hz
    return (1.0 - np.exp(-jw * t)) / (jw * t) * np.exp(-jw * extra_delay_s)


def pi_response(p: float, i: float, f_hz: np.ndarray, rate_hz: float) -> np.ndarray:
    """The discrete PI as coded (forward-Euler integrator, added after the output) at ``rate_hz``."""
    zi = np.exp(-1j * 2 * math.pi * f_hz / rate_hz)
    return p + i * (zi / rate_hz) / (1.0 - zi)


def design_outer(
    name: str,
    plant: np.ndarray,
    inner_closed: np.ndarray,
    f_hz: np.ndarray,
    ratio: float,
    controller: Callable[[float, np.ndarray], tuple[float, float, np.ndarray]],
) -> OuterLoop:
    """K such that the loop's closed-loop bandwidth is the inner loop's / ``ratio`` (bisection on K).

    ``plant``: the outer loop's plant on ``f_hz`` (the inner closed loop included); ``controller(K, f)``
    gives (P, I, response)."""
    inner_bw = bandwidth_hz(inner_closed, f_hz)
    target = inner_bw / ratio

    def closed(k: float) -> tuple[np.ndarray, np.ndarray]:
        loop = controller(k, f_hz)[2] * plant
        return loop, loop / (1.0 + loop)

    lo, hi = 1e-4, 1e4
    for _ in range(80):
        mid = math.sqrt(lo * hi)
        bw = bandwidth_hz(closed(mid)[1], f_hz)
        lo, hi = (mid, hi) if not bw > target else (lo, mid)
    p, i, _ = controller(lo, f_hz)
    loop, cl = closed(lo)
    return OuterLoop(name, p, i, margins_of(loop, f_hz), bandwidth_hz(cl, f_hz), inner_bw, cl)


def p_controller(k: float, f_hz: np.ndarray) -> tuple[float, float, np.ndarray]:
    return k, 0.0, np.full(f_hz.shape, k, dtype=complex)


def pi_controller(k: float, f_hz: np.ndarray) -> tuple[float, float, np.ndarray]:
    i = VEL_I_RATIO * k * k
    return k, i, pi_response(k, i, f_hz, OUTER_HZ)


def design_attitude(rate_closed: np.ndarray, f_hz: np.ndarray, ratio: float, name: str) -> OuterLoop:
    """Attitude P on (closed rate loop) / s."""
    return design_outer(name, rate_closed * integrator(f_hz), rate_closed, f_hz, ratio, p_controller)


def design_velocity_xy(att_closed: np.ndarray, f_hz: np.ndarray, ratio: float) -> OuterLoop:
    """Horizontal velocity PI on (closed attitude loop) * hold / s."""
    plant = att_closed * hold(f_hz) * integrator(f_hz)
    return design_outer("velocity xy", plant, att_closed, f_hz, ratio, pi_controller)


def motor_response(tau_s: float, f_hz: np.ndarray) -> np.ndarray:
    """The collective thrust's first-order lag (the motors)."""
    return 1.0 / (1.0 + 1j * 2 * math.pi * f_hz * tau_s)


def design_velocity_z(tau_s: float, f_hz: np.ndarray, ratio: float) -> OuterLoop:
    """Vertical velocity PI on motors * hold / s."""
    motors = motor_response(tau_s, f_hz)
    plant = motors * hold(f_hz) * integrator(f_hz)
    return design_outer("velocity z", plant, motors, f_hz, ratio, pi_controller)


def design_position(vel: OuterLoop, f_hz: np.ndarray, ratio: float, name: str) -> OuterLoop:
    """Position P on (closed velocity loop) / s."""
    return design_outer(name, vel.closed * integrator(f_hz), vel.closed, f_hz, ratio, p_controller)
