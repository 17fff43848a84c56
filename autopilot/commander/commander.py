"""Commander: arming, modes, commands and the flight task that is active.

Implements :class:`autopilot.vehicle_interface.VehicleInterface` for the
ground-station link.  Every refusal says why in a STATUSTEXT.  Time is the
simulated time of the latest sensor sample; nothing here reads a clock.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np
from pymavlink.dialects.v20 import common as mavlink

from autopilot.control.position_control import PositionSetpoint
from mavsim_core.geodesy import geodetic_to_ned, ned_to_geodetic
from autopilot.land_detector import LandDetector, Landed
from mavsim_core.px4_modes import Mode
from autopilot.navigator import LandTask, MoveTask, ReturnTask
from autopilot.parameters import ParamDef, ParameterStore, ParamType, param
from autopilot.topics import (BatteryState, ControlSetpoints, GpsSample, HomePosition, LandedState, TelemetrySnapshot,
                              VehicleEstimate)


# The parameters this module reads (listed in autopilot/param_catalogue.py).
PARAMS: tuple[ParamDef, ...] = (
    param("COM_DISARM_LAND", 2.0, -1.0, 20.0, "s", "Disarm this long after landing (-1: never)"),
    param("COM_DISARM_PRFLT", 10.0, -1.0, 60.0, "s", "Disarm this long after arming if no take-off (-1: never)"),
    param("COM_ARM_TILT_MAX", 10.0, 1.0, 60.0, "deg", "Maximum tilt to allow arming (vehicle level check)"),
    param("SYS_AUTOSTART", 4001, 1, 99999, "", "Airframe id (4001 quadcopter X, 6001 hexacopter)", ParamType.INT32, True),
)

# Modes this flight controller can fly today (no RC input yet: POSCTL holds position).
AVAILABLE = {Mode.POSCTL, Mode.AUTO_TAKEOFF, Mode.AUTO_LOITER, Mode.AUTO_RTL, Mode.AUTO_LAND}

S = mavlink  # MAV_RESULT_*, MAV_SEVERITY_*, MAV_CMD_* constants
FORCE_MAGIC = 21196
SENSORS_PRESENT = (
    S.MAV_SYS_STATUS_SENSOR_3D_GYRO | S.MAV_SYS_STATUS_SENSOR_3D_ACCEL | S.MAV_SYS_STATUS_SENSOR_3D_MAG
    | S.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE | S.MAV_SYS_STATUS_SENSOR_GPS
    | S.MAV_SYS_STATUS_SENSOR_ANGULAR_RATE_CONTROL | S.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION
    | S.MAV_SYS_STATUS_SENSOR_YAW_POSITION | S.MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL
    | S.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL | S.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
    | S.MAV_SYS_STATUS_AHRS | S.MAV_SYS_STATUS_SENSOR_BATTERY | S.MAV_SYS_STATUS_PREARM_CHECK
)
MAV_TYPES = {"QUADROTOR": S.MAV_TYPE_QUADROTOR, "HEXAROTOR": S.MAV_TYPE_HEXAROTOR, "OCTOROTOR": S.MAV_TYPE_OCTOROTOR}


def _int_param(x: float, default: int = 0) -> int:
    """A command parameter as an integer; NaN or infinite ("unused", as MAVSDK sends) gives default."""
    return int(x) if math.isfinite(x) else default


class Commander:
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
        self.land = LandDetector(params)
        self.task = None
        self.events: list[tuple[int, str]] = []
        self.throttle_frac = 0.0
        self.thrust_frac_of_hover = 0.0
        self.motor_outputs: tuple[float, ...] = ()
        self.setpoint: PositionSetpoint | None = None
        # Telemetry of the controllers' setpoints (set by the FlightController that owns this commander).
        self.control_setpoints: Callable[[], ControlSetpoints | None] | None = None
        self.estimator = None  # autopilot.estimation.estimator.Estimator, set by the FlightController
        self._reset_count = 0

    # -- events ---------------------------------------------------------------------
    def say(self, severity: int, text: str) -> None:
        self.events.append((severity, text))

    def pop_events(self) -> list[tuple[int, str]]:
        out, self.events = self.events, []
        return out

    # -- checks ---------------------------------------------------------------------
    def prearm_failures(self) -> list[str]:
        e = self.est
        out = []
        if e is None or not e.attitude_valid:
            out.append("attitude estimate not ready")
        if self.gps is None or self.gps.fix_type < 3:
            out.append("no 3D GPS fix")
        if e is None or not e.position_valid:
            out.append("position estimate not ready")
        if self.estimator is not None and self.estimator.use_ekf:
            out.extend(self.estimator.prearm_failures())
        if self.home is None:
            out.append("home position not set")
        if e is not None and e.attitude_valid:
            tilt = math.degrees(math.acos(max(-1.0, min(1.0, math.cos(e.roll_rad) * math.cos(e.pitch_rad)))))
            if tilt > self.params.get("COM_ARM_TILT_MAX"):
                out.append(f"vehicle not level ({tilt:.0f} deg)")
        if 0 <= self.battery.remaining_frac < 0.15:
            out.append(f"battery low ({self.battery.remaining_frac:.0%})")
        return out

    @property
    def in_air(self) -> bool:
        return self.land.state is Landed.IN_AIR

    # -- periodic -----------------------------------------------------------------------
    def update(self, now_us: int, est: VehicleEstimate, gps: GpsSample | None, gps_ok: bool) -> PositionSetpoint | None:
        """Advance the state machines; return the position setpoint, or None for motors idle/off."""
        self.now_us, self.est, self.gps_ok = now_us, est, gps_ok
        if gps is not None:
            self.gps = gps
        if self.home is None and est.position_valid:
            self._set_home(est)  # first valid position; set again at arming, as PX4 does
        if est.reset_count != self._reset_count:
            self._follow_reset(est)
        before = self.land.state
        state = self.land.update(now_us, self.armed, est.vel_ned_m_s, float(est.pos_ned_m[2]), self.thrust_frac_of_hover)
        if state is not before and self.armed:
            self.say(S.MAV_SEVERITY_INFO, "Takeoff detected" if state is Landed.IN_AIR else "Landing detected")
            if state is Landed.ON_GROUND and self.mode in (Mode.AUTO_LAND, Mode.AUTO_RTL):
                self.task = None
        if self.armed:
            self._auto_disarm(now_us)
        if self.armed and self.in_air and not est.position_valid and self.mode is not Mode.AUTO_LAND:
            self.say(S.MAV_SEVERITY_CRITICAL, "Position estimate lost: landing")
            self._enter(Mode.AUTO_LAND)
        if self.armed and self.mode is Mode.AUTO_TAKEOFF and isinstance(self.task, MoveTask) and self.task.arrived(now_us, est):
            goal = self.task.goal
            self.say(S.MAV_SEVERITY_INFO, "Takeoff complete: holding")
            self.mode = Mode.AUTO_LOITER
            self.task = MoveTask(goal, goal, self.task.yaw_rad, now_us, 1.0, 1.0)
        if not self.armed or self.task is None:
            self.setpoint = None
            return None
        if not self.in_air and self.mode is not Mode.AUTO_TAKEOFF:
            self.setpoint = None
            return None
        self.setpoint = self.task.setpoint(now_us, est)
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

    def _auto_disarm(self, now_us: int) -> None:
        p = self.params
        if self.land.state is Landed.ON_GROUND:
            since = self.land.landed_since_us
            limit = p.get("COM_DISARM_LAND")
            if since is not None and since > self.armed_at_us and limit >= 0 and now_us - since >= limit * 1e6:
                self._disarm("landed")
            elif (since is not None and since <= self.armed_at_us and p.get("COM_DISARM_PRFLT") >= 0
                  and self.mode is not Mode.AUTO_TAKEOFF and now_us - self.armed_at_us >= p.get("COM_DISARM_PRFLT") * 1e6):
                self._disarm("no takeoff")

    def _set_home(self, est: VehicleEstimate) -> None:
        lat, lon, alt = ned_to_geodetic(est.pos_ned_m, est.origin_lat_deg, est.origin_lon_deg, est.origin_alt_amsl_m)
        first = self.home is None
        self.home = HomePosition(lat, lon, alt, est.pos_ned_m.copy(), est.yaw_rad)
        if first:
            self.say(S.MAV_SEVERITY_INFO, f"Home set: {lat:.7f}, {lon:.7f}, {alt:.1f} m")

    # -- arming -----------------------------------------------------------------------
    def _arm(self, force: bool) -> int:
        if self.armed:
            return S.MAV_RESULT_ACCEPTED
        fails = self.prearm_failures()
        if fails and not force:
            self.say(S.MAV_SEVERITY_CRITICAL, "Arming denied: " + "; ".join(fails))
            return S.MAV_RESULT_DENIED
        if self.est is None:
            self.say(S.MAV_SEVERITY_CRITICAL, "Arming denied: no sensor data")
            return S.MAV_RESULT_DENIED
        if self.est.position_valid:
            self._set_home(self.est)
        self.armed = True
        self.armed_at_us = self.now_us
        self.land.on_arm(float(self.est.pos_ned_m[2]))
        self.land.landed_since_us = self.now_us
        self.task = None
        if self.mode not in (Mode.AUTO_TAKEOFF, Mode.POSCTL):
            self.mode = Mode.AUTO_LOITER
        self.say(S.MAV_SEVERITY_INFO, "Armed")
        return S.MAV_RESULT_ACCEPTED

    def _disarm(self, why: str) -> None:
        self.armed = False
        self.task = None
        self.say(S.MAV_SEVERITY_INFO, f"Disarmed ({why})")

    def _cmd_arm(self, p: tuple[float, ...]) -> int:
        force = _int_param(p[1]) == FORCE_MAGIC
        if p[0] >= 0.5:
            return self._arm(force)
        if not self.armed:
            return S.MAV_RESULT_ACCEPTED
        if self.in_air and not force:
            self.say(S.MAV_SEVERITY_CRITICAL, "Disarm denied: vehicle in air (land first or force)")
            return S.MAV_RESULT_DENIED
        self._disarm("command")
        return S.MAV_RESULT_ACCEPTED

    # -- modes ------------------------------------------------------------------------
    def _hold_here(self) -> MoveTask:
        e = self.est
        return MoveTask(e.pos_ned_m, e.pos_ned_m, e.yaw_rad, self.now_us, 1.0, 1.0)

    def _enter(self, mode: Mode, takeoff_down_m: float | None = None) -> int:
        """Switch mode and start its task; refuse (with a reason) if it cannot run now."""
        e = self.est
        if mode not in AVAILABLE:
            self.say(S.MAV_SEVERITY_CRITICAL, f"Mode {mode.label} not available on this vehicle")
            return S.MAV_RESULT_DENIED
        if e is None or not (e.position_valid or (mode is Mode.AUTO_LAND and e.height_valid)):
            self.say(S.MAV_SEVERITY_CRITICAL, f"Mode {mode.label} denied: no position estimate")
            return S.MAV_RESULT_DENIED
        if mode is Mode.AUTO_RTL and self.home is None:
            self.say(S.MAV_SEVERITY_CRITICAL, "Return denied: no home position")
            return S.MAV_RESULT_DENIED
        if mode is Mode.AUTO_TAKEOFF:
            if not self.armed:
                self.say(S.MAV_SEVERITY_CRITICAL, "Takeoff denied: vehicle not armed")
                return S.MAV_RESULT_DENIED
            if self.in_air:
                self.say(S.MAV_SEVERITY_CRITICAL, "Takeoff denied: already flying")
                return S.MAV_RESULT_DENIED
            if takeoff_down_m is None:
                takeoff_down_m = self.home.pos_ned_m[2] - self.params.get("MIS_TAKEOFF_ALT")
            goal = np.array([e.pos_ned_m[0], e.pos_ned_m[1], takeoff_down_m])
            self.task = MoveTask(e.pos_ned_m, goal, e.yaw_rad, self.now_us, self.params.get("MPC_TKO_SPEED"), 1.0)
            self.say(S.MAV_SEVERITY_INFO, f"Taking off to {self.home.pos_ned_m[2] - takeoff_down_m:.1f} m above home")
        elif mode in (Mode.AUTO_LOITER, Mode.POSCTL):
            if mode is not self.mode or self.task is None:
                self.task = self._hold_here()
        elif mode is Mode.AUTO_LAND:
            self.task = LandTask(e.pos_ned_m[:2], e.yaw_rad, self.home.pos_ned_m[2] if self.home else e.pos_ned_m[2], self.params)
        elif mode is Mode.AUTO_RTL:
            self.task = ReturnTask(self.now_us, e, self.home.pos_ned_m, self.params)
        if mode is not self.mode:
            self.say(S.MAV_SEVERITY_INFO, f"Mode {mode.label}")
        self.mode = mode
        return S.MAV_RESULT_ACCEPTED

    def handle_set_mode(self, base_mode: int, custom_mode: int) -> int:
        if not base_mode & S.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            self.say(S.MAV_SEVERITY_CRITICAL, "Mode change denied: only custom (PX4) modes are supported")
            return S.MAV_RESULT_DENIED
        mode = Mode.from_custom_mode(custom_mode)
        if mode is None:
            self.say(S.MAV_SEVERITY_CRITICAL, f"Mode change denied: unknown custom mode {custom_mode:#x}")
            return S.MAV_RESULT_DENIED
        if mode is self.mode:
            return S.MAV_RESULT_ACCEPTED
        if self.armed or mode not in AVAILABLE:
            return self._enter(mode)  # starts the mode's task, or refuses with a reason
        self.mode = mode  # on the ground, disarmed: PX4 accepts the mode; it acts once armed
        self.task = None
        self.say(S.MAV_SEVERITY_INFO, f"Mode {mode.label}")
        return S.MAV_RESULT_ACCEPTED

    # -- commands -----------------------------------------------------------------------
    def handle_command(self, command: int, p: tuple[float, ...], frame: int) -> int:
        if command == S.MAV_CMD_COMPONENT_ARM_DISARM:
            result = self._cmd_arm(p)
            if result == S.MAV_RESULT_ACCEPTED and self.armed and self.mode is Mode.AUTO_TAKEOFF and not self.in_air:
                return self._takeoff((0,) * 6 + (math.nan,))
            return result
        if command == S.MAV_CMD_NAV_TAKEOFF:
            return self._takeoff(p)
        if command == S.MAV_CMD_NAV_LAND:
            if not self.armed:
                self.say(S.MAV_SEVERITY_CRITICAL, "Land denied: vehicle not armed")
                return S.MAV_RESULT_DENIED
            return self._enter(Mode.AUTO_LAND)
        if command == S.MAV_CMD_NAV_RETURN_TO_LAUNCH:
            if not self.armed:
                self.say(S.MAV_SEVERITY_CRITICAL, "Return denied: vehicle not armed")
                return S.MAV_RESULT_DENIED
            return self._enter(Mode.AUTO_RTL)
        if command == S.MAV_CMD_DO_SET_MODE:
            return self.handle_set_mode(_int_param(p[0]), _int_param(p[1]) << 16 | _int_param(p[2]) << 24)
        if command == S.MAV_CMD_DO_REPOSITION:
            return self._reposition(p)
        return S.MAV_RESULT_UNSUPPORTED

    def _takeoff(self, p: tuple[float, ...]) -> int:
        if self.home is None or self.est is None:
            self.say(S.MAV_SEVERITY_CRITICAL, "Takeoff denied: no home position")
            return S.MAV_RESULT_DENIED
        alt = p[6]
        home_alt = self.home.alt_amsl_m
        if not math.isfinite(alt):
            rel = self.params.get("MIS_TAKEOFF_ALT")
        elif alt < home_alt:
            # MAVProxy's "takeoff 5" sends 5: a value below home is read as metres above home.
            rel = alt
            self.say(S.MAV_SEVERITY_INFO, f"Takeoff altitude {alt:g} m is below home: using {alt:g} m above home")
        else:
            rel = alt - home_alt
        rel = max(rel, 1.0)
        return self._enter(Mode.AUTO_TAKEOFF, self.home.pos_ned_m[2] - rel)

    def _reposition(self, p: tuple[float, ...]) -> int:
        e = self.est
        if not (self.armed and self.in_air) or e is None:
            self.say(S.MAV_SEVERITY_CRITICAL, "Reposition denied: vehicle not flying")
            return S.MAV_RESULT_DENIED
        if not e.position_valid:
            self.say(S.MAV_SEVERITY_CRITICAL, "Reposition denied: no position estimate")
            return S.MAV_RESULT_DENIED
        lat, lon, alt = p[4], p[5], p[6]
        if not (math.isfinite(lat) and math.isfinite(lon)) or (lat == 0 and lon == 0):
            goal = e.pos_ned_m.copy()
        else:
            if abs(lat) > 90 or abs(lon) > 180:
                self.say(S.MAV_SEVERITY_CRITICAL, "Reposition denied: latitude/longitude out of range")
                return S.MAV_RESULT_DENIED
            goal = geodetic_to_ned(lat, lon, 0.0, e.origin_lat_deg, e.origin_lon_deg, 0.0)
            goal[2] = e.pos_ned_m[2]
        if math.isfinite(alt):
            goal[2] = e.origin_alt_amsl_m - alt
        if np.linalg.norm(goal - e.pos_ned_m) > 1000.0:
            self.say(S.MAV_SEVERITY_CRITICAL, "Reposition denied: target more than 1 km away")
            return S.MAV_RESULT_DENIED
        yaw = e.yaw_rad if not math.isfinite(p[3]) else math.radians(p[3])
        speed = p[0] if math.isfinite(p[0]) and p[0] > 0 else self.params.get("MPC_XY_CRUISE")
        start = self.setpoint.pos_ned_m if self.setpoint is not None and np.all(np.isfinite(self.setpoint.pos_ned_m)) else e.pos_ned_m
        if self.mode is not Mode.AUTO_LOITER:
            self.say(S.MAV_SEVERITY_INFO, "Mode AUTO.LOITER")
        self.mode = Mode.AUTO_LOITER
        self.task = MoveTask(start, goal, yaw, self.now_us, speed, self.params.get("MPC_ACC_HOR"))
        return S.MAV_RESULT_ACCEPTED

    # -- telemetry --------------------------------------------------------------------
    def landed_state(self) -> LandedState:
        if not self.armed or self.land.state is Landed.ON_GROUND:
            if self.armed and self.mode is Mode.AUTO_TAKEOFF and self.task is not None:
                return LandedState.TAKEOFF
            return LandedState.ON_GROUND
        if self.mode is Mode.AUTO_TAKEOFF:
            return LandedState.TAKEOFF
        if self.mode is Mode.AUTO_LAND or (self.mode is Mode.AUTO_RTL and getattr(self.task, "phase", None) and
                                           self.task.phase.value == "land"):
            return LandedState.LANDING
        return LandedState.IN_AIR

    def snapshot(self) -> TelemetrySnapshot:
        e = self.est
        health = SENSORS_PRESENT
        if e is None or not e.attitude_valid:
            health &= ~(S.MAV_SYS_STATUS_AHRS | S.MAV_SYS_STATUS_SENSOR_3D_GYRO | S.MAV_SYS_STATUS_SENSOR_3D_ACCEL)
        if not self.gps_ok:
            health &= ~S.MAV_SYS_STATUS_SENSOR_GPS
        if e is None or not e.position_valid:
            health &= ~S.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL
        est_status = None
        if self.estimator is not None:
            est_status = self.estimator.status()
            if est_status.mag_fault:
                health &= ~S.MAV_SYS_STATUS_SENSOR_3D_MAG
            if est_status.gps_glitch:
                health &= ~S.MAV_SYS_STATUS_SENSOR_GPS
            if self.estimator.use_ekf and not est_status.flags & 1:
                health &= ~S.MAV_SYS_STATUS_AHRS
        prearm_ok = not self.armed and not self.prearm_failures()
        if not prearm_ok and not self.armed:
            health &= ~S.MAV_SYS_STATUS_PREARM_CHECK
        if e is None:
            status = S.MAV_STATE_BOOT
        elif self.armed:
            status = S.MAV_STATE_ACTIVE
        else:
            status = S.MAV_STATE_STANDBY
        return TelemetrySnapshot(
            timestamp_us=self.now_us, mav_type=self.mav_type, armed=self.armed,
            base_mode=self.mode.base_mode_flags(self.armed), custom_mode=self.mode.custom_mode,
            system_status=status, landed_state=self.landed_state(), estimate=e, gps=self.gps, home=self.home,
            battery=self.battery, throttle_frac=self.throttle_frac, sensors_present=SENSORS_PRESENT,
            sensors_enabled=SENSORS_PRESENT, sensors_health=health, prearm_ok=prearm_ok or self.armed,
            position_setpoint_ned_m=None if self.setpoint is None else self.setpoint.pos_ned_m,
            motor_outputs=self.motor_outputs,
            control=self.control_setpoints() if self.control_setpoints is not None else None,
            estimator_status=est_status,
        )
