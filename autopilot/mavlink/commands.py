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

_GLOBAL_FRAMES = frozenset(
    {
        mavlink.MAV_FRAME_GLOBAL,
        mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT,
        mavlink.MAV_FRAME_GLOBAL_INT,
        mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
        mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT,
        mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
    }
)
_LOCAL_FRAMES = frozenset(
    {
        mavlink.MAV_FRAME_LOCAL_NED,
        mavlink.MAV_FRAME_LOCAL_ENU,
        mavlink.MAV_FRAME_LOCAL_OFFSET_NED,
        mavlink.MAV_FRAME_BODY_NED,
        mavlink.MAV_FRAME_BODY_OFFSET_NED,
        mavlink.MAV_FRAME_BODY_FRD,
        mavlink.MAV_FRAME_LOCAL_FRD,
        mavlink.MAV_FRAME_LOCAL_FLU,
    }
)


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


def _arm_disarm(cmd: CommanderCommands, p: Params) -> int:
    """param1 >= 0.5 arm, else disarm; param2 21196 forces either."""
    force = int_param(p[1]) == FORCE_MAGIC
    if p[0] >= 0.5:
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
    """param1 speed m/s (<= 0 or NaN: MPC_XY_CRUISE), param4 yaw deg (NaN: keep), param5/6 lat/lon deg
    (NaN or both 0: here), param7 altitude AMSL m (NaN: keep)."""
    speed = p[0] if math.isfinite(p[0]) and p[0] > 0 else None
    yaw = math.radians(p[3]) if math.isfinite(p[3]) else None
    lat, lon = p[4], p[5]
    if not (math.isfinite(lat) and math.isfinite(lon)) or (lat == 0 and lon == 0):
        lat = lon = None
    return cmd.reposition(lat, lon, given(p[6]), yaw, speed)


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
