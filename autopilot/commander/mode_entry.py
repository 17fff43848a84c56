"""Entering a mode, as methods of the :class:`Commander`: the refusal decided, else the mode's flight task built.

:meth:`ModeEntry._enter` is the commander's one mode switch: it builds a frozen
:class:`~autopilot.commander.mode_requirements.ModeEntryInputs` (what the estimate, the inputs and the vehicle
say now), asks the pure :func:`~autopilot.commander.mode_requirements.entry_refusal` whether the mode may be
entered (what each mode needs, as PX4's mode requirements, is written there) and, refused, says why in a
STATUSTEXT; else it builds and starts the mode's task and switches.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from pymavlink.dialects.v20 import common as S

from autopilot.commander import mission_landing, mode_requirements, precision_landing
from autopilot.commander.commander_state import CommanderState
from autopilot.commander.mode_requirements import NEEDS_STICKS, EstimateValidity, ModeEntryInputs
from autopilot.navigation import LandTask, LoiterTask, TakeoffTask, started
from autopilot.navigation.follow_target import FollowTargetTask, fresh_target
from autopilot.navigation.manual_modes import AcroTask, AltCtlTask, PosCtlTask, StabilizedTask
from autopilot.navigation.offboard import OffboardTask, offboard_refusal
from mavsim_core.px4_modes import Mode

if TYPE_CHECKING:
    from autopilot.navigation.precland import PrecLandMode
    from autopilot.topics import VehicleEstimate


class ModeEntry(CommanderState):
    """The mode switch and the tasks of the modes, as methods of the :class:`Commander`."""

    # Beyond CommanderState's, the commander's state these methods read and set (Commander.__init__ sets it)
    wall_s: float | None
    hover_thrust_frac: float
    precland_mode: PrecLandMode
    feet_below_m: float

    def _mode_entry_inputs(self, mode: Mode) -> ModeEntryInputs:
        """What entering ``mode`` depends on now."""
        now_us, wall = self.now_us, self.wall_s
        return ModeEntryInputs(
            armed=self.armed,
            in_air=self.in_air,
            estimate=EstimateValidity.of(self.est),
            has_home=self.home is not None,
            manual_age_s=self.inputs.manual_age_s(now_us, wall) if mode in NEEDS_STICKS else None,
            rc_loss_t_s=self.params.get("COM_RC_LOSS_T"),
            offboard_refusal=offboard_refusal(self.inputs, now_us, wall, self.params)
            if mode is Mode.OFFBOARD
            else None,
        )

    def _input_refusal(self, mode: Mode) -> str | None:
        """Why ``mode`` lacks its outside input now (sticks, an offboard setpoint stream), or None; armed or not."""
        return mode_requirements.input_refusal(mode, self._mode_entry_inputs(mode))

    def _enter(self, mode: Mode, takeoff_down_m: float | None = None) -> int:
        """Switch to ``mode`` and start its task; refuse (with a reason) if it cannot run now."""
        refusal = mode_requirements.entry_refusal(mode, self._mode_entry_inputs(mode))
        if refusal is not None:
            self.say(S.MAV_SEVERITY_CRITICAL, refusal)
            return S.MAV_RESULT_DENIED
        e = self.est
        assert e is not None  # (refused without an estimate)
        if mode is Mode.AUTO_TAKEOFF:
            assert self.home is not None
            if takeoff_down_m is None:
                takeoff_down_m = self.home.pos_ned_m[2] - self.params.get("MIS_TAKEOFF_ALT")
            self.task = started(TakeoffTask(takeoff_down_m, self.params), e, self.now_us)
            self.say(S.MAV_SEVERITY_INFO, f"Taking off to {self.home.pos_ned_m[2] - takeoff_down_m:.1f} m above home")
        elif mode is Mode.AUTO_LOITER:
            if mode is not self.mode or self.task is None:
                self.task = started(LoiterTask(), e, self.now_us)
        elif mode in (Mode.POSCTL, Mode.ALTCTL, Mode.STABILIZED, Mode.ACRO):
            if mode is not self.mode or self.task is None:
                self.task = started(self._manual_task(mode), e, self.now_us)
        elif mode is Mode.OFFBOARD:
            task = OffboardTask(self.params, lambda: self.inputs.offboard, self.hover_thrust_frac)
            self.task = started(task, e, self.now_us)
        elif mode is Mode.AUTO_LAND:
            self.task = started(LandTask(self._ground_down_m(e), self.params), e, self.now_us)
        elif mode is Mode.AUTO_RTL:
            assert self.home is not None
            route, text = mission_landing.return_task(self.plans, self.params, self.home, self.mode, e)  # RTL_TYPE
            if text is not None:
                self.say(S.MAV_SEVERITY_INFO, text)
            self.task = started(route, e, self.now_us)
        elif mode is Mode.AUTO_MISSION and (result := self._start_mission()) != S.MAV_RESULT_ACCEPTED:
            return result
        elif mode is Mode.AUTO_PRECLAND:
            self.task = started(self._new_precland(self.precland_mode, e), e, self.now_us)
        elif mode is Mode.AUTO_FOLLOW_TARGET:
            target = lambda: fresh_target(self.inputs, self.now_us, self.wall_s)  # noqa: E731
            self.task = started(FollowTargetTask(self.params, target, self._ground_down_m(e), self.say), e, self.now_us)
        self._switch_mode(mode)
        return S.MAV_RESULT_ACCEPTED

    def _ground_down_m(self, est: VehicleEstimate):
        """The ground's height (m NED down): home's, or the estimate's without a home."""
        return self.home.pos_ned_m[2] if self.home else est.pos_ned_m[2]

    def _new_precland(self, mode: PrecLandMode, est: VehicleEstimate):
        """A precision landing in ``mode`` onto the ground (:meth:`_ground_down_m`), not started."""
        return precision_landing.new_task(self.params, mode, self._ground_down_m(est), self.feet_below_m)

    def _manual_task(self, mode: Mode):
        """The task of a stick mode; it reads the latest MANUAL_CONTROL through ``self.inputs``."""
        sticks = lambda: self.inputs.manual  # noqa: E731
        if mode is Mode.POSCTL:
            return PosCtlTask(self.params, sticks)
        if mode is Mode.ALTCTL:
            return AltCtlTask(self.params, sticks)
        if mode is Mode.STABILIZED:
            return StabilizedTask(self.params, sticks, self.hover_thrust_frac)
        return AcroTask(self.params, sticks, self.hover_thrust_frac)
