"""Commander: arming, modes, commands and the flight task that is active.

Its typed command methods (:meth:`Commander.arm`, ``disarm``, ``set_mode`` here;
``takeoff``, ``land``, ``return_to_launch``, ``reposition`` inherited from
:class:`autopilot.commander.flight_commands.FlightCommands`) are what the MAVLink command
table (:mod:`autopilot.mavlink.commands`) calls; each returns a MAV_RESULT.  Every refusal
says why in a STATUSTEXT (:meth:`Commander.pop_events`).  After each update, command
and battery reading the commander publishes a frozen
:class:`~autopilot.topics.CommanderStatus` (``commander.status``) that the flight
controller, the flight log and the telemetry read; nobody writes into it.

Positions are NED metres from the estimator origin, altitudes AMSL or above home as
named.  Time is the simulated time of the latest sensor sample; nothing here reads a
clock.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from pymavlink.dialects.v20 import common as mavlink

from autopilot import telemetry_extras
from autopilot.commander import failsafes, health, mission_control, prearm_checks, precision_landing
from autopilot.commander.external_inputs import ExternalInputs
from autopilot.commander.failsafe_actions import FailsafeActions
from autopilot.commander.failure_detector import FailureDetector
from autopilot.commander.flight_commands import FlightCommands, publishes
from autopilot.commander.mission_control import Plans
from autopilot.commander.mission_flight import MissionFlight
from autopilot.commander.mode_entry import ModeEntry
from autopilot.commander.mode_requirements import AVAILABLE
from autopilot.commander.vehicle_commands import MAV_TYPES, VehicleCommands
from autopilot.control.position_control import PositionSetpoint
from autopilot.navigation import LoiterTask, TakeoffTask, started
from autopilot.navigation.land_detector import LandDetector, Landed
from autopilot.navigation.mission import MissionTask
from autopilot.navigation.precland import LandingTargetInput, PrecLandMode, PrecLandTask
from autopilot.parameters import ParamDef, ParameterStore, ParamType, param
from autopilot.topics import (
    NO_ACTUATORS,
    ActuatorStatus,
    AttitudeSetpoint,
    BatteryState,
    CommanderStatus,
    GpsSample,
    HomePosition,
    LandedState,
    VehicleEstimate,
)
from mavsim_core.geodesy import ned_to_geodetic
from mavsim_core.px4_modes import Mode

# The parameters this module reads (listed in autopilot/param_catalogue.py).
PARAMS: tuple[ParamDef, ...] = (
    param("COM_DISARM_LAND", 2.0, -1.0, 20.0, "s", "Disarm this long after landing (-1: never)"),
    param("COM_DISARM_PRFLT", 10.0, -1.0, 60.0, "s", "Disarm this long after arming if no take-off (-1: never)"),
    param("COM_ARM_TILT_MAX", 10.0, 1.0, 60.0, "deg", "Maximum tilt to allow arming (vehicle level check)"),
    param(
        "SYS_AUTOSTART", 4001, 1, 99999, "", "Airframe id (4001 quadcopter X, 6001 hexacopter)", ParamType.INT32, True
    ),
)

CLIMBS_FROM_GROUND = (Mode.AUTO_TAKEOFF, Mode.AUTO_MISSION)  # modes that take off by themselves
# Modes whose task flies from the ground too: the pilot's sticks or offboard setpoints lift off.
FLY_FROM_GROUND = (*CLIMBS_FROM_GROUND, Mode.POSCTL, Mode.ALTCTL, Mode.STABILIZED, Mode.ACRO, Mode.OFFBOARD)

S = mavlink  # MAV_RESULT_*, MAV_SEVERITY_*, MAV_TYPE_* constants


class Commander(FlightCommands, VehicleCommands, ModeEntry, MissionFlight, FailsafeActions):
    """Arming, modes and the active flight task; publishes :class:`CommanderStatus` as ``status``."""

    at_rest: bool = True  # the flight controller's rest detector (autopilot/estimation/rest_detector.py) sets it
    autotune: Any = None  # the vehicle's Autotune (autopilot/tuning/autotune.py): the flight controller sets it

    def __init__(self, params: ParameterStore, mav_type_name: str) -> None:
        self.params = params
        self.mav_type = MAV_TYPES.get(mav_type_name, S.MAV_TYPE_QUADROTOR)
        self.mode = Mode.POSCTL
        self.armed = False
        self.armed_at_us = 0
        self.now_us = 0
        self.est: VehicleEstimate | None = None
        self.gps: GpsSample | None = None
        self.gps_ok = False
        self.home: HomePosition | None = None
        self.battery = BatteryState(float("nan"), -1.0, -1.0)
        self.land_detector = LandDetector(params)
        self.task = None
        self.events: list[tuple[int, str]] = []
        self.setpoint: PositionSetpoint | AttitudeSetpoint | None = None
        self.estimator_checks: tuple[str, ...] = ()  # the estimator's own pre-arm failures, latest update
        self._reset_count = 0
        # Precision landing: the target the flight controller measured this update (None: no new
        # measurement), NAV_LAND param 2's mode, and the feet's depth below the reference point.
        self.landing_target: LandingTargetInput | None = None
        # The ground pushed up on the vehicle (the disturbance observer's contact: an impact, legs on a deck),
        # set by the flight controller after each outer-loop step; a precision landing's docking reads it.
        self.contact_push = False
        # The vertical velocity the position controller flew at its latest step (m/s, NED down; NaN: none, as
        # with attitude setpoints), set by the flight controller; the thrust-loss check reads it.
        self.vel_sp_down_m_s = math.nan
        self.precland_mode = PrecLandMode.REQUIRED
        self.feet_below_m = 0.0
        self.plans = Plans(params)  # mission, fence, rally (mission_control)
        self.inputs = ExternalInputs()  # sticks, offboard setpoints, ground-station heartbeats
        self.wall_s: float | None = None  # wall clock (s) of the latest update, for the input-loss timers
        self.hover_thrust_frac = 0.5  # weight / maximum thrust (the flight controller sets the vehicle's)
        self.failsafe = failsafes.FailsafeState()
        self.failure_detector = FailureDetector()  # loss of control, crash check
        self.status = self._make_status()

    # -- events ---------------------------------------------------------------------
    def say(self, severity: int, text: str) -> None:
        self.events.append((severity, text))

    def pop_events(self) -> list[tuple[int, str]]:
        out, self.events = self.events, []
        return out

    # -- status -----------------------------------------------------------------------
    def _make_status(self) -> CommanderStatus:
        armed, mode, battery = self.armed, self.mode, self.battery
        warning = health.battery_warning(battery.remaining_frac, self.params)
        return CommanderStatus(
            timestamp_us=self.now_us,
            mav_type=self.mav_type,
            armed=armed,
            mode=mode,
            landed_state=self.landed_state(),
            in_air=self.land_detector.state is Landed.IN_AIR,
            ground_contact=self.land_detector.ground_contact,
            home=self.home,
            estimate=self.est,
            gps=self.gps,
            gps_ok=self.gps_ok,
            battery=battery,
            battery_warning=warning,
            prearm_failures=() if armed else tuple(self.prearm_failures()),
            position_setpoint_ned_m=getattr(self.setpoint, "pos_ned_m", None),
            mission=self.plans.status(mode),  # (the previous records again while nothing in them changed)
            failsafe=failsafes.status(self.failsafe, armed, mode, self.inputs.manual is not None, warning),
            gimbal_request=precision_landing.gimbal_request(self.task, self.est, self.params),
        )

    def _publish(self) -> None:
        self.status = self._make_status()

    def set_battery(self, battery: BatteryState) -> None:
        """A new battery reading (the simulator's BATTERY_STATUS, 5 Hz)."""
        self.battery = battery
        self._publish()

    # -- checks ---------------------------------------------------------------------
    def prearm_failures(self) -> list[str]:
        """Why arming would be refused now (:mod:`autopilot.commander.prearm_checks`)."""
        p = self.params
        inputs = prearm_checks.PrearmInputs(
            est=self.est,
            gps=self.gps,
            home=self.home,
            battery=self.battery,
            estimator_failures=tuple(self.estimator_checks),
            tilt_max_deg=p.get("COM_ARM_TILT_MAX"),
            battery_low_thr=p.get("BAT_LOW_THR"),
            terminated=self.terminated,
            fence_failures=tuple(mission_control.fence_prearm_failures(self.plans, self.est)),
        )
        return prearm_checks.prearm_failures(inputs)

    @property
    def in_air(self) -> bool:
        return self.land_detector.state is Landed.IN_AIR

    # -- periodic -----------------------------------------------------------------------
    def update(
        self,
        now_us: int,
        est: VehicleEstimate,
        gps: GpsSample | None,
        gps_ok: bool,
        actuators: ActuatorStatus = NO_ACTUATORS,
        estimator_checks: tuple[str, ...] = (),
        wall_s: float | None = None,
    ) -> PositionSetpoint | AttitudeSetpoint | None:
        """Advance the state machines and publish the status; return the setpoint (position, or attitude for
        the stick, offboard-attitude and descend modes), or None for motors idle/off.

        ``actuators``: the flight controller's latest outputs (the land detector reads the thrust, the failure
        detector the motor outputs);
        ``estimator_checks``: the estimator's own pre-arm failures (empty when it has none to report);
        ``wall_s``: the wall clock (time.monotonic) for the input-loss timers (None: simulated time only).
        """
        self.wall_s = wall_s
        try:
            return self._update(now_us, est, gps, gps_ok, actuators, estimator_checks)
        finally:
            self._publish()

    def _update(
        self,
        now_us: int,
        est: VehicleEstimate,
        gps: GpsSample | None,
        gps_ok: bool,
        actuators: ActuatorStatus,
        estimator_checks: tuple[str, ...],
    ) -> PositionSetpoint | AttitudeSetpoint | None:
        self.now_us, self.est, self.gps_ok = now_us, est, gps_ok
        self.estimator_checks = estimator_checks
        if gps is not None:
            self.gps = gps
        if self.home is None and est.position_valid and self.at_rest:
            self._set_home(est)  # first valid position at rest (never a falling vehicle's); again at arming, as PX4
        if est.reset_count != self._reset_count:
            self._follow_reset(est)
        before = self.land_detector.state
        state = self.land_detector.update(
            now_us,
            self.armed,
            precision_landing.velocity_over_ground_below(self.task, est),
            float(est.pos_ned_m[2]),
            actuators.thrust_frac_of_hover,
        )
        if state is not before and self.armed:
            self.say(S.MAV_SEVERITY_INFO, "Takeoff detected" if state is Landed.IN_AIR else "Landing detected")
            if state is Landed.ON_GROUND and self.mode in (Mode.AUTO_LAND, Mode.AUTO_RTL, Mode.AUTO_MISSION):
                if self.mode is Mode.AUTO_MISSION:
                    self._say_all(mission_control.on_landed(self.plans))
                self.task = None
        if self.armed and state is Landed.ON_GROUND:  # (the auto-disarm timers run on the ground only)
            reason = health.auto_disarm_reason(
                self.land_detector, self.armed_at_us, now_us, self.mode in CLIMBS_FROM_GROUND, self.params
            )
            if reason:
                self._disarm(reason)
        self._check_failsafes(now_us)
        self._check_failures(now_us, actuators)
        if (
            self.armed
            and self.mode is Mode.AUTO_TAKEOFF
            and isinstance(self.task, TakeoffTask)
            and self.task.arrived(now_us, est)
        ):
            goal = self.task.goal
            self.say(S.MAV_SEVERITY_INFO, "Takeoff complete: holding")
            self.mode = Mode.AUTO_LOITER
            self.task = started(LoiterTask(goal, self.task.yaw_rad), est, now_us)
        if not self.armed or self.task is None:
            self.setpoint = None
            return None
        if not self.in_air and self.mode not in FLY_FROM_GROUND:
            self.setpoint = None
            return None
        if self.in_air:
            self._check_geofence(est, now_us)
        if isinstance(self.task, MissionTask):
            self.setpoint = self._step_mission(self.task, est, now_us)
            return self.setpoint
        if isinstance(self.task, PrecLandTask):
            self.setpoint = self._step_precland(self.task, est, now_us)
            return self.setpoint
        if hasattr(self.task, "on_ground"):
            self.task.on_ground = not self.in_air  # stick and offboard tasks stay idle until lift-off
        self.setpoint = self.task.update(est, now_us)
        return self.setpoint

    def _follow_reset(self, est: VehicleEstimate) -> None:
        """The estimator jumped (reset to GPS): move setpoints and home with it, as PX4 does,
        so the vehicle stays where it is."""
        self._reset_count = est.reset_count
        delta = est.reset_delta_ned_m if est.reset_delta_ned_m is not None else np.zeros(3)
        if self.task is not None and hasattr(self.task, "shift"):
            self.task.shift(delta)
        if self.home is not None:
            h = self.home
            self.home = HomePosition(h.lat_deg, h.lon_deg, h.alt_amsl_m, h.pos_ned_m + delta, h.yaw_rad)

    def _set_home(self, est: VehicleEstimate) -> None:
        self._set_home_at(est.pos_ned_m, quiet=self.home is not None)

    def _set_home_at(self, pos_ned_m: np.ndarray, quiet: bool = False) -> None:
        """Home at ``pos_ned_m`` (m NED; DO_SET_HOME, arming, the first position)."""
        est = self.est
        assert est is not None
        lat, lon, alt = ned_to_geodetic(pos_ned_m, est.origin_lat_deg, est.origin_lon_deg, est.origin_alt_amsl_m)
        self.home = HomePosition(lat, lon, alt, pos_ned_m.astype(float).copy(), est.yaw_rad)
        if not quiet:
            self.say(S.MAV_SEVERITY_INFO, f"Home set: {lat:.7f}, {lon:.7f}, {alt:.1f} m")

    # -- arming -----------------------------------------------------------------------
    def _arm(self, force: bool) -> int:
        if self.armed:
            return S.MAV_RESULT_ACCEPTED
        refusal = prearm_checks.arming_refusal(self.prearm_failures(), force, self.est is not None)
        if refusal is not None:
            self.say(S.MAV_SEVERITY_CRITICAL, refusal)
            return S.MAV_RESULT_DENIED
        assert self.est is not None  # (refused without one)
        if self.est.position_valid:
            self._set_home(self.est)
        self.armed = True
        self.armed_at_us = self.now_us
        telemetry_extras.count_flight(self.params)  # COM_FLIGHT_UUID: this flight's number (saved with the params)
        self.land_detector.on_arm(float(self.est.pos_ned_m[2]))
        self.land_detector.landed_since_us = self.now_us
        self.task = None
        if self.mode not in FLY_FROM_GROUND:
            self.mode = Mode.AUTO_LOITER
        self.say(S.MAV_SEVERITY_INFO, "Armed")
        if self.mode in FLY_FROM_GROUND and self.mode not in CLIMBS_FROM_GROUND:
            mode = self.mode  # the stick and offboard modes fly from the ground: their task starts now
            if self._enter(mode) != S.MAV_RESULT_ACCEPTED:
                self.mode = Mode.AUTO_LOITER
        if self.mode is Mode.AUTO_MISSION and self._start_mission() != S.MAV_RESULT_ACCEPTED:
            self.mode = Mode.AUTO_LOITER  # armed in MISSION: the mission starts (take-off first), as in PX4
        return S.MAV_RESULT_ACCEPTED

    def _disarm(self, why: str) -> None:
        self.armed = False
        self.task = None
        self.say(S.MAV_SEVERITY_INFO, f"Disarmed ({why})")

    @publishes
    def arm(self, force: bool = False) -> int:
        """Arm (``force``: whatever the pre-arm checks say); armed in AUTO_TAKEOFF on the ground, take off."""
        result = self._arm(force)
        if result == S.MAV_RESULT_ACCEPTED and self.armed and self.mode is Mode.AUTO_TAKEOFF and not self.in_air:
            return self._takeoff(None)
        return result

    @publishes
    def disarm(self, force: bool = False) -> int:
        """Disarm; refused in the air unless ``force``."""
        if not self.armed:
            return S.MAV_RESULT_ACCEPTED
        if self.in_air and not force:
            self.say(S.MAV_SEVERITY_CRITICAL, "Disarm denied: vehicle in air (land first or force)")
            return S.MAV_RESULT_DENIED
        self._disarm("command")
        return S.MAV_RESULT_ACCEPTED

    # -- modes ------------------------------------------------------------------------
    def _switch_mode(self, mode: Mode) -> None:
        """Change the mode (the caller has set its task): say so, and pause a mission that was flown."""
        if mode is not self.mode:
            self.say(S.MAV_SEVERITY_INFO, f"Mode {mode.label}")
            mission_control.on_mode_change(self.plans, self.mode, mode)
        self.mode = mode

    @publishes
    def set_mode(self, mode: Mode) -> int:
        """Switch to ``mode`` (SET_MODE, DO_SET_MODE): armed, its task starts now or the switch is refused;
        disarmed, an available mode is accepted and acts once armed, as in PX4."""
        if mode is self.mode:
            return S.MAV_RESULT_ACCEPTED
        if mode is Mode.AUTO_PRECLAND:  # as PX4's navigator: the mode itself requires the target
            self.precland_mode = PrecLandMode.REQUIRED
            return self._enter(mode)
        if self.armed or mode not in AVAILABLE:
            return self._enter(mode)  # starts the mode's task, or refuses with a reason
        if (why := self._input_refusal(mode)) is not None:
            self.say(S.MAV_SEVERITY_CRITICAL, f"Mode {mode.label} denied: {why}")
            return S.MAV_RESULT_DENIED
        self.mode = mode  # on the ground, disarmed: PX4 accepts the mode; it acts once armed
        self.task = None
        self.say(S.MAV_SEVERITY_INFO, f"Mode {mode.label}")
        return S.MAV_RESULT_ACCEPTED

    # -- status -------------------------------------------------------------------------
    def landed_state(self) -> LandedState:
        if not self.armed or self.land_detector.state is Landed.ON_GROUND:
            if self.armed and self.mode is Mode.AUTO_TAKEOFF and self.task is not None:
                return LandedState.TAKEOFF
            return LandedState.ON_GROUND
        if self.mode is Mode.AUTO_TAKEOFF:
            return LandedState.TAKEOFF
        if (
            self.mode is Mode.AUTO_LAND
            or getattr(self.task, "landing", False)
            or (self.mode is Mode.AUTO_RTL and getattr(getattr(self.task, "phase", None), "value", None) == "land")
        ):
            return LandedState.LANDING
        return LandedState.IN_AIR
