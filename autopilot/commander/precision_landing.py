"""The commander's side of AUTO.PRECLAND: run the task, report its phases, cut the motors when docked, and
decide where the camera gimbal points (:func:`gimbal_request`, applied by the gimbal manager).

The task (:class:`autopilot.navigation.precland.PrecLandTask`) flies the phases; here its phase
changes become STATUSTEXTs ("Precland: tracking (...)"), a required landing that found no
target is reported once, and the docking point disarms the vehicle, as [F 3] cuts the motors
there.  A mission's NAV_LAND with param2 1/2 flies the same task inside AUTO.MISSION (the runner's
``precland``, as PX4's mission keeps its mode): :func:`landing_of` finds it in either.  Frames: NED, m/s.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from pymavlink.dialects.v20 import common as S

from autopilot.control.gimbal_pointing import GimbalRequest
from autopilot.navigation.precland import PrecLandConfig, PrecLandMode, PrecLandPhase, PrecLandTask
from autopilot.navigation.precland_gimbal import landing_gimbal_request
from autopilot.parameters import ParameterStore
from autopilot.topics import VehicleEstimate

if TYPE_CHECKING:
    from autopilot.commander.commander import Commander
    from autopilot.control.position_control import PositionSetpoint


def new_task(c: Commander, mode: PrecLandMode) -> PrecLandTask:
    """A precision landing in ``mode`` onto the ground at home's height (the estimate's without a home)."""
    assert c.est is not None
    ground = c.home.pos_ned_m[2] if c.home else c.est.pos_ned_m[2]
    return PrecLandTask(ground, c.params, PrecLandConfig.from_store(c.params), mode, feet_below_m=c.feet_below_m)


def landing_of(task: object) -> PrecLandTask | None:
    """The precision landing ``task`` flies: itself (AUTO.PRECLAND), a mission's (AUTO.MISSION), or None."""
    if isinstance(task, PrecLandTask):
        return task
    inner = getattr(task, "precland", None)
    return inner if isinstance(inner, PrecLandTask) else None


def step(commander: Commander, task: PrecLandTask, est: VehicleEstimate, now_us: int) -> PositionSetpoint | None:
    """One update of the precision landing; the setpoint, or None once the motors are cut."""
    failed_before = task.failed
    task.on_deck = commander.land_detector.ground_contact or commander.contact_push
    task.gimbal_reach_rad = commander.inputs.gimbal_reach_rad  # the view cone's reach when PLD_CAM_REACH is -1
    setpoint = task.update(est, now_us, commander.landing_target)
    for _t, text in task.events:
        commander.say(S.MAV_SEVERITY_INFO, text)
    task.events.clear()
    if task.failed and not failed_before:
        commander.say(S.MAV_SEVERITY_CRITICAL, "Precision landing failed: no landing target, holding position")
    if task.done:
        commander._disarm("docked on the landing target")
        return None
    return setpoint


def velocity_over_ground_below(task: object, est: VehicleEstimate) -> np.ndarray:
    """The velocity the land detector judges: over the ground, or over the deck while a precision
    landing docks (landed means at rest relative to the ground below)."""
    landing = landing_of(task)
    if landing is not None and landing.phase in (PrecLandPhase.DOCKING, PrecLandPhase.DONE):
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
