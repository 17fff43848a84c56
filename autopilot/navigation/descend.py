"""Descend: the last-resort failsafe when neither a position nor an attitude can be trusted (PX4's Descend).

The vehicle is held level at the heading it had when the task started, with a collective thrust
a little below the hover thrust (:data:`DESCEND_THRUST_OF_HOVER`), so it sinks slowly wherever it
is; it returns an :class:`~autopilot.topics.AttitudeSetpoint`, which the flight controller flies
directly even without a valid attitude estimate.  Once the vertical speed estimate has been near
zero for :data:`TOUCHDOWN_S` (the thrust no longer carries the weight: the legs do), the thrust is
cut to :data:`IDLE_THRUST_FRAC` so that the land detector declares the landing.

Frames and units: attitude quaternion FRD -> NED, yaw rad, thrust a fraction of the vehicle's
maximum (0..1), speeds m/s NED.  Time is ``now_us`` (simulated microseconds); nothing here reads a
clock.
"""

from __future__ import annotations

import numpy as np

from autopilot.topics import AttitudeSetpoint, VehicleEstimate
from mavsim_core import quaternion as quat

DESCEND_THRUST_OF_HOVER = 0.9  # thrust while descending, fraction of the hover thrust
TOUCHDOWN_SPEED_M_S = 0.15  # vertical speed below which the vehicle may be resting on its legs
TOUCHDOWN_S = 2.0  # ... for this long (after descending at least as long): on the ground
IDLE_THRUST_FRAC = 0.05  # thrust once on the ground (the land detector then declares the landing)


class DescendTask:
    """Level, heading held, thrust just below hover; idle once resting on the ground (module docstring)."""

    landing = True  # the commander reports MAV_LANDED_STATE_LANDING while it flies

    def __init__(self, hover_thrust_frac: float) -> None:
        self.hover_thrust_frac = hover_thrust_frac
        self.yaw_rad = 0.0
        self.started_us = 0
        self._still_since_us: int | None = None
        self.touched_down = False

    def activate(self, est: VehicleEstimate, now_us: int) -> None:
        self.yaw_rad = est.yaw_rad if np.isfinite(est.yaw_rad) else 0.0
        self.started_us = now_us
        self._still_since_us = None
        self.touched_down = False

    def update(self, est: VehicleEstimate, now_us: int) -> AttitudeSetpoint:
        q = quat.from_euler(0.0, 0.0, self.yaw_rad)
        vz = float(est.vel_ned_m_s[2])
        if not (est.height_valid and abs(vz) < TOUCHDOWN_SPEED_M_S) or now_us - self.started_us < TOUCHDOWN_S * 1e6:
            self._still_since_us = None
        elif self._still_since_us is None:
            self._still_since_us = now_us
        elif now_us - self._still_since_us >= TOUCHDOWN_S * 1e6:
            self.touched_down = True
        thrust = IDLE_THRUST_FRAC if self.touched_down else DESCEND_THRUST_OF_HOVER * self.hover_thrust_frac
        return AttitudeSetpoint(q, None, thrust)

    @property
    def done(self) -> bool:
        return self.touched_down

    @property
    def failed(self) -> bool:
        return False

    def shift(self, delta_ned_m: np.ndarray) -> None:
        """No point held: nothing to move."""
