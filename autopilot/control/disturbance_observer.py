"""Disturbance observer: the external acceleration (wind, drag) that the thrust and gravity do not explain.

Newton in NED: m a = T + m g + m d, so d = a - g - T / m, with
- ``a`` the measured kinematic acceleration (m/s^2, NED, gravity removed: the estimator's rotated
  accelerometer, so a - g is the specific force the accelerometer felt);
- ``T`` the thrust the rotors gave (N, NED): the mixer's collective thrust through a first-order
  motor lag (the vehicle file's time constant), along the body's -z axis at the estimated attitude;
- ``g`` = (0, 0, 9.81) m/s^2.
The raw estimate is low-passed (first order, ``cutoff_hz``) and clamped to ``limit_m_s2``.  A raw
vertical part pushing up by more than ``CONTACT_M_S2`` is the ground carrying part of the weight (or
an impact), not the air: the estimate is reset then and held at zero for ``CONTACT_HOLD_S`` after
the last such push (a touchdown's friction and a tilted vehicle's thrust held by its legs would
otherwise be fed forward as tilt, and rock it on its legs from one bounce to the next).  Fed
forward as -d into the acceleration setpoint, it cancels a wind's push within a few tenths of a
second, before the velocity integrator would; the integrator is left with what remains.  Only in the
air: on the ground the ground's reaction would read as a disturbance (:meth:`reset` there).

NaN-safe: a non-finite input changes nothing.  Pure: no I/O, no clock; ``dt`` is an input.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from mavsim_core.constants import GRAVITY_M_S2
from mavsim_core.floats import floats3

MAX_DT_S = 0.1  # a longer step (a gap) filters nothing
LIMIT_M_S2 = 5.0  # the largest disturbance fed forward (horizontal norm), m/s^2
CONTACT_M_S2 = 3.0  # a raw upward push beyond this (0.3 g): the ground carries the vehicle, reset
CONTACT_HOLD_S = 1.0  # ... and held at zero this long after the last one (bounces)
_G_NED = (0.0, 0.0, GRAVITY_M_S2)


class DisturbanceObserver:
    """The low-passed external acceleration ``estimate`` (m/s^2, NED) of a vehicle of ``mass_kg``."""

    def __init__(self, mass_kg: float, cutoff_hz: float, limit_m_s2: float = LIMIT_M_S2) -> None:
        self.mass_kg = mass_kg
        self.cutoff_hz = cutoff_hz
        self.limit_m_s2 = limit_m_s2
        self.estimate = np.zeros(3)
        self.valid = False  # at least one update since the last reset
        self._contact_s = 0.0  # time left holding the estimate at zero after a ground contact

    def reset(self) -> None:
        self.estimate = np.zeros(3)
        self.valid = False

    @property
    def in_contact(self) -> bool:
        """The ground pushed up within the last CONTACT_HOLD_S (the estimate is held at zero meanwhile)."""
        return self._contact_s > 0.0

    def update(
        self, accel_ned_m_s2: np.ndarray | Sequence[float], thrust_ned_n: np.ndarray | Sequence[float], dt: float
    ) -> np.ndarray:
        """One step: ``accel_ned_m_s2`` measured (gravity removed), ``thrust_ned_n`` given; the estimate.
        (On Python floats per axis: numpy's per-call cost on 3-vectors would be most of the work.)"""
        ax, ay, az = floats3(accel_ned_m_s2)
        tx, ty, tz = floats3(thrust_ned_n)
        m = self.mass_kg
        raw = (ax - _G_NED[0] - tx / m, ay - _G_NED[1] - ty / m, az - _G_NED[2] - tz / m)
        if not (0.0 < dt <= MAX_DT_S) or not math.isfinite(raw[0] + raw[1] + raw[2]):
            return self.estimate
        self._contact_s = CONTACT_HOLD_S if raw[2] < -CONTACT_M_S2 else max(0.0, self._contact_s - dt)
        if self._contact_s > 0.0:  # on the ground (or bouncing on it): its reaction is no disturbance to cancel
            self.reset()
            return self.estimate
        k = dt / (dt + 1.0 / (2.0 * math.pi * self.cutoff_hz)) if self.cutoff_hz > 0 else 1.0
        ex, ey, ez = self.estimate.tolist()
        ex, ey, ez = ex + k * (raw[0] - ex), ey + k * (raw[1] - ey), ez + k * (raw[2] - ez)
        lim = self.limit_m_s2
        h = math.hypot(ex, ey)
        if h > lim:
            ex, ey = ex * (lim / h), ey * (lim / h)
        ez = min(max(ez, -lim), lim)
        self.estimate = est = np.array((ex, ey, ez))
        self.valid = True
        return est


class MotorLag:
    """The collective thrust the rotors give (N): the commanded one through a first-order lag (``tau_s``)."""

    def __init__(self, tau_s: float) -> None:
        self.tau_s = tau_s
        self.thrust_n = 0.0
        self._k: tuple[float, float] = (-1.0, 0.0)  # (dt, gain) of the latest step

    def step(self, commanded_n: float, dt: float) -> float:
        if self._k[0] != dt:
            self._k = (dt, 1.0 - math.exp(-dt / self.tau_s) if self.tau_s > 0 else 1.0)
        if math.isfinite(commanded_n):
            self.thrust_n += self._k[1] * (commanded_n - self.thrust_n)
        return self.thrust_n


class DisturbanceFeedForward:
    """The flight controller's use of the observer: the motor lag at the control rate (:meth:`motors`), the
    observer at the outer loop (:meth:`update`), in the air only.  ``enabled`` and ``cutoff_hz`` are
    MPC_DOB_EN and MPC_DOB_LP, kept current by :class:`autopilot.control.gains_from_params.GainsFromParams`
    (:meth:`set_settings`).  Horizontal only: the wind pushes sideways, and near the ground the ground
    effect and the landing's touch would read as vertical disturbances (the vertical integrator has those)."""

    def __init__(self, mass_kg: float, motor_tau_s: float, enabled: bool, cutoff_hz: float) -> None:
        self.observer = DisturbanceObserver(mass_kg, cutoff_hz)
        self.lag = MotorLag(motor_tau_s)
        self.enabled = enabled

    def set_settings(self, enabled: bool, cutoff_hz: float) -> None:
        """New settings from the next update on."""
        self.enabled = enabled
        self.observer.cutoff_hz = cutoff_hz

    def motors(self, collective_n: float, dt: float) -> None:
        """The mixer's collective thrust (N) of this control step."""
        self.lag.step(collective_n, dt)

    def update(self, accel_ned_m_s2: np.ndarray, r_ned_frd: np.ndarray, flying: bool, dt: float) -> np.ndarray | None:
        """The disturbance to feed forward (m/s^2, NED; None: none), from the estimator's acceleration and
        attitude (FRD -> NED) at the outer loop; ``flying``: in the air, off the ground."""
        obs = self.observer
        if not flying or not self.enabled:
            obs.reset()
            return None
        t = -self.lag.thrust_n
        ux, uy, uz = r_ned_frd[:, 2].tolist()  # body z axis, NED
        ex, ey, _ = obs.update(accel_ned_m_s2, (t * ux, t * uy, t * uz), dt).tolist()
        return np.array((ex, ey, 0.0))
