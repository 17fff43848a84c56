"""The commander's remaining vehicle commands: speed, home, yaw, pause/continue, termination, parameter
storage, reboot, motor test and orbit.

:class:`VehicleCommands` is a base class of :class:`autopilot.commander.commander.Commander`; its
methods are what the MAVLink command table (:mod:`autopilot.mavlink.commands`) calls for
DO_CHANGE_SPEED, DO_SET_HOME, CONDITION_YAW, DO_PAUSE_CONTINUE, DO_FLIGHTTERMINATION,
PREFLIGHT_STORAGE, PREFLIGHT_REBOOT_SHUTDOWN, DO_MOTOR_TEST and DO_ORBIT.  Each returns a
MAV_RESULT, says why in a STATUSTEXT when it refuses, and (:func:`publishes`) has the commander
publish its status afterwards.  The flight controller reads :meth:`VehicleCommands.motor_test_output`
while disarmed.

Positions are NED metres from the estimator origin; altitudes AMSL; yaw in radians, rates rad/s;
speeds m/s; time the commander's simulated µs.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Any, NamedTuple

import numpy as np
from pymavlink.dialects.v20 import common as S

from autopilot.commander.commander_state import CommanderState
from autopilot.commander.flight_commands import (
    REPOSITION_MAX_M,
    above_ceiling,
    flown_position_setpoint,
    point_ned,
    publishes,
)
from autopilot.navigation import GotoTask, LoiterTask, started
from autopilot.navigation.geofence import stop_point
from autopilot.navigation.mission import MissionTask
from autopilot.navigation.mission_leg import Leg, path_speed
from autopilot.navigation.orbit import (
    ORBIT_DEFAULT_RADIUS_M,
    ORBIT_DEFAULT_SPEED_M_S,
    ORBIT_RADIUS_MIN_M,
    OrbitTask,
    orbit_speed_limit,
)
from autopilot.navigation.yaw_turn import YawTurn, turn_angle
from autopilot.parameters import ParamError
from mavsim_core import mission_items as mi
from mavsim_core.px4_modes import Mode

if TYPE_CHECKING:
    from autopilot.control.position_control import PositionSetpoint
    from autopilot.topics import AttitudeSetpoint, VehicleEstimate

MOTOR_TEST_TIMEOUT_MAX_S = 3.0  # a motor test never runs longer than this
ROTORS = {S.MAV_TYPE_QUADROTOR: 4, S.MAV_TYPE_HEXAROTOR: 6, S.MAV_TYPE_OCTOROTOR: 8}
# What a reboot keeps: the stored plans, the latest outside inputs, the vehicle's constants, the latest
# readings of the devices that do not reboot with it (GPS receiver, battery) and the parameter storage.
# Everything else starts again as at power-on.
KEPT_OVER_REBOOT = (
    "plans", "inputs", "hover_thrust_frac", "feet_below_m", "battery", "gps", "wall_s", "param_saver",
)  # fmt: skip


# The airframes by name (the process's --vehicle) and their MAV_TYPE.
MAV_TYPES = {"QUADROTOR": S.MAV_TYPE_QUADROTOR, "HEXAROTOR": S.MAV_TYPE_HEXAROTOR, "OCTOROTOR": S.MAV_TYPE_OCTOROTOR}


class MotorTest(NamedTuple):
    motor: int  # 0-based
    frac: float  # motor command 0..1
    until_us: int  # simulated µs


class VehicleCommands(CommanderState):
    """Speed, home, yaw, pause/continue, termination, storage, reboot, motor test and orbit, as methods of the
    :class:`Commander`."""

    # Set here (class defaults; a reboot puts them back) ...
    terminated: bool = False  # DO_FLIGHTTERMINATION: arming refused until a reboot
    motor_test_run: MotorTest | None = None
    reboot_pending: bool = False  # the flight controller restarts the estimator and controllers, then clears it
    param_saver: Any = None  # autopilot.param_storage.ParamSaver with --state-dir (set by the process), or None
    # ... and the commander's state these methods read and set (Commander.__init__, FlightCommands).
    mav_type: int
    setpoint: PositionSetpoint | AttitudeSetpoint | None
    cruise_override_m_s: float | None

    if TYPE_CHECKING:

        def set_mode(self, mode: Mode) -> int: ...

    def _deny(self, why: str) -> int:
        self.say(S.MAV_SEVERITY_CRITICAL, why)
        return S.MAV_RESULT_DENIED

    def _flying_estimate(self, what: str) -> tuple[VehicleEstimate | None, str]:
        """The estimate when flying with a position, else (None, why not)."""
        e = self.est
        if not (self.armed and self.in_air) or e is None:
            return None, f"{what} denied: vehicle not flying"
        if not e.position_valid:
            return None, f"{what} denied: no position estimate"
        return e, ""

    def _setpoint_or(self, e: VehicleEstimate) -> tuple[np.ndarray, float]:
        """The position and yaw being flown (the latest setpoint where finite, else the estimate)."""
        sp = flown_position_setpoint(self.setpoint)
        pos = sp.pos_ned_m if sp is not None and np.all(np.isfinite(sp.pos_ned_m)) else e.pos_ned_m
        yaw = sp.yaw_rad if sp is not None and math.isfinite(sp.yaw_rad) else e.yaw_rad
        return pos.astype(float).copy(), float(yaw)

    # -- DO_CHANGE_SPEED ----------------------------------------------------------------
    @publishes
    def change_speed(self, speed_m_s: float | None) -> int:
        """The horizontal speed (at most MPC_XY_VEL_MAX) of the current go-to, mission or orbit and of later
        repositions (None: back to MPC_XY_CRUISE)."""
        limit = self.params.get("MPC_XY_VEL_MAX")
        if speed_m_s is not None and speed_m_s > limit:
            self.say(S.MAV_SEVERITY_INFO, f"Speed {speed_m_s:g} m/s limited to MPC_XY_VEL_MAX")
            speed_m_s = limit
        self.cruise_override_m_s = speed_m_s
        speed = speed_m_s if speed_m_s is not None else self.params.get("MPC_XY_CRUISE")
        inner = getattr(self.task, "inner", self.task)
        if isinstance(inner, GotoTask) and self.est is not None and not inner.finished(self.now_us):
            goto = self._goto_at_new_speed(inner, speed, self.est)
            if inner is self.task:
                self.task = goto
            else:  # a turn in place (CONDITION_YAW) goes on, around the go-to at its new speed
                self.task.inner = goto
        elif isinstance(inner, MissionTask):
            inner.cruise = speed
            self._mission_leg_at_new_speed(inner, speed)
        elif isinstance(inner, OrbitTask):
            inner.set_speed(speed)
        self.say(S.MAV_SEVERITY_INFO, f"Speed set to {speed:.1f} m/s")
        return S.MAV_RESULT_ACCEPTED

    def _goto_at_new_speed(self, old: GotoTask, speed: float, e: VehicleEstimate) -> GotoTask:
        """The rest of ``old`` at ``speed``, on from the setpoint's position, velocity and acceleration."""
        pos, _ = self._setpoint_or(e)
        sp = flown_position_setpoint(self.setpoint)
        vel = sp.vel_ned_m_s if sp is not None else None
        acc = sp.acc_ned_m_s2 if sp is not None else None
        accel, jerk = self.params.get("MPC_ACC_HOR"), self.params.get("MPC_JERK_AUTO")
        turns = old.heading.limits  # (the heading on from the vehicle's, at the same rate and acceleration)
        return started(GotoTask(old.goal, old.yaw_rad, speed, accel, pos, jerk, vel, acc, turns), e, self.now_us)

    def _mission_leg_at_new_speed(self, task: MissionTask, speed: float) -> None:
        """The rest of the mission leg being flown (not a take-off's climb) at ``speed``, from its setpoint at
        its present speed (or ``speed`` if slower)."""
        leg, item = task.leg, task.pending
        if leg is None or item is None or item.command == mi.NAV_TAKEOFF or leg.finished(self.now_us):
            return
        s, v, _ = leg.profile((self.now_us - leg.t0_us) * 1e-6)
        up, down = 0.7 * self.params.get("MPC_Z_VEL_MAX_UP"), 0.7 * self.params.get("MPC_Z_VEL_MAX_DN")
        cruise = path_speed(leg.dir, speed, up, down)
        start, v_out = leg.start + leg.dir * s, min(leg.v_out, cruise)
        task.leg = Leg(start, leg.end, v, v_out, cruise, leg.a, self.now_us, leg.jerk)

    # -- DO_SET_HOME ---------------------------------------------------------------------
    @publishes
    def set_home(self, lat_deg: float | None, lon_deg: float | None, alt_amsl_m: float | None) -> int:
        """Home here (None) or at the given point, at most REPOSITION_MAX_M from the vehicle (a return goes
        there)."""
        e = self.est
        if e is None or not e.position_valid:
            return self._deny("Set home denied: no position estimate")
        if lat_deg is None or lon_deg is None or alt_amsl_m is None:
            self._set_home_at(e.pos_ned_m)
            return S.MAV_RESULT_ACCEPTED
        home = point_ned(e, lat_deg, lon_deg, alt_amsl_m, e.pos_ned_m)
        if home is None:
            return self._deny("Set home denied: latitude/longitude out of range")
        if np.linalg.norm(home - e.pos_ned_m) > REPOSITION_MAX_M:
            return self._deny(f"Set home denied: more than {REPOSITION_MAX_M / 1000:g} km from the vehicle")
        self._set_home_at(home)
        return S.MAV_RESULT_ACCEPTED

    # -- CONDITION_YAW -------------------------------------------------------------------
    @publishes
    def condition_yaw(self, angle_rad: float, rate_rad_s: float | None, direction: int, relative: bool) -> int:
        """Turn in place while holding or going to a point: to ``angle_rad`` from north, or by it (``relative``;
        direction -1 turns the other way), at ``rate_rad_s`` (None: MPC_YAWRAUTO_MAX; at most MC_YAWRATE_MAX)."""
        e, why = self._flying_estimate("Yaw")
        if e is None:
            return self._deny(why)
        inner = getattr(self.task, "inner", self.task)
        if self.mode is not Mode.AUTO_LOITER or not isinstance(inner, (LoiterTask, GotoTask)):
            return self._deny("Yaw denied: only while holding or going to a point (AUTO.LOITER)")
        _, start = self._setpoint_or(e)
        if relative:
            turn = -abs(angle_rad) if direction < 0 else angle_rad
        else:
            turn = turn_angle(start, angle_rad, direction)
        default, limit = (math.radians(self.params.get(n)) for n in ("MPC_YAWRAUTO_MAX", "MC_YAWRATE_MAX"))
        rate = min(rate_rad_s, limit) if rate_rad_s is not None else default
        acc = math.radians(self.params.get("MPC_YAWRAUTO_ACC"))  # speeds up and slows down to stop on the heading
        self.task = started(YawTurn(inner, start, turn, rate, acc), e, self.now_us)
        return S.MAV_RESULT_ACCEPTED

    # -- DO_PAUSE_CONTINUE ---------------------------------------------------------------
    @publishes
    def pause_continue(self, pause: bool) -> int:
        """Pause: brake and hold there (AUTO.LOITER; a mission pauses at its item).  Continue: the mission."""
        if not pause:
            if not self.armed:
                return self._deny("Continue denied: vehicle not armed")
            if not self.plans.items[mi.MISSION]:
                return self._deny("Continue denied: no mission uploaded")
            return self.set_mode(Mode.AUTO_MISSION)
        e, why = self._flying_estimate("Pause")
        if e is None:
            return self._deny(why)
        pos, yaw = self._setpoint_or(e)
        v = e.vel_ned_m_s.copy()
        v[2] = 0.0
        stop = np.array(stop_point(tuple(e.pos_ned_m), v, self.params.get("MPC_ACC_HOR"), 0.0))
        stop[2] = pos[2]
        self.task = started(LoiterTask(stop, yaw), e, self.now_us)
        self._switch_mode(Mode.AUTO_LOITER)
        self.say(S.MAV_SEVERITY_INFO, "Paused: holding position")
        return S.MAV_RESULT_ACCEPTED

    # -- DO_FLIGHTTERMINATION ------------------------------------------------------------
    @publishes
    def terminate_flight(self) -> int:
        """Motors off and disarmed, wherever the vehicle is; arming is refused until a reboot."""
        self.terminated = True
        self.motor_test_run = None
        if self.armed:
            self._disarm("flight termination")
        self.say(S.MAV_SEVERITY_EMERGENCY, "Flight terminated: motors off until reboot")
        return S.MAV_RESULT_ACCEPTED

    # -- PREFLIGHT_STORAGE ---------------------------------------------------------------
    @publishes
    def param_storage(self, action: int) -> int:
        """0 read the saved parameters (defaults + the saved file), 1 save them now, 2 and 4 reset to the
        defaults (saved like any change), 3 sensor calibration (there is none to reset).  All but the save:
        disarmed only (the values flown would change under the controllers)."""
        if action not in range(5):
            return self._deny(f"Parameter storage denied: unknown action {action}")
        if self.armed and action != 1:
            return self._deny("Parameter storage denied: vehicle armed")
        if action in (2, 4):
            n = self._reset_parameters()
            self.say(S.MAV_SEVERITY_INFO, f"Parameters reset to defaults ({n} changed)")
            return S.MAV_RESULT_ACCEPTED
        if action == 3:
            self.say(S.MAV_SEVERITY_INFO, "No sensor calibration to reset")
            return S.MAV_RESULT_ACCEPTED
        saver = self.param_saver
        if saver is None:
            return self._deny("Parameter storage denied: parameters are not saved (no --state-dir)")
        if action == 1:
            if not saver.save():
                self.say(S.MAV_SEVERITY_CRITICAL, f"Parameters could not be saved to {saver.path}")
                return S.MAV_RESULT_FAILED
            self.say(S.MAV_SEVERITY_INFO, "Parameters saved")
            return S.MAV_RESULT_ACCEPTED
        from autopilot.param_storage import apply_entries
        from params.param_file import ParamFileError, read_param_file

        try:  # read before the reset: the saver writes the reset values to that file soon after
            entries = read_param_file(saver.path).entries if saver.path.exists() else []
        except ParamFileError as exc:
            self.say(S.MAV_SEVERITY_CRITICAL, f"Parameter storage: {exc}")
            return S.MAV_RESULT_FAILED
        self._reset_parameters()
        applied, problems = apply_entries(self.params, entries)
        for problem in problems[:3]:
            self.say(S.MAV_SEVERITY_WARNING, f"Parameter storage: {problem}")
        self.say(S.MAV_SEVERITY_INFO, f"Parameters read from storage ({applied} saved values)")
        return S.MAV_RESULT_ACCEPTED

    def _reset_parameters(self) -> int:
        """Every parameter back to its default (in passes, so cross-parameter rules hold); how many changed."""
        store, n = self.params, 0
        pending = list(store.changed())
        for _ in range(3):
            failed = []
            for name in pending:
                try:
                    store.set(name, store.default(name))
                    n += 1
                except ParamError:
                    failed.append(name)
            if not failed:
                break
            pending = failed
        return n

    # -- PREFLIGHT_REBOOT_SHUTDOWN -------------------------------------------------------
    @publishes
    def reboot(self) -> int:
        """Restart the commander's state in place as at power-on (disarmed only): parameters and plans kept;
        home, mode and failsafes start again; the flight controller then restarts the estimator and the
        controllers (:attr:`reboot_pending`)."""
        if self.armed:
            return self._deny("Reboot denied: vehicle armed (disarm first)")
        kept = {k: self.__dict__[k] for k in KEPT_OVER_REBOOT if k in self.__dict__}
        name = next((k for k, v in MAV_TYPES.items() if v == self.mav_type), "QUADROTOR")
        for attr in ("terminated", "motor_test_run", "cruise_override_m_s"):
            self.__dict__.pop(attr, None)  # back to the class defaults
        type(self).__init__(self, self.params, name)  # type: ignore[call-arg]  # (the commander's own __init__)
        self.__dict__.update(kept)
        self.reboot_pending = True
        self.say(S.MAV_SEVERITY_INFO, "Rebooted: flight controller restarted, parameters kept")
        return S.MAV_RESULT_ACCEPTED

    # -- DO_MOTOR_TEST -------------------------------------------------------------------
    @publishes
    def motor_test(self, motor: int, frac: float, timeout_s: float, count: int) -> int:
        """Spin ``motor`` (1-based) at ``frac`` (0..1) for ``timeout_s`` (at most MOTOR_TEST_TIMEOUT_MAX_S);
        disarmed on the ground only; one motor at a time; 0 throttle or timeout stops the test."""
        n = ROTORS.get(self.mav_type, 4)
        if self.armed:
            return self._deny("Motor test denied: vehicle armed")
        if self.in_air or self.terminated:
            return self._deny("Motor test denied: " + ("vehicle in air" if self.in_air else "flight terminated"))
        if count > 1:
            return self._deny("Motor test denied: one motor at a time (motor count 0 or 1)")
        if not 1 <= motor <= n:
            return self._deny(f"Motor test denied: motor {motor} not in 1..{n}")
        timeout_s = min(timeout_s, MOTOR_TEST_TIMEOUT_MAX_S)
        if frac <= 0.0 or timeout_s <= 0.0:
            self.motor_test_run = None
            return S.MAV_RESULT_ACCEPTED
        self.motor_test_run = MotorTest(motor - 1, frac, self.now_us + int(timeout_s * 1e6))
        self.say(S.MAV_SEVERITY_INFO, f"Motor test: motor {motor} at {frac * 100:.0f}% for {timeout_s:g} s")
        return S.MAV_RESULT_ACCEPTED

    def motor_test_output(self, now_us: int, n: int) -> np.ndarray | None:
        """The motor commands (0..1) of a running motor test at ``now_us``, or None (none, ended, or armed)."""
        run = self.motor_test_run
        if run is None or self.armed or now_us >= run.until_us:
            if run is not None and now_us >= run.until_us:
                self.motor_test_run = None
            return None
        out = np.zeros(n)
        if run.motor < n:
            out[run.motor] = run.frac
        return out

    # -- DO_ORBIT ------------------------------------------------------------------------
    @publishes
    def orbit(
        self,
        radius_m: float | None,
        speed_m_s: float | None,
        yaw_behaviour: int | None,
        lat_deg: float | None,
        lon_deg: float | None,
        alt_amsl_m: float | None,
    ) -> int:
        """Circle a centre (None: here, or the current orbit's) at ``radius_m`` (> 0 clockwise; None: the current
        orbit's or ORBIT_DEFAULT_RADIUS_M) and ``speed_m_s`` (None: the current or 1 m/s), in PX4's orbit mode
        (POSCTL main mode, ORBIT sub-mode)."""
        e, why = self._flying_estimate("Orbit")
        if e is None:
            return self._deny(why)
        now = self.task if isinstance(self.task, OrbitTask) else None
        centre = point_ned(e, lat_deg, lon_deg, alt_amsl_m, now.centre if now is not None else e.pos_ned_m)
        if centre is None:
            return self._deny("Orbit denied: latitude/longitude out of range")
        radius = radius_m if radius_m is not None else (now.radius_m if now else ORBIT_DEFAULT_RADIUS_M)
        if not ORBIT_RADIUS_MIN_M <= abs(radius) <= self.params.get("MC_ORBIT_RAD_MAX"):
            limit = self.params.get("MC_ORBIT_RAD_MAX")
            return self._deny(f"Orbit denied: radius {abs(radius):g} m outside {ORBIT_RADIUS_MIN_M:g}..{limit:g} m")
        if np.linalg.norm(centre[:2] - e.pos_ned_m[:2]) > REPOSITION_MAX_M:
            return self._deny("Orbit denied: centre more than 1 km away")
        if self.home is not None and (too_high := above_ceiling(self.params, self.home.pos_ned_m[2] - centre[2])):
            return self._deny(f"Orbit denied: {too_high}")
        speed = abs(speed_m_s) if speed_m_s is not None else (now.speed_m_s if now else ORBIT_DEFAULT_SPEED_M_S)
        limit = orbit_speed_limit(radius, self.params.get("MPC_ACC_HOR"))
        if speed > limit:
            self.say(S.MAV_SEVERITY_INFO, f"Orbit speed limited to {limit:.1f} m/s (radius {abs(radius):g} m)")
        if yaw_behaviour is None or yaw_behaviour > 4:  # 5: unchanged
            yaw_behaviour = now.yaw_behaviour if now else int(self.params.get("MC_ORBIT_YAW_MOD"))
        task = started(OrbitTask(centre, radius, speed, yaw_behaviour, self.params), e, self.now_us)
        if now is not None and now.direction == task.direction:
            task.v_t = min(now.v_t, task.speed_m_s)  # a changed orbit goes on without stopping
        self.task = task
        self._switch_mode(Mode.POSCTL_ORBIT)
        self.say(S.MAV_SEVERITY_INFO, f"Orbit: radius {abs(radius):g} m at {task.speed_m_s:.1f} m/s")
        return S.MAV_RESULT_ACCEPTED
