"""The command handler: ONE table from MAV_CMD to handler, for COMMAND_LONG and COMMAND_INT.

Every command a ground station may send is a row of :data:`COMMANDS`.  A row's handler
decodes MAVLink's units and conventions (degE7, altitude AMSL, NaN = "not given", the
force magic 21196, PX4's mode numbers) and calls a typed method either of the link
(message intervals, message requests: :class:`LinkCommands`) or of the commander
(:class:`CommanderCommands`: ``arm(force)``, ``takeoff(rel_alt_m)``, ``set_mode(mode)``,
...), and returns the MAV_RESULT for the COMMAND_ACK.  A command that is not in the
table gets MAV_RESULT_UNSUPPORTED.  Refusals are explained by the commander in a
STATUSTEXT (its event queue).

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

from autopilot.topics import CommanderStatus
from mavsim_core.px4_modes import Mode

FORCE_MAGIC = 21196  # param2 of MAV_CMD_COMPONENT_ARM_DISARM: arm or disarm whatever the checks say
INT32_MAX = 2**31 - 1  # COMMAND_INT x/y "not given"

_GLOBAL_FRAMES = frozenset({
    mavlink.MAV_FRAME_GLOBAL, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT, mavlink.MAV_FRAME_GLOBAL_INT,
    mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT,
    mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
})  # fmt: skip
_LOCAL_FRAMES = frozenset({
    mavlink.MAV_FRAME_LOCAL_NED, mavlink.MAV_FRAME_LOCAL_ENU, mavlink.MAV_FRAME_LOCAL_OFFSET_NED,
    mavlink.MAV_FRAME_BODY_NED, mavlink.MAV_FRAME_BODY_OFFSET_NED, mavlink.MAV_FRAME_BODY_FRD,
    mavlink.MAV_FRAME_LOCAL_FRD, mavlink.MAV_FRAME_LOCAL_FLU,
})  # fmt: skip


class LinkCommands(Protocol):
    """What the link does itself, on the endpoint the command came in on (each returns a MAV_RESULT)."""

    def set_message_interval(self, msg_id: int, interval_us: int) -> int:
        """-1 disables the stream, 0 restores its default interval, > 0 sets it (µs of simulated time)."""

    def request_message(self, msg_id: int, param2: float) -> int:
        """Send message ``msg_id`` once (``param2``: the index for PARAM_VALUE)."""

    def send_autopilot_version(self) -> int:
        """Send AUTOPILOT_VERSION."""


class CommanderCommands(Protocol):
    """The typed command methods of :class:`autopilot.commander.Commander` (each returns a MAV_RESULT)."""

    status: CommanderStatus

    def say(self, severity: int, text: str) -> None: ...
    def arm(self, force: bool = False) -> int: ...
    def disarm(self, force: bool = False) -> int: ...
    def takeoff(self, rel_alt_m: float | None = None) -> int: ...
    def land(self, precision: int = 0) -> int: ...
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


Params = tuple[float, ...]  # param1..param7; for COMMAND_INT x, y already in degrees (global frames) or m


@dataclass(frozen=True)
class Command:
    by: By
    handler: Callable[[Any, Params], int]  # (LinkCommands or CommanderCommands, params) -> MAV_RESULT


def int_param(x: float, default: int = 0) -> int:
    """A command parameter as an integer; NaN or infinite ("unused", as MAVSDK sends) gives default."""
    return int(x) if math.isfinite(x) else default


def given(x: float) -> float | None:
    """A float parameter, or None when not given (NaN, as MAVLink's commands mark it)."""
    return x if math.isfinite(x) else None


# --------------------------------------------------------------------------- decoding messages


def command_long_params(msg: mavlink.MAVLink_message) -> Params:
    """COMMAND_LONG's seven parameters, unchanged (positions: lat/lon degrees, altitude AMSL m)."""
    return (msg.param1, msg.param2, msg.param3, msg.param4, msg.param5, msg.param6, msg.param7)


def command_int_params(msg: mavlink.MAVLink_message) -> Params:
    """COMMAND_INT's parameters with x, y as floats: degE7 -> degrees in global frames, m * 1e4 -> m in
    local frames, INT32_MAX (both) = not given (NaN)."""
    if msg.x == INT32_MAX and msg.y == INT32_MAX:
        x = y = math.nan
    elif msg.frame in _GLOBAL_FRAMES:
        x, y = msg.x * 1e-7, msg.y * 1e-7
    elif msg.frame in _LOCAL_FRAMES:
        x, y = msg.x * 1e-4, msg.y * 1e-4
    else:
        x, y = float(msg.x), float(msg.y)
    return (msg.param1, msg.param2, msg.param3, msg.param4, x, y, msg.z)


# --------------------------------------------------------------------------- the link's commands


def _set_message_interval(link: LinkCommands, p: Params) -> int:
    """param1 message id, param2 interval µs (-1 disable, 0 default)."""
    if not (math.isfinite(p[0]) and math.isfinite(p[1])):
        return mavlink.MAV_RESULT_DENIED
    return link.set_message_interval(int(p[0]), int(round(p[1])))


def _request_message(link: LinkCommands, p: Params) -> int:
    """param1 message id, param2 its first parameter (PARAM_VALUE: the index)."""
    if not math.isfinite(p[0]):
        return mavlink.MAV_RESULT_DENIED
    return link.request_message(int(p[0]), p[1])


def _request_autopilot_capabilities(link: LinkCommands, p: Params) -> int:
    return link.send_autopilot_version()


# --------------------------------------------------------------------------- the vehicle's commands


def _deny(cmd: CommanderCommands, why: str) -> int:
    """Say why (STATUSTEXT, critical) and refuse."""
    cmd.say(mavlink.MAV_SEVERITY_CRITICAL, why)
    return mavlink.MAV_RESULT_DENIED


def _arm_disarm(cmd: CommanderCommands, p: Params) -> int:
    """param1 >= 0.5 arm, else disarm; param2 21196 forces either."""
    force = int_param(p[1]) == FORCE_MAGIC
    if p[0] >= 0.5:
        if cmd.terminated:  # DO_FLIGHTTERMINATION holds until a reboot, forced or not
            return _deny(cmd, "Arming denied: flight terminated (reboot to clear)")
        return cmd.arm(force)
    return cmd.disarm(force)


def _takeoff(cmd: CommanderCommands, p: Params) -> int:
    """param7 altitude AMSL (m); NaN: MIS_TAKEOFF_ALT; below home: read as metres above home (MAVProxy's
    ``takeoff 5`` sends 5)."""
    home = cmd.status.home
    alt = p[6]
    if home is None or not math.isfinite(alt):
        return cmd.takeoff(None)  # the default altitude, or refused for want of a home
    if alt < home.alt_amsl_m:
        cmd.say(mavlink.MAV_SEVERITY_INFO, f"Takeoff altitude {alt:g} m is below home: using {alt:g} m above home")
        return cmd.takeoff(alt)
    return cmd.takeoff(alt - home.alt_amsl_m)


def _land(cmd: CommanderCommands, p: Params) -> int:
    """param2: precision landing as PX4 (0 none, 1 opportunistic, 2 required); other values refused."""
    precision = p[1] if len(p) > 1 and math.isfinite(p[1]) else 0.0
    if precision not in (0.0, 1.0, 2.0):
        cmd.say(mavlink.MAV_SEVERITY_CRITICAL, f"Land denied: precision land mode {precision:g} unknown (0, 1, 2)")
        return mavlink.MAV_RESULT_DENIED
    return cmd.land(int(precision))


def _return_to_launch(cmd: CommanderCommands, p: Params) -> int:
    return cmd.return_to_launch()


def _do_set_mode(cmd: CommanderCommands, p: Params) -> int:
    """param1 base_mode, param2 PX4 main mode, param3 PX4 sub mode (as MAVSDK and MAVProxy send them)."""
    return handle_set_mode(cmd, int_param(p[0]), int_param(p[1]) << 16 | int_param(p[2]) << 24)


def _reposition(cmd: CommanderCommands, p: Params) -> int:
    """param1 ground speed m/s (<= 0 or NaN: the default), param4 yaw in RADIANS (NaN: keep the heading; as
    the MAVLink spec, PX4 and MAVSDK), param5/6 lat/lon deg (NaN or both 0: here), param7 altitude AMSL m
    (NaN: keep).  Infinite values are not "not given": refused."""
    if any(math.isinf(x) for x in (p[3], p[4], p[5], p[6])):
        return _deny(cmd, "Reposition denied: infinite position or yaw")
    speed = p[0] if math.isfinite(p[0]) and p[0] > 0 else None
    lat, lon = p[4], p[5]
    if not (math.isfinite(lat) and math.isfinite(lon)) or (lat == 0 and lon == 0):
        lat = lon = None
    return cmd.reposition(lat, lon, given(p[6]), given(p[3]), speed)


def _set_mission_current(cmd: CommanderCommands, p: Params) -> int:
    """param1 the item (-1 or NaN: keep), param2 1: reset the mission (DO_JUMP counters), as PX4."""
    status = cmd.status.mission
    seq = int_param(p[0], -1)
    reset = int_param(p[1]) == 1
    if seq == -1:
        seq = min(status.seq, max(status.total - 1, 0))
        if status.total == 0:
            cmd.say(mavlink.MAV_SEVERITY_CRITICAL, "Set current mission item denied: no mission")
            return mavlink.MAV_RESULT_DENIED
    done, why = cmd.set_mission_current(seq, reset)
    if not done:
        cmd.say(mavlink.MAV_SEVERITY_CRITICAL, f"Set current mission item denied: {why}")
    return mavlink.MAV_RESULT_ACCEPTED if done else mavlink.MAV_RESULT_DENIED


def _change_speed(cmd: CommanderCommands, p: Params) -> int:
    """param1 speed type (0 air, 1 ground: both the horizontal speed of a multicopter; 2 climb, 3 descent:
    not supported), param2 m/s (-1 or NaN: no change, -2: back to MPC_XY_CRUISE), param3 throttle (ignored)."""
    kind = int_param(p[0], 1)
    if kind not in (0, 1):
        return _deny(cmd, f"Change speed denied: speed type {kind} not supported (0, 1)")
    if not math.isfinite(p[1]) or p[1] == -1:
        return mavlink.MAV_RESULT_ACCEPTED  # no change
    if p[1] == -2:
        return cmd.change_speed(None)
    if p[1] <= 0:
        return _deny(cmd, f"Change speed denied: {p[1]:g} m/s is not a speed")
    return cmd.change_speed(p[1])


def _set_home(cmd: CommanderCommands, p: Params) -> int:
    """param1 1: the current position; else param5/6 lat/lon deg and param7 altitude AMSL m (all finite)."""
    if int_param(p[0]) == 1:
        return cmd.set_home(None, None, None)
    if not all(math.isfinite(x) for x in (p[4], p[5], p[6])):
        return _deny(cmd, "Set home denied: latitude, longitude and altitude required")
    return cmd.set_home(p[4], p[5], p[6])


def _get_home_position(link: LinkCommands, p: Params) -> int:
    """HOME_POSITION once (TEMPORARILY_REJECTED before home is set), as REQUEST_MESSAGE 242."""
    return link.request_message(mavlink.MAVLINK_MSG_ID_HOME_POSITION, 0.0)


def _condition_yaw(cmd: CommanderCommands, p: Params) -> int:
    """param1 angle deg (absolute from north, or relative), param2 rate deg/s (<= 0 or NaN: MPC_YAWRAUTO_MAX),
    param3 direction (-1 counter-clockwise, 0 shortest, 1 clockwise), param4 1 relative, 0 absolute."""
    if not math.isfinite(p[0]):
        return _deny(cmd, "Yaw denied: angle not given")
    rate = math.radians(p[1]) if math.isfinite(p[1]) and p[1] > 0 else None
    direction = max(-1, min(1, int_param(p[2])))
    return cmd.condition_yaw(math.radians(p[0]), rate, direction, int_param(p[3]) == 1)


def _pause_continue(cmd: CommanderCommands, p: Params) -> int:
    """param1 0: pause (hold here, AUTO.LOITER), 1: continue the mission."""
    action = int_param(p[0], -1)
    if action not in (0, 1):
        return _deny(cmd, "Pause/continue denied: param1 must be 0 (pause) or 1 (continue)")
    return cmd.pause_continue(action == 0)


def _flight_termination(cmd: CommanderCommands, p: Params) -> int:
    """param1 >= 0.5: motors off and disarmed, for good (until a reboot); below: nothing (accepted)."""
    if math.isfinite(p[0]) and p[0] >= 0.5:
        return cmd.terminate_flight()
    return mavlink.MAV_RESULT_ACCEPTED


def _preflight_storage(cmd: CommanderCommands, p: Params) -> int:
    """param1 0 read the saved parameters, 1 write, 2 and 4 reset to defaults, 3 sensors (none); param2 ignored."""
    return cmd.param_storage(int_param(p[0], -1))


def _reboot_shutdown(cmd: CommanderCommands, p: Params) -> int:
    """param1 0 nothing, 1 reboot (the flight controller's state restarts in place), 2 shutdown, 3 bootloader:
    not simulated; param2.. (companion computer, camera, mount) ignored: there are none."""
    action = int_param(p[0], 0)
    if action == 0:
        return mavlink.MAV_RESULT_ACCEPTED
    if action == 1:
        return cmd.reboot()
    what = {2: "shutdown", 3: "reboot to bootloader"}.get(action)
    if what is not None:
        cmd.say(mavlink.MAV_SEVERITY_CRITICAL, f"Reboot/shutdown: {what} not supported in simulation")
        return mavlink.MAV_RESULT_UNSUPPORTED
    return _deny(cmd, f"Reboot/shutdown denied: unknown action {action}")


def _motor_test(cmd: CommanderCommands, p: Params) -> int:
    """param1 motor (1-based), param2 throttle type (0 percent, 1 PWM µs 1000-2000), param3 the value,
    param4 timeout s, param5 motor count (0 or 1: one motor)."""
    kind = int_param(p[1], -1)
    value = p[2]
    if kind not in (mavlink.MOTOR_TEST_THROTTLE_PERCENT, mavlink.MOTOR_TEST_THROTTLE_PWM):
        cmd.say(mavlink.MAV_SEVERITY_CRITICAL, f"Motor test denied: throttle type {kind} not supported (0, 1)")
        return mavlink.MAV_RESULT_UNSUPPORTED
    if not (math.isfinite(value) and math.isfinite(p[3])):
        return _deny(cmd, "Motor test denied: throttle and timeout required")
    frac = value / 100.0 if kind == mavlink.MOTOR_TEST_THROTTLE_PERCENT else (value - 1000.0) / 1000.0
    return cmd.motor_test(int_param(p[0]), min(max(frac, 0.0), 1.0), max(p[3], 0.0), int_param(p[4]))


def _orbit(cmd: CommanderCommands, p: Params) -> int:
    """param1 radius m (sign: > 0 clockwise, < 0 counter-clockwise; NaN: keep/default), param2 speed m/s
    (NaN: keep/default), param3 ORBIT_YAW_BEHAVIOUR (NaN: MC_ORBIT_YAW_MOD), param5/6 centre lat/lon deg and
    param7 altitude AMSL m (NaN: here / the current orbit's)."""
    if any(math.isinf(x) for x in (p[0], p[1], p[4], p[5], p[6])):
        return _deny(cmd, "Orbit denied: infinite parameter")
    lat, lon = p[4], p[5]
    lat, lon = (None, None) if not (math.isfinite(lat) and math.isfinite(lon)) else (lat, lon)
    yaw = int_param(p[2], -1)
    return cmd.orbit(given(p[0]), given(p[1]), None if yaw < 0 else yaw, lat, lon, given(p[6]))


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
    mavlink.MAV_CMD_SET_MESSAGE_INTERVAL: Command(By.LINK, _set_message_interval),
    mavlink.MAV_CMD_REQUEST_MESSAGE: Command(By.LINK, _request_message),
    mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES: Command(By.LINK, _request_autopilot_capabilities),
    mavlink.MAV_CMD_COMPONENT_ARM_DISARM: Command(By.VEHICLE, _arm_disarm),
    mavlink.MAV_CMD_NAV_TAKEOFF: Command(By.VEHICLE, _takeoff),
    mavlink.MAV_CMD_NAV_LAND: Command(By.VEHICLE, _land),
    mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH: Command(By.VEHICLE, _return_to_launch),
    mavlink.MAV_CMD_DO_SET_MODE: Command(By.VEHICLE, _do_set_mode),
    mavlink.MAV_CMD_DO_REPOSITION: Command(By.VEHICLE, _reposition),
    mavlink.MAV_CMD_DO_SET_MISSION_CURRENT: Command(By.VEHICLE, _set_mission_current),
    mavlink.MAV_CMD_DO_CHANGE_SPEED: Command(By.VEHICLE, _change_speed),
    mavlink.MAV_CMD_DO_SET_HOME: Command(By.VEHICLE, _set_home),
    mavlink.MAV_CMD_GET_HOME_POSITION: Command(By.LINK, _get_home_position),
    mavlink.MAV_CMD_CONDITION_YAW: Command(By.VEHICLE, _condition_yaw),
    mavlink.MAV_CMD_DO_PAUSE_CONTINUE: Command(By.VEHICLE, _pause_continue),
    mavlink.MAV_CMD_DO_FLIGHTTERMINATION: Command(By.VEHICLE, _flight_termination),
    mavlink.MAV_CMD_PREFLIGHT_STORAGE: Command(By.VEHICLE, _preflight_storage),
    mavlink.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN: Command(By.VEHICLE, _reboot_shutdown),
    mavlink.MAV_CMD_DO_MOTOR_TEST: Command(By.VEHICLE, _motor_test),
    mavlink.MAV_CMD_DO_ORBIT: Command(By.VEHICLE, _orbit),
}


def run(command: int, params: Params, frame: int, link: LinkCommands, vehicle: Any) -> int:
    """The link's entry: its own rows here; every other command (known or not) goes to
    ``vehicle.handle_command(command, params, frame)`` (a VehicleInterface)."""
    row = COMMANDS.get(command)
    if row is not None and row.by is By.LINK:
        return int(row.handler(link, params))
    return int(vehicle.handle_command(command, params, frame))


def handle_vehicle_command(cmd: CommanderCommands, command: int, params: Params, frame: int) -> int:
    """The vehicle's entry: run a vehicle row on the commander; MAV_RESULT_UNSUPPORTED for anything else."""
    row = COMMANDS.get(command)
    if row is None or row.by is not By.VEHICLE:
        return mavlink.MAV_RESULT_UNSUPPORTED
    return int(row.handler(cmd, params))
