"""Loiter (hold): keep a fixed point and heading.

The point and heading are given (the commander holds the take-off's goal) or taken
from the vehicle's estimate at activation ("hold here").  The setpoint is that point
(metres NED, relative to the estimator origin) with zero velocity and acceleration
feed-forward, as a go-to of zero length gives.  A loiter is never ``done``: it holds
until the commander starts another task.
"""

from __future__ import annotations

import numpy as np

from autopilot.navigation.flight_task import PositionSetpoint
from autopilot.parameters import ParamDef
from autopilot.topics import VehicleEstimate

# The loiter reads no parameter (listed in autopilot/param_catalogue.py all the same).
PARAMS: tuple[ParamDef, ...] = ()


class LoiterTask:
    """Hold ``pos_ned_m`` (m NED) at ``yaw_rad``; None holds where the vehicle is at activation."""

    def __init__(self, pos_ned_m: np.ndarray | None = None, yaw_rad: float | None = None) -> None:
        self.pos = None if pos_ned_m is None else pos_ned_m.astype(float).copy()
        self.yaw_rad = yaw_rad

    def activate(self, est: VehicleEstimate, now_us: int) -> None:
        """Fix the point and heading (the estimate's where none was given)."""
        if self.pos is None:
            self.pos = est.pos_ned_m.astype(float).copy()
        if self.yaw_rad is None:
            self.yaw_rad = est.yaw_rad

    def update(self, est: VehicleEstimate, now_us: int) -> PositionSetpoint:
        """The held point with zero velocity and acceleration feed-forward."""
        assert self.pos is not None and self.yaw_rad is not None  # (activate fixed both)
        return PositionSetpoint(self.pos.copy(), np.zeros(3), self.yaw_rad, np.zeros(3))

    @property
    def done(self) -> bool:
        return False

    @property
    def failed(self) -> bool:
        return False

    def shift(self, delta_ned_m: np.ndarray) -> None:
        """Move the held point with an estimator reset, so the vehicle itself does not move."""
        if self.pos is not None:
            self.pos += delta_ned_m
