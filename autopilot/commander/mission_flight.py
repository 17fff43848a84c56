"""Flying a mission, a precision landing and the geofence, as methods of the :class:`Commander`.

:mod:`.mission_control` and :mod:`.precision_landing` decide from what they are given (the plans, the estimate,
home, the parameters) and return what to say and do; these methods give it to them and do it: say the
STATUSTEXTs, start the task, enter the mode a mission or the geofence asks for, set home, cut the motors once
a precision landing docked.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from pymavlink.dialects.v20 import common as S

from autopilot.commander import mission_control, precision_landing
from autopilot.commander.commander_state import CommanderState
from autopilot.navigation import LoiterTask, started
from autopilot.navigation.precland import PrecLandMode, PrecLandTask
from mavsim_core.px4_modes import Mode

if TYPE_CHECKING:
    from autopilot.control.position_control import PositionSetpoint
    from autopilot.navigation.land_detector import LandDetector
    from autopilot.navigation.mission import MissionTask
    from autopilot.navigation.precland import LandingTargetInput
    from autopilot.topics import AttitudeSetpoint, VehicleEstimate

    Setpoint = PositionSetpoint | AttitudeSetpoint | None  # what a step flies (None: nothing, the motors cut)


class MissionFlight(CommanderState):
    """AUTO.MISSION started and stepped, precision landings stepped, the geofence checked, as methods of the
    :class:`Commander`."""

    # Beyond CommanderState's, the commander's state these methods read and set (Commander.__init__ sets it)
    land_detector: LandDetector
    contact_push: bool
    landing_target: LandingTargetInput | None
    hover_thrust_frac: float

    if TYPE_CHECKING:  # ... and the commander's methods they call.

        def _new_precland(self, mode: PrecLandMode, est: VehicleEstimate) -> PrecLandTask: ...

    def _say_all(self, texts: list[tuple[int, str]] | tuple[tuple[int, str], ...]) -> None:
        for severity, text in texts:
            self.say(severity, text)

    def _start_mission(self) -> int:
        """Build the runner for AUTO.MISSION from the current item (a MAV_RESULT; refusals say why)."""
        task, texts = mission_control.start_mission(
            self.plans, self.home, self.est, self.params, self.in_air, self.now_us
        )
        if task is not None:
            self.task = task
        self._say_all(texts)
        return S.MAV_RESULT_DENIED if task is None else S.MAV_RESULT_ACCEPTED

    def _step_mission(self, task: MissionTask, est: VehicleEstimate, now_us: int) -> "Setpoint":
        """One update of the mission (or of a return flown through it): the runner's setpoint, its progress and
        its requests; once a precision landing has started, that landing's update."""
        if task.precland is not None:
            return self._step_mission_precland(task, est, now_us)
        setpoint, texts, request = mission_control.advance(self.plans, task, est, now_us)
        self._say_all(texts)
        if request is None:
            return setpoint
        if request[0] == "rtl":
            self._enter(Mode.AUTO_RTL)
        elif request[0] == "precland":  # PX4's mission flies it in AUTO.MISSION (and its RTL in AUTO.RTL)
            task.precland = started(self._new_precland(PrecLandMode(request[1]), est), est, now_us)
            return self._step_mission_precland(task, est, now_us)
        elif request[0] == "home":
            self._set_home_at(mission_control.requested_home(request[1], est, self.home))
        return self.task.update(est, now_us) if self.task is not task and self.task is not None else setpoint

    def _step_mission_precland(self, task: MissionTask, est: VehicleEstimate, now_us: int) -> "Setpoint":
        assert task.precland is not None
        setpoint = self._step_precland(task.precland, est, now_us)
        if not self.armed and task.follows_plan:  # docked: the motors are cut, the mission is over
            self._say_all(mission_control.on_landed(self.plans))
        return setpoint

    def _step_precland(self, task: PrecLandTask, est: VehicleEstimate, now_us: int) -> "Setpoint":
        """One update of the precision landing; the setpoint, or None once the motors are cut (docked)."""
        on_deck = self.land_detector.ground_contact or self.contact_push
        result = precision_landing.step(
            task, est, now_us, on_deck, self.inputs.gimbal_reach_rad, self.landing_target, self.hover_thrust_frac
        )
        self._say_all(result.texts)
        if result.docked:
            self._disarm("docked on the landing target")
            return None
        return result.setpoint

    def _check_geofence(self, est: VehicleEstimate, now_us: int) -> None:
        """Predict a breach and act as GF_ACTION says (:func:`.mission_control.check_geofence`)."""
        holding = self.task is not None and self.task is self.plans.fence_hold
        action = mission_control.check_geofence(self.plans, self.params, est, now_us, self.home, self.mode, holding)
        if action.text is not None:
            self.say(*action.text)
        if action.hold_at is not None:
            if self.mode is not Mode.AUTO_LOITER:
                self._switch_mode(Mode.AUTO_LOITER)
            self.task = self.plans.fence_hold = started(LoiterTask(action.hold_at, est.yaw_rad), est, now_us)
        elif action.enter is not None:
            self._enter(action.enter)
