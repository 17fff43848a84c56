"""The command handler: ONE table from MAV_CMD to handler, for COMMAND_LONG and COMMAND_INT.

Every command a ground station may send is a row of :data:`COMMANDS`.  A row's handler
decodes MAVLink's units and conventions (degE7, altitude AMSL, NaN = "not given", the
force magic 21196, PX4's mode numbers) and calls a typed method either of the link
(message intervals, message requests: :class:`LinkCommands`) or of the commander
(:class:`CommanderCommands`: ``arm(force)``, ``takeoff(rel_alt_m)``, ``set_mode(mode)``,
...), and returns the MAV_RESULT for the COMMAND_ACK.  A command that is not in the
table gets MAV_RESULT_UNSUPPORTED.  Refusals are explained by the commander in a
STATUSTEXT (its event queue).

Every field a row reads is checked (:mod:`autopilot.mavlink.command_fields`: NaN is "not
given", an infinity anywhere, a value outside its range or enumeration, a MAV_BOOL other
than 0 or 1 are refused with MAV_RESULT_DENIED and a STATUSTEXT naming the field) before
anything changes; a COMMAND_INT's frame decides what its altitude means (AMSL, or above home).

Two entry points share the table: the link runs its own rows (:func:`run`) and hands
the others to the vehicle (``VehicleInterface.handle_command``), whose flight
controller implementation runs the vehicle rows (:func:`handle_vehicle_command`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import Enum
from typing import Any, Callable, Protocol

from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink import command_fields as f
from autopilot.mavlink.autotune_command import handle_autotune
from autopilot.mavlink.command_fields import FieldError, Params, command_int_params, command_long_params
from autopilot.topics import CommanderStatus
from mavsim_core.px4_modes import Mode

__all__ = ["COMMANDS", "FORCE_MAGIC", "command_int_params", "command_long_params", "handle_vehicle_command", "run"]

FORCE_MAGIC = 21196  # param2 of MAV_CMD_COMPONENT_ARM_DISARM: arm or disarm whatever the checks say
INTERVAL_MAX_US = 2**31 - 1  # MESSAGE_INTERVAL.interval_us is an int32
# Commands with a global position in param5..7: COMMAND_INT frames are read by command_fields.to_amsl
LOCATION_COMMANDS = frozenset({
    mavlink.MAV_CMD_NAV_TAKEOFF, mavlink.MAV_CMD_NAV_LAND, mavlink.MAV_CMD_DO_REPOSITION,
    mavlink.MAV_CMD_DO_SET_HOME, mavlink.MAV_CMD_DO_ORBIT,
})  # fmt: skip


class LinkCommands(Protocol):
    """What the link does itself, on the endpoint the command came in on (each returns a MAV_RESULT)."""

    def set_message_interval(self, msg_id: int, interval_us: int) -> int:
        """-1 disables the stream, 0 restores its default interval, > 0 sets it (µs of simulated time)."""

    def request_message(self, msg_id: int, param2: float) -> int:
        """Send message ``msg_id`` once (``param2``: the index for PARAM_VALUE)."""

    def send_autopilot_version(self) -> int:
        """Send AUTOPILOT_VERSION."""

    def say(self, severity: int, text: str) -> None: ...  # a STATUSTEXT to the endpoint the command came in on


class CommanderCommands(Protocol):
    """The typed command methods of :class:`autopilot.commander.Commander` (each returns a MAV_RESULT)."""

    status: CommanderStatus

    def say(self, severity: int, text: str) -> None: ...
    def arm(self, force: bool = False) -> int: ...
    def disarm(self, force: bool = False) -> int: ...
    def takeoff(self, rel_alt_m: float | None = None) -> int: ...
    def land(self, precision: int = 0) -> int: ...
    def land_start(self) -> int: ...
    def return_to_launch(self) -> int: ...
    def set_mode(self, mode: Mode) -> int: ...
    def set_mission_current(self, seq: int, reset_jumps: bool = False) -> tuple[bool, str]: ...
    def reposition(
        self,
        lat_deg: float | None,
        lon_deg: float | None,
        alt_amsl_m: float | None,
        yaw_rad: float | None,
        speed_m_s: float | None,
    ) -> int: ...

    # autopilot.commander.vehicle_commands.VehicleCommands
    terminated: bool

    def change_speed(self, speed_m_s: float | None) -> int: ...
    def set_home(self, lat_deg: float | None, lon_deg: float | None, alt_amsl_m: float | None) -> int: ...
    def condition_yaw(self, angle_rad: float, rate_rad_s: float | None, direction: int, relative: bool) -> int: ...
    def pause_continue(self, pause: bool) -> int: ...
    def terminate_flight(self) -> int: ...
    def param_storage(self, action: int) -> int: ...
    def reboot(self) -> int: ...
    def motor_test(self, motor: int, frac: float, timeout_s: float, count: int) -> int: ...
    def orbit(self, radius_m: float | None, speed_m_s: float | None, yaw_behaviour: int | None,
              lat_deg: float | None, lon_deg: float | None, alt_amsl_m: float | None) -> int: ...  # fmt: skip


class By(Enum):
    """Who runs a command: the link itself, or the vehicle (commander)."""

    LINK = "link"
    VEHICLE = "vehicle"


@dataclass(frozen=True)
class Command:
    by: By
    handler: Callable[[Any, Params], int]  # (LinkCommands or CommanderCommands, params) -> MAV_RESULT
    label: str  # what a refusal's STATUSTEXT calls it: "<label> denied: <why>"


# --------------------------------------------------------------------------- the link's commands


def _set_message_interval(link: LinkCommands, p: Params) -> int:
    """param1 message id, param2 interval µs (-1 disable, 0 default, > 0 up to INT32_MAX)."""
    msg_id = f.message_id(p[0])
    interval = f.required(p[1], "param2 (interval)")
    if not (interval in (-1.0, 0.0) or 0 < interval <= INTERVAL_MAX_US):
        raise FieldError(f"param2 (interval) {interval:g} µs is not -1, 0 or 1..{INTERVAL_MAX_US}")
    return link.set_message_interval(msg_id, int(round(interval)))


def _request_message(link: LinkCommands, p: Params) -> int:
    """param1 message id, param2 its first parameter (PARAM_VALUE: the index; checked by the message)."""
    return link.request_message(f.message_id(p[0]), p[1])


def _request_autopilot_capabilities(link: LinkCommands, p: Params) -> int:
    return link.send_autopilot_version()


# --------------------------------------------------------------------------- the vehicle's commands


def _deny(cmd: CommanderCommands, why: str) -> int:
    """Say why (STATUSTEXT, critical) and refuse."""
    cmd.say(mavlink.MAV_SEVERITY_CRITICAL, why)
    return mavlink.MAV_RESULT_DENIED


def _arm_disarm(cmd: CommanderCommands, p: Params) -> int:
    """param1 1 arm, 0 disarm (nothing else: the MAVLink spec); param2 0 (or NaN) checked, 21196 forced."""
    arm = f.flag(p[0], "param1 (arm)")
    force = f.choice(p[1], "param2 (force)", (0, FORCE_MAGIC), nan=0) == FORCE_MAGIC
    if arm:
        if cmd.terminated:  # DO_FLIGHTTERMINATION holds until a reboot, forced or not
            return _deny(cmd, "Arming denied: flight terminated (reboot to clear)")
        return cmd.arm(force)
    return cmd.disarm(force)


def _takeoff(cmd: CommanderCommands, p: Params) -> int:
    """param7 altitude AMSL (m); NaN: MIS_TAKEOFF_ALT; below home: read as metres above home (MAVProxy's
    ``takeoff 5`` sends 5).  The commander refuses altitudes above its ceiling (GF_MAX_VER_DIST)."""
    home = cmd.status.home
    alt = f.optional(p[6], "param7 (altitude)")
    if home is None or alt is None:
        return cmd.takeoff(None)  # the default altitude, or refused for want of a home
    if 0 <= alt < home.alt_amsl_m:
        cmd.say(mavlink.MAV_SEVERITY_INFO, f"Takeoff altitude {alt:g} m is below home: using {alt:g} m above home")
        return cmd.takeoff(alt)
    return cmd.takeoff(alt - home.alt_amsl_m)


def _land(cmd: CommanderCommands, p: Params) -> int:
    """param2: precision landing as PX4 (0 or NaN none, 1 opportunistic, 2 required); param5/6: NaN (or both 0)
    only: the vehicle lands where it is (fly there first with DO_REPOSITION)."""
    precision = f.choice(p[1], "param2 (precision land mode)", (0, 1, 2), nan=0)
    if f.lat_lon(p[4], p[5], zero_is_here=True) is not None:
        raise FieldError("landing at a given latitude/longitude is not supported (NaN: here)")
    return cmd.land(precision)


def _return_to_launch(cmd: CommanderCommands, p: Params) -> int:
    return cmd.return_to_launch()


def _do_set_mode(cmd: CommanderCommands, p: Params) -> int:
    """param1 base_mode, param2 PX4 main mode, param3 PX4 sub mode (NaN: 0), as MAVSDK and MAVProxy send them."""
    base = f.whole(p[0], "param1 (base mode)", 0, 255)
    main = f.whole(p[1], "param2 (custom main mode)", 0, 255)
    sub = f.whole(p[2], "param3 (custom sub mode)", 0, 255, nan=0)
    return handle_set_mode(cmd, base, main << 16 | sub << 24)


def _reposition(cmd: CommanderCommands, p: Params) -> int:
    """param1 ground speed m/s (<= 0 or NaN: the default), param4 yaw in RADIANS (NaN: keep the heading; as
    the MAVLink spec, PX4 and MAVSDK), param5/6 lat/lon deg (NaN or both 0: here), param7 altitude AMSL m
    (NaN: keep)."""
    speed = f.optional(p[0], "param1 (ground speed)")
    yaw = f.yaw_rad(p[3])
    here = f.lat_lon(p[4], p[5], zero_is_here=True)
    lat, lon = here if here is not None else (None, None)
    alt = f.optional(p[6], "param7 (altitude)")
    return cmd.reposition(lat, lon, alt, yaw, speed if speed is not None and speed > 0 else None)


def _set_mission_current(cmd: CommanderCommands, p: Params) -> int:
    """param1 the item (-1 or NaN: keep), param2 1: reset the mission (DO_JUMP counters), as PX4."""
    status = cmd.status.mission
    seq = f.whole(p[0], "param1 (item)", -1, 65535, nan=-1)
    reset = f.flag(p[1], "param2 (reset)", nan=False)
    if seq == -1:
        seq = min(status.seq, max(status.total - 1, 0))
        if status.total == 0:
            return _deny(cmd, "Set current mission item denied: no mission")
    done, why = cmd.set_mission_current(seq, reset)
    if not done:
        cmd.say(mavlink.MAV_SEVERITY_CRITICAL, f"Set current mission item denied: {why}")
    return mavlink.MAV_RESULT_ACCEPTED if done else mavlink.MAV_RESULT_DENIED


def _change_speed(cmd: CommanderCommands, p: Params) -> int:
    """param1 speed type (0 air, 1 ground, NaN: ground; both the horizontal speed of a multicopter; 2 climb,
    3 descent: not supported), param2 m/s (-1 or NaN: no change, -2: back to MPC_XY_CRUISE), param3 throttle
    (ignored)."""
    kind = f.choice(p[0], "param1 (speed type)", (0, 1, 2, 3), nan=1)
    if kind not in (0, 1):
        return _deny(cmd, f"Change speed denied: speed type {kind} not supported (0, 1)")
    speed = f.optional(p[1], "param2 (speed)")
    if speed is None or speed == -1:
        return mavlink.MAV_RESULT_ACCEPTED  # no change
    if speed == -2:
        return cmd.change_speed(None)
    if speed <= 0:
        return _deny(cmd, f"Change speed denied: {speed:g} m/s is not a speed")
    return cmd.change_speed(speed)


def _set_home(cmd: CommanderCommands, p: Params) -> int:
    """param1 1: the current position; 0: param5/6 lat/lon deg and param7 altitude AMSL m (all given)."""
    if f.flag(p[0], "param1 (use current location)"):
        return cmd.set_home(None, None, None)
    where = f.lat_lon(p[4], p[5])
    alt = f.optional(p[6], "param7 (altitude)")
    if where is None or alt is None:
        return _deny(cmd, "Set home denied: latitude, longitude and altitude required")
    return cmd.set_home(where[0], where[1], alt)


def _get_home_position(link: LinkCommands, p: Params) -> int:
    """HOME_POSITION once, as REQUEST_MESSAGE 242; before home is set TEMPORARILY_REJECTED, and a STATUSTEXT why."""
    result = link.request_message(mavlink.MAVLINK_MSG_ID_HOME_POSITION, 0.0)
    if result == mavlink.MAV_RESULT_TEMPORARILY_REJECTED:
        link.say(mavlink.MAV_SEVERITY_WARNING, "Home position not set: waiting for a position fix")
    return result


def _condition_yaw(cmd: CommanderCommands, p: Params) -> int:
    """param1 angle deg (absolute from north, or relative; -360..360), param2 rate deg/s (<= 0 or NaN:
    MPC_YAWRAUTO_MAX), param3 direction (-1 counter-clockwise, 0 or NaN shortest, 1 clockwise), param4 1
    relative, 0 (or NaN) absolute."""
    angle = f.within(p[0], "param1 (angle)", -360.0, 360.0)
    rate = f.optional(p[1], "param2 (rate)")
    direction = f.choice(p[2], "param3 (direction)", (-1, 0, 1), nan=0)
    relative = f.flag(p[3], "param4 (relative)", nan=False)
    rate_rad_s = math.radians(rate) if rate is not None and rate > 0 else None
    return cmd.condition_yaw(math.radians(angle), rate_rad_s, direction, relative)


def _pause_continue(cmd: CommanderCommands, p: Params) -> int:
    """param1 0: pause (hold here, AUTO.LOITER), 1: continue the mission."""
    return cmd.pause_continue(not f.flag(p[0], "param1 (continue)"))


def _flight_termination(cmd: CommanderCommands, p: Params) -> int:
    """param1 > 0.5: motors off and disarmed, for good (until a reboot); NaN or below: nothing (accepted)."""
    value = f.optional(p[0], "param1 (terminate)")
    if value is not None and value > 0.5:
        return cmd.terminate_flight()
    return mavlink.MAV_RESULT_ACCEPTED


def _preflight_storage(cmd: CommanderCommands, p: Params) -> int:
    """param1 0 read the saved parameters, 1 write, 2 and 4 reset to defaults, 3 sensors (none); param2 ignored."""
    return cmd.param_storage(f.whole(p[0], "param1 (parameter storage action)", 0, 4))


def _reboot_shutdown(cmd: CommanderCommands, p: Params) -> int:
    """param1 0 (or NaN) nothing, 1 reboot (the flight controller's state restarts in place), 2 shutdown, 3
    bootloader: not simulated; param2.. (companion computer, camera, mount) ignored: there are none."""
    action = f.whole(p[0], "param1 (autopilot action)", 0, 3, nan=0)
    if action == 0:
        return mavlink.MAV_RESULT_ACCEPTED
    if action == 1:
        return cmd.reboot()
    what = {2: "shutdown", 3: "reboot to bootloader"}[action]
    cmd.say(mavlink.MAV_SEVERITY_CRITICAL, f"Reboot/shutdown: {what} not supported in simulation")
    return mavlink.MAV_RESULT_UNSUPPORTED


def _motor_test(cmd: CommanderCommands, p: Params) -> int:
    """param1 motor (1-based), param2 throttle type (0 percent 0-100, 1 PWM µs 1000-2000; 2 pilot and 3 compass
    calibration: not supported), param3 the value, param4 timeout s (>= 0), param5 motor count (0, 1 or NaN:
    one motor)."""
    motor = f.whole(p[0], "param1 (motor)", 1, 255)
    kind = f.choice(p[1], "param2 (throttle type)", (0, 1, 2, 3))
    if kind not in (mavlink.MOTOR_TEST_THROTTLE_PERCENT, mavlink.MOTOR_TEST_THROTTLE_PWM):
        cmd.say(mavlink.MAV_SEVERITY_CRITICAL, f"Motor test denied: throttle type {kind} not supported (0, 1)")
        return mavlink.MAV_RESULT_UNSUPPORTED
    if kind == mavlink.MOTOR_TEST_THROTTLE_PERCENT:
        frac = f.within(p[2], "param3 (throttle %)", 0.0, 100.0) / 100.0
    else:
        frac = (f.within(p[2], "param3 (throttle PWM)", 1000.0, 2000.0) - 1000.0) / 1000.0
    timeout_s = f.within(p[3], "param4 (timeout)", 0.0, math.inf)
    return cmd.motor_test(motor, frac, timeout_s, f.whole(p[4], "param5 (motor count)", 0, 255, nan=0))


def _orbit(cmd: CommanderCommands, p: Params) -> int:
    """param1 radius m (sign: > 0 clockwise, < 0 counter-clockwise; NaN: keep/default), param2 speed m/s >= 0
    (NaN: keep/default), param3 ORBIT_YAW_BEHAVIOUR 0..5 (NaN or 5: MC_ORBIT_YAW_MOD / unchanged), param4 NaN
    or 0 (orbit for ever: a given angle is not supported), param5/6 centre lat/lon deg and param7 altitude
    AMSL m (NaN: here / the current orbit's)."""
    radius = f.optional(p[0], "param1 (radius)")
    speed = f.optional(p[1], "param2 (speed)")
    if speed is not None and speed < 0:
        raise FieldError(f"param2 (speed) {speed:g} m/s is negative")
    yaw = f.whole(p[2], "param3 (yaw behaviour)", 0, 5, nan=5)
    if f.optional(p[3], "param4 (orbits)") not in (None, 0.0):
        raise FieldError("orbiting a given angle is not supported (param4 NaN or 0: for ever)")
    centre = f.lat_lon(p[4], p[5])
    lat, lon = centre if centre is not None else (None, None)
    return cmd.orbit(radius, speed, None if yaw == 5 else yaw, lat, lon, f.optional(p[6], "param7 (altitude)"))


def handle_set_mode(cmd: CommanderCommands, base_mode: int, custom_mode: int) -> int:
    """SET_MODE / MAV_CMD_DO_SET_MODE: PX4's custom_mode (main << 16 | sub << 24) to a mode; a MAV_RESULT."""
    if not base_mode & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
        cmd.say(mavlink.MAV_SEVERITY_CRITICAL, "Mode change denied: only custom (PX4) modes are supported")
        return mavlink.MAV_RESULT_DENIED
    mode = Mode.from_custom_mode(custom_mode)
    if mode is None:
        cmd.say(mavlink.MAV_SEVERITY_CRITICAL, f"Mode change denied: unknown custom mode {custom_mode:#x}")
        return mavlink.MAV_RESULT_DENIED
    return cmd.set_mode(mode)


# --------------------------------------------------------------------------- the table

COMMANDS: dict[int, Command] = {
    mavlink.MAV_CMD_SET_MESSAGE_INTERVAL: Command(By.LINK, _set_message_interval, "Set message interval"),
    mavlink.MAV_CMD_REQUEST_MESSAGE: Command(By.LINK, _request_message, "Request message"),
    mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: Command(By.LINK, _request_autopilot_capabilities, "Capabilities"),
    mavlink.MAV_CMD_COMPONENT_ARM_DISARM: Command(By.VEHICLE, _arm_disarm, "Arming"),
    mavlink.MAV_CMD_NAV_TAKEOFF: Command(By.VEHICLE, _takeoff, "Takeoff"),
    mavlink.MAV_CMD_NAV_LAND: Command(By.VEHICLE, _land, "Land"),
    mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH: Command(By.VEHICLE, _return_to_launch, "Return"),
    mavlink.MAV_CMD_DO_LAND_START: Command(By.VEHICLE, lambda cmd, p: cmd.land_start(), "Mission landing"),
    mavlink.MAV_CMD_DO_SET_MODE: Command(By.VEHICLE, _do_set_mode, "Mode change"),
    mavlink.MAV_CMD_DO_REPOSITION: Command(By.VEHICLE, _reposition, "Reposition"),
    mavlink.MAV_CMD_DO_SET_MISSION_CURRENT: Command(By.VEHICLE, _set_mission_current, "Set current mission item"),
    mavlink.MAV_CMD_DO_CHANGE_SPEED: Command(By.VEHICLE, _change_speed, "Change speed"),
    mavlink.MAV_CMD_DO_SET_HOME: Command(By.VEHICLE, _set_home, "Set home"),
    mavlink.MAV_CMD_GET_HOME_POSITION: Command(By.LINK, _get_home_position, "Get home position"),
    mavlink.MAV_CMD_CONDITION_YAW: Command(By.VEHICLE, _condition_yaw, "Yaw"),
    mavlink.MAV_CMD_DO_PAUSE_CONTINUE: Command(By.VEHICLE, _pause_continue, "Pause/continue"),
    mavlink.MAV_CMD_DO_FLIGHTTERMINATION: Command(By.VEHICLE, _flight_termination, "Flight termination"),
    mavlink.MAV_CMD_PREFLIGHT_STORAGE: Command(By.VEHICLE, _preflight_storage, "Parameter storage"),
    mavlink.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN: Command(By.VEHICLE, _reboot_shutdown, "Reboot/shutdown"),
    mavlink.MAV_CMD_DO_MOTOR_TEST: Command(By.VEHICLE, _motor_test, "Motor test"),
    mavlink.MAV_CMD_DO_ORBIT: Command(By.VEHICLE, _orbit, "Orbit"),
    mavlink.MAV_CMD_DO_AUTOTUNE_ENABLE: Command(By.VEHICLE, handle_autotune, "Autotune"),  # autotune_command.py
}


def run(command: int, params: Params, frame: int, link: LinkCommands, vehicle: Any) -> int:
    """The link's entry: its own rows here (a bad field: MAV_RESULT_DENIED); every other command (known or not)
    goes to ``vehicle.handle_command(command, params, frame)`` (a VehicleInterface)."""
    row = COMMANDS.get(command)
    if row is not None and row.by is By.LINK:
        try:
            f.no_infinity(params)
            return int(row.handler(link, params))
        except FieldError:
            return mavlink.MAV_RESULT_DENIED
    return int(vehicle.handle_command(command, params, frame))


def handle_vehicle_command(cmd: CommanderCommands, command: int, params: Params, frame: int) -> int:
    """The vehicle's entry: run a vehicle row on the commander; MAV_RESULT_UNSUPPORTED for anything else.  A
    field the row cannot accept (:mod:`autopilot.mavlink.command_fields`): MAV_RESULT_DENIED, and a STATUSTEXT
    naming it; nothing changes."""
    row = COMMANDS.get(command)
    if row is None or row.by is not By.VEHICLE:
        return mavlink.MAV_RESULT_UNSUPPORTED
    try:
        f.no_infinity(params)
        if command in LOCATION_COMMANDS:
            home = cmd.status.home
            params = f.to_amsl(params, frame, home.alt_amsl_m if home is not None else None)
        return int(row.handler(cmd, params))
    except FieldError as exc:
        return _deny(cmd, f"{row.label} denied: {exc}")
