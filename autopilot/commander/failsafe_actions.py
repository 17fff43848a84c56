"""Where the commander applies what the failsafes (:mod:`.failsafes`) and the failure detector
(:mod:`.failure_detector`) decide, as methods of the :class:`Commander`.

Each update the commander builds the failsafes' snapshot (:meth:`FailsafeActions._failsafe_inputs`), calls the
pure :func:`.failsafes.decide` with their memory, says the decision's STATUSTEXTs and takes its action: a mode
switch through ``Commander._enter`` (a refused mode falls back: Return or Hold -> Land -> Descend), the descend
task, or a forced disarm.  The failure detector's decision (:meth:`FailsafeActions._check_failures`) is applied
the same way.  This is the only place a failsafe changes the vehicle.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from pymavlink.dialects.v20 import common as S

from autopilot.commander import failsafes, health
from autopilot.commander.commander_state import CommanderState
from autopilot.commander.failsafes import DESCEND, PHRASE, TERMINATE, Alarm, FailsafeInputs, FailsafeParams, Target
from autopilot.commander.failure_detector import FailureDetector, FailureInputs, FailureParams, StopMotors
from autopilot.commander.mode_requirements import EstimateValidity
from autopilot.navigation import offboard, started
from autopilot.navigation.descend import DescendTask
from mavsim_core.px4_modes import Mode

if TYPE_CHECKING:
    from autopilot.navigation.land_detector import LandDetector
    from autopilot.topics import ActuatorStatus, BatteryState


class FailsafeActions(CommanderState):
    """The failsafes' snapshot built and their decisions applied, as methods of the :class:`Commander`."""

    # Beyond CommanderState's, the commander's state these methods read and set (Commander.__init__ sets it)
    events: list[tuple[int, str]]
    battery: BatteryState
    wall_s: float | None
    hover_thrust_frac: float
    failsafe: failsafes.FailsafeState
    failure_detector: FailureDetector
    land_detector: LandDetector
    armed_at_us: int
    vel_sp_down_m_s: float

    def _check_failsafes(self, now_us: int) -> None:
        """Run the failsafes on this update's snapshot and apply their decision (the module docstring)."""
        st = self.failsafe
        if self.armed:
            st.terminated = False
        else:
            st.in_force = None
        start: int | None = 0
        while start is not None:
            decision, st.memory = failsafes.decide(self._failsafe_inputs(now_us), st.memory, start)
            for severity, text in decision.texts:
                self.say(severity, text)
            if decision.alarm is not None:
                self._raise_alarm(decision.alarm)
            start = decision.resume_at
        if self.est is not None and st.in_force is not None and self.mode is not st.in_force:
            st.in_force = None  # the pilot took over

    def _failsafe_inputs(self, now_us: int) -> FailsafeInputs:
        """What the failsafes watch, now."""
        inputs, wall, p = self.inputs, self.wall_s, self.params
        offboard_lost = self.armed and self.mode is Mode.OFFBOARD and offboard.offboard_lost(inputs, now_us, wall, p)
        frac = self.battery.remaining_frac
        return FailsafeInputs(
            armed=self.armed,
            in_air=self.in_air,
            mode=self.mode,
            estimate=EstimateValidity.of(self.est),
            manual_age_s=inputs.manual_age_s(now_us, wall),
            gcs_age_s=inputs.gcs_age_s(now_us, wall),
            offboard_lost=offboard_lost,
            battery_frac=frac,
            battery_level=health.battery_warning(frac, p),
            params=FailsafeParams.from_store(p),
        )

    def _raise_alarm(self, alarm: Alarm) -> None:
        """Report ``alarm`` and, flying, take its action: one STATUSTEXT "what: action", said before the mode
        change's own messages."""
        at = len(self.events)
        phrase = self._take_failsafe_action(alarm.target) if self.armed and self.in_air else None
        self.events.insert(at, (alarm.severity, f"{alarm.what}: {phrase}" if phrase else alarm.what))

    def _take_failsafe_action(self, target: Target) -> str | None:
        """Do ``target`` (falling back when its mode is refused); what was done, in words (None: nothing)."""
        st = self.failsafe
        if target is None:
            return None
        if target == TERMINATE:
            self._stop_motors("flight termination")
            return "motors stopped"
        current = DESCEND if isinstance(self.task, DescendTask) else self.mode
        if failsafes.already_flown(current, target):
            st.in_force = self.mode
            return f"already {PHRASE[current]}"
        for step in failsafes.fallback_chain(target):
            if step == DESCEND:
                self._descend()
                st.in_force = Mode.AUTO_LAND
                return PHRASE[DESCEND]
            assert isinstance(step, Mode)
            if self._enter(step) == S.MAV_RESULT_ACCEPTED:
                st.in_force = step
                return PHRASE.get(step, f"mode {step.label}")
        return None  # not reached: descending is never refused

    def _descend(self) -> None:
        """Fly the descend task (level, thrust just below hover) in AUTO.LAND, as PX4 reports Descend."""
        assert self.est is not None
        self.task = started(DescendTask(self.hover_thrust_frac), self.est, self.now_us)
        self._switch_mode(Mode.AUTO_LAND)

    def _stop_motors(self, why: str) -> None:
        """A failsafe stops the motors (a forced disarm): HEARTBEAT EMERGENCY until the next arming."""
        self._disarm(why)
        self.failsafe.terminated, self.failsafe.in_force = True, None

    def _check_failures(self, now_us: int, actuators: ActuatorStatus) -> None:
        """Feed the failure detector this update and apply its decision (STATUSTEXTs, motors stopped)."""
        inputs = FailureInputs(
            now_us=now_us,
            armed=self.armed,
            armed_at_us=self.armed_at_us,
            in_air=self.in_air,
            mode=self.mode,
            est=self.est,
            actuators=actuators,
            vel_sp_down_m_s=self.vel_sp_down_m_s,
            ground_down_m=self.land_detector.ground_down_m,
            params=FailureParams.from_store(self.params),
        )
        decision = self.failure_detector.step(inputs)
        for step in decision.steps:
            if isinstance(step, StopMotors):
                self._stop_motors(step.why)
            else:
                self.say(*step)
        self.failsafe.critical_failure = decision.critical_failure
