"""The flight-task interface (PX4's FlightTask idea) and what the tasks share.

A flight task turns the vehicle's estimate into a position setpoint, one call per
outer-loop step:

1. the commander builds the task with its configuration (goal, speeds, parameters);
2. ``activate(est, now_us)`` starts it from the vehicle's state at that moment;
3. ``update(est, now_us)`` returns the :class:`PositionSetpoint` for this step;
4. ``done`` says the task has reached its end state (it keeps holding there if
   updated further); ``failed`` says it cannot go on (the commander picks another);
5. ``shift(delta_ned_m)`` moves the task's points with an estimator reset, so the
   vehicle itself does not move.

Frames and units: positions in metres NED relative to the estimator origin,
velocities m/s NED, accelerations m/s^2 NED, yaw radians.  A NaN setpoint
component means "not controlled" (the position controller skips that axis).
Time is an input (``now_us``, simulated microseconds): no task reads a clock.
"""

from __future__ import annotations

from typing import Protocol, TypeVar, runtime_checkable

import numpy as np

from autopilot.control.position_control import PositionSetpoint
from autopilot.parameters import ParamDef
from autopilot.topics import VehicleEstimate

__all__ = ["FlightTask", "PositionSetpoint", "VehicleEstimate", "defined_in", "started"]


@runtime_checkable
class FlightTask(Protocol):
    """One flight task: activate, update -> setpoint, done/failed, shift on estimator resets."""

    def activate(self, est: VehicleEstimate, now_us: int) -> None:
        """Start the task from the vehicle's estimate at ``now_us`` (simulated microseconds)."""
        ...

    def update(self, est: VehicleEstimate, now_us: int) -> PositionSetpoint:
        """The position setpoint for this step (NED metres, NaN = not controlled)."""
        ...

    @property
    def done(self) -> bool:
        """The task reached its end state (as of the latest ``update``)."""
        ...

    @property
    def failed(self) -> bool:
        """The task cannot continue (as of the latest ``update``)."""
        ...

    def shift(self, delta_ned_m: np.ndarray) -> None:
        """Move the task's points by an estimator reset's jump (m, NED)."""
        ...


class _Startable(Protocol):
    """What :func:`started` needs of a task: every flight task, and those whose setpoints are attitudes."""

    def activate(self, est: VehicleEstimate, now_us: int) -> None: ...


T = TypeVar("T", bound=_Startable)


def defined_in(params: tuple[ParamDef, ...], name: str) -> ParamDef:
    """The definition of ``name`` from another module's ``PARAMS``: a task that reads a parameter
    declared elsewhere lists that one definition instead of declaring it a second time."""
    for d in params:
        if d.name == name:
            return d
    raise KeyError(f"parameter {name} is not declared in the given PARAMS")


def started(task: T, est: VehicleEstimate, now_us: int) -> T:
    """``task`` activated from ``est`` at ``now_us``: build-and-start in one expression."""
    task.activate(est, now_us)
    return task
