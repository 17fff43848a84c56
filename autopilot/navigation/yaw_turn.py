"""Turn in place (MAV_CMD_CONDITION_YAW): the hold or go-to task flown on, its heading turned at a rate.

:class:`YawTurn` wraps the active task (a :class:`LoiterTask` or :class:`GotoTask`): each
update it takes the task's setpoint and replaces the yaw with one that moves from the
heading at the start by ``turn_rad`` (:func:`turn_angle`: +1 clockwise seen from above =
growing yaw, -1 counter-clockwise, 0 the shorter way) at ``rate_rad_s``, speeding up and
slowing down at most at ``acc_rad_s2`` (MPC_YAWRAUTO_ACC) so that it stops on the target
(:class:`autopilot.navigation.heading_smoothing.HeadingSmoothing`), with that rate fed forward
(the setpoint's ``yaw_rate_rad_s``).  Once there, the wrapped task's own heading becomes the
target, so it holds it.

Yaw in radians from north, rates rad/s, accelerations rad/s^2; time is simulated microseconds.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from autopilot.navigation.flight_task import FlightTask, PositionSetpoint
from autopilot.navigation.heading_smoothing import HeadingLimits, HeadingSmoothing, yaw_rate_of
from autopilot.topics import VehicleEstimate
from mavsim_core.quaternion import wrap_pi


def turn_angle(start_rad: float, target_rad: float, direction: int) -> float:
    """The signed turn (rad) from ``start_rad`` to ``target_rad``: shorter way (0), clockwise (+1, >= 0) or
    counter-clockwise (-1, <= 0)."""
    d = wrap_pi(target_rad - start_rad)
    if direction > 0 and d < 0:
        d += 2 * math.pi
    elif direction < 0 and d > 0:
        d -= 2 * math.pi
    return d


class YawTurn:
    """``task`` flown as it is, its heading turned by ``turn_rad`` from ``start_rad`` at ``rate_rad_s`` (speeding
    up and slowing down at ``acc_rad_s2``; None: MPC_YAWRAUTO_ACC's default)."""

    def __init__(
        self, task: FlightTask, start_rad: float, turn_rad: float, rate_rad_s: float, acc_rad_s2: float | None = None
    ) -> None:
        self.inner = task
        self.start_rad = start_rad
        self.turn_rad = turn_rad
        self.target_rad = wrap_pi(start_rad + turn_rad)
        self.rate_rad_s = max(rate_rad_s, 1e-3)
        acc = HeadingLimits().acc_rad_s2 if acc_rad_s2 is None else max(acc_rad_s2, 1e-3)
        self.heading = HeadingSmoothing(HeadingLimits(self.rate_rad_s, acc), start_rad)
        self.t_us: int | None = None  # the latest update's
        self.turned = False

    def activate(self, est: VehicleEstimate, now_us: int) -> None:
        """The wrapped task is already active: the turn starts now, from the vehicle's own yaw rate."""
        self.heading.reset(self.start_rad, yaw_rate_of(est.q_wxyz, est.rate_frd_rad_s))
        self.t_us = now_us

    @property
    def yaw_rad(self) -> float:
        return self.target_rad

    def update(self, est: VehicleEstimate, now_us: int) -> PositionSetpoint:
        sp = self.inner.update(est, now_us)
        if self.turned:
            return dataclasses.replace(sp, yaw_rad=self.target_rad, yaw_rate_rad_s=0.0)
        h = self.heading
        last = now_us if self.t_us is None else self.t_us
        self.t_us = now_us
        yaw = h.update(self.start_rad + self.turn_rad, (now_us - last) * 1e-6, shortest=False)
        if h.on_target:
            self.turned = True
            if hasattr(self.inner, "yaw_rad"):
                self.inner.yaw_rad = self.target_rad  # the wrapped task holds the new heading from now on
            return dataclasses.replace(sp, yaw_rad=self.target_rad, yaw_rate_rad_s=0.0)
        return dataclasses.replace(sp, yaw_rad=yaw, yaw_rate_rad_s=h.rate_rad_s)

    @property
    def done(self) -> bool:
        return self.inner.done

    @property
    def failed(self) -> bool:
        return self.inner.failed

    def shift(self, delta_ned_m: np.ndarray) -> None:
        self.inner.shift(delta_ned_m)
