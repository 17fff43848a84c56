"""The commander's side of AUTO.PRECLAND: run the task, report its phases, say when it docked, and
decide where the camera gimbal points (:func:`gimbal_request`, applied by the gimbal manager).

The task (:class:`autopilot.navigation.precland.PrecLandTask`) flies the phases; :func:`step` turns its phase
changes into STATUSTEXTs ("Precland: tracking (...)"), reports once a required landing that found no
target, and says when the docking point is reached (a :class:`PrecLandStep`); the commander says the texts
and then disarms the vehicle, as [F 3] cuts the motors there (``Commander._step_precland``).  Nothing here
takes the commander: each function is given what it reads.

A mission's NAV_LAND with param2 1/2 flies the same task inside AUTO.MISSION (the runner's
``precland``, as PX4's mission keeps its mode): :func:`landing_of` finds it in either.  Frames: NED, m/s.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import TYPE_CHECKING

import numpy as np
from pymavlink.dialects.v20 import common as S

from autopilot.control.gimbal_pointing import GimbalRequest
from autopilot.navigation.precland import (
    LandingTargetInput,
    PrecLandConfig,
    PrecLandMode,
    PrecLandPhase,
    PrecLandTask,
)
from autopilot.navigation.precland_gimbal import landing_gimbal_request
from autopilot.parameters import ParameterStore
from autopilot.topics import AttitudeSetpoint, VehicleEstimate

if TYPE_CHECKING:
    from autopilot.control.position_control import PositionSetpoint


def new_task(params: ParameterStore, mode: PrecLandMode, ground_down_m: float, feet_below_m: float) -> PrecLandTask:
    """A precision landing in ``mode`` onto the ground at ``ground_down_m`` (m NED down: home's height, or the
    estimate's without a home); ``feet_below_m``: the feet's depth below the reference point."""
    return PrecLandTask(ground_down_m, params, PrecLandConfig.from_store(params), mode, feet_below_m=feet_below_m)


def landing_of(task: object) -> PrecLandTask | None:
    """The precision landing ``task`` flies: itself (AUTO.PRECLAND), a mission's (AUTO.MISSION), or None."""
    if isinstance(task, PrecLandTask):
        return task
    inner = getattr(task, "precland", None)
    return inner if isinstance(inner, PrecLandTask) else None


@dataclass(frozen=True)
class PrecLandStep:
    """One update of a precision landing: the setpoint, the STATUSTEXTs to say, and whether it docked (the
    commander then cuts the motors, as [F 3] does)."""

    setpoint: PositionSetpoint | AttitudeSetpoint | None
    texts: tuple[tuple[int, str], ...]
    docked: bool


def step(
    task: PrecLandTask,
    est: VehicleEstimate,
    now_us: int,
    on_deck: bool,
    gimbal_reach_rad: float | None,
    landing_target: LandingTargetInput | None,
    hover_thrust_frac: float,
) -> PrecLandStep:
    """One update of the precision landing: ``on_deck``, the ground (or the deck) pushes up on the feet;
    ``gimbal_reach_rad``: the view cone's reach when PLD_CAM_REACH is -1; ``landing_target``: this update's
    measurement (None: none new); ``hover_thrust_frac``: the vehicle's (the touchdown's thrust is a part of it)."""
    failed_before = task.failed
    task.on_deck = on_deck
    task.gimbal_reach_rad = gimbal_reach_rad
    task.hover_thrust_frac = hover_thrust_frac
    setpoint = task.update(est, now_us, landing_target)
    texts = [(S.MAV_SEVERITY_INFO, text) for _t, text in task.events]
    task.events.clear()
    if task.failed and not failed_before:
        texts.append((S.MAV_SEVERITY_CRITICAL, "Precision landing failed: no landing target, holding position"))
    return PrecLandStep(setpoint, tuple(texts), task.done)


def velocity_over_ground_below(task: object, est: VehicleEstimate) -> np.ndarray:
    """The velocity the land detector judges: over the ground, or over the deck while a precision
    landing docks (landed means at rest relative to the ground below)."""
    landing = landing_of(task)
    if landing is not None and landing.phase in (PrecLandPhase.DOCKING, PrecLandPhase.TOUCHDOWN, PrecLandPhase.DONE):
        return est.vel_ned_m_s - landing.target_velocity_ned_m_s
    return est.vel_ned_m_s


def gimbal_request(task: object, est: VehicleEstimate | None, params: ParameterStore) -> GimbalRequest:
    """The camera gimbal's request of the flight task ``task`` (:mod:`autopilot.navigation.precland_gimbal`):
    a precision landing's, nothing (RELEASE) for any other task or none."""
    landing = landing_of(task)
    return landing_gimbal_request(
        bool(int(params.get("PLD_GIMB_POINT"))),
        None if landing is None else landing.phase,
        None if landing is None else landing.target_pos_ned_m,
        None if est is None else est.pos_ned_m,
    )
