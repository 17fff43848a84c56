"""Ground-station side of the flight controller: MAVLink over UDP, as PX4 SITL does it.

Two UDP endpoints, offset by the instance number like PX4's ``-i``:

* "gcs": bound to 0.0.0.0:(local_gcs_port + i), telemetry to 127.0.0.1:(gcs_port + i)
  (QGroundControl listens on 14550);
* "api": bound to 0.0.0.0:(local_api_port + i), telemetry to 127.0.0.1:(api_port + i)
  (MAVSDK listens on 14540).

Whoever talks to an endpoint becomes (also) a destination of it, so replies reach
clients on any port.  The link has no flight logic: telemetry comes from
:meth:`VehicleInterface.snapshot`, commands and mode changes go to the vehicle,
parameters live in ``vehicle.params``.  The link serves the parameter protocol,
message-interval commands, AUTOPILOT_VERSION, TIMESYNC and an empty mission.

What one :meth:`GcsLink.update` sends to a destination goes out packed into as few
datagrams as fit MAX_DATAGRAM_BYTES, as PX4's UDP links buffer theirs: one system
call per update instead of one per message.  Replies outside an update go out at once.

Time: :meth:`GcsLink.update` receives the SIMULATED time (lockstep, microseconds).
Stream intervals are measured in it; this module never reads the wall clock.

Units: SI and radians inside (``TelemetrySnapshot``); degE7, mm, cm/s, centidegrees
and mV only where messages are encoded or decoded.
"""

from __future__ import annotations

import logging
import math
import struct
from dataclasses import dataclass
from typing import Callable

from pymavlink.dialects.v20 import common as mavlink

from mavsim_core.geodesy import ned_to_geodetic
from mavsim_core.quaternion import to_euler
from autopilot.parameters import ParamError, ParamType
from autopilot.topics import TelemetrySnapshot
from mavsim_core.mavlink_udp import UdpEndpoint
from mavsim_core.statustext import StatustextChunker
from autopilot.mavlink.vehicle_interface import VehicleInterface
from mavsim_core.param_encoding import decode_param_bytes, encode_param_bytes, raw_param_value

log = logging.getLogger(__name__)


UINT16_MAX = 65535
INT16_MAX = 32767
INT32_MAX = 2**31 - 1

# Telemetry streams sent on every endpoint, rate in Hz of simulated time.
DEFAULT_STREAM_RATES_HZ: dict[int, float] = {
    mavlink.MAVLINK_MSG_ID_HEARTBEAT: 1.0,
    mavlink.MAVLINK_MSG_ID_SYS_STATUS: 1.0,
    mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: 1.0,
    mavlink.MAVLINK_MSG_ID_ATTITUDE: 20.0,
    mavlink.MAVLINK_MSG_ID_ATTITUDE_QUATERNION: 10.0,
    mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 5.0,
    mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED: 5.0,
    mavlink.MAVLINK_MSG_ID_GPS_RAW_INT: 2.0,
    mavlink.MAVLINK_MSG_ID_VFR_HUD: 4.0,
    mavlink.MAVLINK_MSG_ID_HOME_POSITION: 0.5,
    mavlink.MAVLINK_MSG_ID_BATTERY_STATUS: 0.5,
    # setpoint against actual while tuning: ATTITUDE_TARGET at ATTITUDE's rate (PX4 onboard profile: 10 Hz)
    mavlink.MAVLINK_MSG_ID_ATTITUDE_TARGET: 20.0,
    mavlink.MAVLINK_MSG_ID_POSITION_TARGET_LOCAL_NED: 10.0,
    mavlink.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW: 5.0,  # motor outputs as PWM µs, as PX4 reports them
    mavlink.MAVLINK_MSG_ID_ESTIMATOR_STATUS: 2.0,  # the EKF's health (PX4 normal profile)
}

PARAM_BURST = 20  # PARAM_VALUEs sent per update() while a list request is being served
RX_DATAGRAMS_PER_UPDATE = 2  # recvfrom calls per socket and update() at most
MAX_DATAGRAM_BYTES = 1400  # packets of one update() share datagrams up to this size (under an Ethernet MTU)
REPORTED_LOAD_PERMILLE = 100  # SYS_STATUS.load: nothing to measure in simulation

# AUTOPILOT_VERSION.capabilities, as PX4 reports them (plus PARAM_FLOAT).
CAPABILITIES = (
    mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT
    | mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
    | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_INT
    | mavlink.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
    | mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE
    | mavlink.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
    | mavlink.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
    | mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2
)
# PX4 1.14.0, FIRMWARE_VERSION_TYPE_OFFICIAL: major << 24 | minor << 16 | patch << 8 | type
DEFAULT_FLIGHT_SW_VERSION = 0x010E00FF

_GLOBAL_FRAMES = frozenset({
    mavlink.MAV_FRAME_GLOBAL,
    mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT,
    mavlink.MAV_FRAME_GLOBAL_INT,
    mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT,
    mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT,
    mavlink.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT,
})
_LOCAL_FRAMES = frozenset({
    mavlink.MAV_FRAME_LOCAL_NED,
    mavlink.MAV_FRAME_LOCAL_ENU,
    mavlink.MAV_FRAME_LOCAL_OFFSET_NED,
    mavlink.MAV_FRAME_BODY_NED,
    mavlink.MAV_FRAME_BODY_OFFSET_NED,
    mavlink.MAV_FRAME_BODY_FRD,
    mavlink.MAV_FRAME_LOCAL_FRD,
    mavlink.MAV_FRAME_LOCAL_FLU,
})

PWM_MIN_US, PWM_MAX_US, PWM_DISARMED_US = 1000, 2000, 900  # PX4's PWM_MAIN_MIN/MAX/DISARM defaults

# POSITION_TARGET_LOCAL_NED type_mask bits of x, y, z, vx, vy, vz, afx, afy, afz, yaw
_POSITION_TARGET_IGNORE_BITS = (
    mavlink.POSITION_TARGET_TYPEMASK_X_IGNORE, mavlink.POSITION_TARGET_TYPEMASK_Y_IGNORE,
    mavlink.POSITION_TARGET_TYPEMASK_Z_IGNORE, mavlink.POSITION_TARGET_TYPEMASK_VX_IGNORE,
    mavlink.POSITION_TARGET_TYPEMASK_VY_IGNORE, mavlink.POSITION_TARGET_TYPEMASK_VZ_IGNORE,
    mavlink.POSITION_TARGET_TYPEMASK_AX_IGNORE, mavlink.POSITION_TARGET_TYPEMASK_AY_IGNORE,
    mavlink.POSITION_TARGET_TYPEMASK_AZ_IGNORE, mavlink.POSITION_TARGET_TYPEMASK_YAW_IGNORE,
)

# ParamType <-> MAV_PARAM_TYPE
_MAV_PARAM_TYPE = {ParamType.INT32: mavlink.MAV_PARAM_TYPE_INT32, ParamType.REAL32: mavlink.MAV_PARAM_TYPE_REAL32}


# --------------------------------------------------------------------------- pure helpers


def _ptype_name(mav_param_type: int) -> str:
    """MAV_PARAM_TYPE number -> ParamType-style name ("INT32", "REAL32", "UINT8", ...)."""
    for name, number in _MAV_PARAM_TYPE.items():
        if number == mav_param_type:
            return name
    entry = mavlink.enums["MAV_PARAM_TYPE"].get(mav_param_type)
    return entry.name.removeprefix("MAV_PARAM_TYPE_") if entry else f"type {mav_param_type}"


def _int(x: float, lo: int, hi: int, invalid: int) -> int:
    """Round and clamp a value for an integer field; ``invalid`` for NaN/inf."""
    if not math.isfinite(x):
        return invalid
    return min(hi, max(lo, int(round(x))))


def _cdeg_0_36000(angle_rad: float) -> int:
    """Heading/course in centidegrees 0..35999; UINT16_MAX if unknown."""
    if not math.isfinite(angle_rad):
        return UINT16_MAX
    return int(round((math.degrees(angle_rad) % 360.0) * 100.0)) % 36000


def _time_boot_ms(now_us: int) -> int:
    return (now_us // 1000) & 0xFFFFFFFF


def _degE7(deg: float) -> int:
    return _int(deg * 1e7, -(2**31), INT32_MAX, 0)


class _ParamValueMessage(mavlink.MAVLink_param_value_message):
    """PARAM_VALUE whose param_value travels as 4 exact bytes (byte-wise encoding).

    Going through a Python float would turn int32 values that look like signalling
    NaNs into different integers.
    """

    def __init__(self, name: str, raw4: bytes, mav_param_type: int, count: int, index: int) -> None:
        super().__init__(name.encode("ascii"), struct.unpack("<f", raw4)[0], mav_param_type, count, index)
        self._raw4 = raw4

    def pack(self, mav: mavlink.MAVLink, force_mavlink1: bool = False) -> bytes:
        payload = self.unpacker.pack(0.0, self.param_count, self.param_index, self._param_id_raw, self.param_type)
        return self._pack(mav, self.crc_extra, self._raw4 + payload[4:], force_mavlink1=force_mavlink1)


# --------------------------------------------------------------------------- endpoint


@dataclass(slots=True)
class _Stream:
    interval_us: int  # <= 0: disabled
    next_due_us: int


class _Endpoint(UdpEndpoint):
    """One UDP socket (:class:`UdpEndpoint`) with its encoder, send batching and streams."""

    def __init__(
        self,
        name: str,
        bind: tuple[str, int],
        default_dest: tuple[str, int],
        sysid: int,
        compid: int,
        default_intervals_us: dict[int, int],
    ) -> None:
        super().__init__(f"gcs_link {name}", bind, default_dest, sysid, compid)
        self.name = name
        self.mav = mavlink.MAVLink(self, sysid, compid)  # encoder: writes through self.write
        self.default_intervals_us = default_intervals_us
        self.streams = {mid: _Stream(iv, 0) for mid, iv in default_intervals_us.items()}
        self.next_due_us = 0  # earliest next_due_us of the enabled streams
        self.param_cursor: int | None = None  # next index of a PARAM_REQUEST_LIST being served
        self.tap: Callable[[bytes], None] | None = None  # sees every packet sent (GcsLink.set_traffic_tap)
        self._batch: list[bytes] | None = None  # packets held for one datagram (begin_batch .. flush)

    # -- sending
    def write(self, data: bytes) -> None:
        """File-like sink for the encoder: the packet joins the open batch, or goes out as a datagram."""
        if self.tap is not None:
            self.tap(data)
        if self._batch is not None:
            self._batch.append(data)
        else:
            self.send_datagram(data)

    def begin_batch(self) -> None:
        """Hold the packets sent from now until :meth:`flush` (one link iteration)."""
        self._batch = []

    def flush(self) -> None:
        """The held packets, several per datagram (up to MAX_DATAGRAM_BYTES), as PX4's UDP link sends them."""
        batch, self._batch = self._batch, None
        if not batch:
            return
        out, size = [], 0
        for packet in batch:
            if out and size + len(packet) > MAX_DATAGRAM_BYTES:
                self.send_datagram(b"".join(out))
                out, size = [], 0
            out.append(packet)
            size += len(packet)
        self.send_datagram(b"".join(out))

    def send(self, msg: mavlink.MAVLink_message) -> None:
        self.mav.send(msg)

    # -- streams
    def refresh_next_due(self) -> None:
        due = [s.next_due_us for s in self.streams.values() if s.interval_us > 0]
        self.next_due_us = min(due) if due else 2**63


# --------------------------------------------------------------------------- the link


class GcsLink:
    """MAVLink ground-station link of the flight controller (PX4 SITL identity and ports).

    Construct it once, call :meth:`update` every control iteration with the simulated
    time, :meth:`close` at exit.  Counters: ``rx_errors`` (damaged input, failed
    handlers), ``rx_messages`` (good messages handled), ``tx_errors`` (failed sends).
    """

    def __init__(
        self,
        vehicle: VehicleInterface,
        instance: int = 0,
        sysid: int = 1,
        compid: int = 1,
        gcs_port: int = 14550,
        api_port: int = 14540,
        local_gcs_port: int = 18570,
        local_api_port: int = 14580,
        *,
        remote_host: str = "127.0.0.1",
        bind_host: str = "0.0.0.0",
        stream_rates_hz: dict[int, float] | None = None,
        flight_sw_version: int = DEFAULT_FLIGHT_SW_VERSION,
        middleware_sw_version: int = 0,
        os_sw_version: int = 0,
        board_version: int = 0,
        flight_custom_version: bytes = b"mavsim\x00\x00",
        vendor_id: int = 0,
        product_id: int = 0,
        uid: int | None = None,
    ) -> None:
        """
        ``stream_rates_hz``: message id -> rate (Hz of simulated time) for the streams on
        both endpoints, replacing :data:`DEFAULT_STREAM_RATES_HZ` entries (0 disables).
        The AUTOPILOT_VERSION fields are reported as given; ``uid`` defaults to a
        non-zero value derived from instance and sysid.
        """
        self.vehicle = vehicle
        self.sysid = sysid
        self.compid = compid
        self.instance = instance
        rates = dict(DEFAULT_STREAM_RATES_HZ)
        unknown = set(stream_rates_hz or {}) - set(rates)
        if unknown:
            raise ValueError(f"gcs_link cannot stream message ids {sorted(unknown)}; streams: {sorted(rates)}")
        rates.update(stream_rates_hz or {})
        intervals = {mid: (int(round(1e6 / hz)) if hz > 0 else -1) for mid, hz in rates.items()}
        self._endpoints: list[_Endpoint] = []
        try:
            for name, local, remote in (("gcs", local_gcs_port, gcs_port), ("api", local_api_port, api_port)):
                self._endpoints.append(
                    _Endpoint(name, (bind_host, local + instance), (remote_host, remote + instance), sysid, compid, intervals)
                )
        except OSError:
            self.close()
            raise
        self._version = dict(
            capabilities=CAPABILITIES,
            flight_sw_version=flight_sw_version,
            middleware_sw_version=middleware_sw_version,
            os_sw_version=os_sw_version,
            board_version=board_version,
            flight_custom_version=list(flight_custom_version[:8].ljust(8, b"\x00")),
            middleware_custom_version=[0] * 8,
            os_custom_version=[0] * 8,
            vendor_id=vendor_id,
            product_id=product_id,
            uid=uid if uid is not None else (0x4D415653 << 32) | (instance << 8) | sysid,
        )
        self.rx_errors = 0
        self.rx_messages = 0
        self.tx_build_errors = 0  # stream messages that could not be built (bug in a snapshot?)
        self._build_failures: set[int] = set()
        self._now_us = 0
        self._snap: TelemetrySnapshot | None = None
        self._snap_valid = False  # _snap belongs to the current update()
        self._built: dict[int, mavlink.MAVLink_message | None] = {}  # stream messages of the current update()
        self._home_key: tuple[float, float, float] | None = None
        self._statustext = StatustextChunker()
        self._params_changed: dict[str, None] = {}  # ordered set of names to broadcast
        self._extra_handlers: dict[str, Callable[[mavlink.MAVLink_message], None]] = {}
        self._tap: Callable[[int, str, bool, bytes], None] | None = None
        self._closed = False
        vehicle.params.subscribe(self._on_param_changed)
        self._handlers: dict[str, Callable[[_Endpoint, mavlink.MAVLink_message], None]] = {
            "HEARTBEAT": lambda ep, msg: None,  # the sender is registered as a peer, nothing else
            "PING": lambda ep, msg: None,
            "COMMAND_LONG": self._on_command_long,
            "COMMAND_INT": self._on_command_int,
            "SET_MODE": self._on_set_mode,
            "PARAM_REQUEST_LIST": self._on_param_request_list,
            "PARAM_REQUEST_READ": self._on_param_request_read,
            "PARAM_SET": self._on_param_set,
            "MISSION_REQUEST_LIST": self._on_mission_request_list,
            "MISSION_CLEAR_ALL": self._on_mission_clear_all,
            "MISSION_COUNT": self._on_mission_count,
            "TIMESYNC": self._on_timesync,
        }
        self._builders: dict[int, Callable[[TelemetrySnapshot, int], mavlink.MAVLink_message | None]] = {
            mavlink.MAVLINK_MSG_ID_HEARTBEAT: self._heartbeat,
            mavlink.MAVLINK_MSG_ID_SYS_STATUS: self._sys_status,
            mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: self._extended_sys_state,
            mavlink.MAVLINK_MSG_ID_ATTITUDE: self._attitude,
            mavlink.MAVLINK_MSG_ID_ATTITUDE_QUATERNION: self._attitude_quaternion,
            mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: self._global_position_int,
            mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED: self._local_position_ned,
            mavlink.MAVLINK_MSG_ID_GPS_RAW_INT: self._gps_raw_int,
            mavlink.MAVLINK_MSG_ID_VFR_HUD: self._vfr_hud,
            mavlink.MAVLINK_MSG_ID_HOME_POSITION: self._home_position,
            mavlink.MAVLINK_MSG_ID_BATTERY_STATUS: self._battery_status,
            mavlink.MAVLINK_MSG_ID_ATTITUDE_TARGET: self._attitude_target,
            mavlink.MAVLINK_MSG_ID_POSITION_TARGET_LOCAL_NED: self._position_target_local_ned,
            mavlink.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW: self._servo_output_raw,
            mavlink.MAVLINK_MSG_ID_ESTIMATOR_STATUS: self._estimator_status,
        }

    # ------------------------------------------------------------------ public API

    @property
    def tx_errors(self) -> int:
        return sum(ep.tx_errors for ep in self._endpoints)

    def on_message(self, msg_type: str, callback: Callable[[mavlink.MAVLink_message], None]) -> None:
        """Hand every received message of ``msg_type`` (e.g. "MANUAL_CONTROL") to ``callback``.

        For messages the link does not handle itself; target fields are not checked.
        """
        if msg_type in self._handlers:
            raise ValueError(f"{msg_type} is handled by the link itself")
        self._extra_handlers[msg_type] = callback

    def set_traffic_tap(self, tap: Callable[[int, str, bool, bytes], None] | None) -> None:
        """Hand every packet the link sends or receives to ``tap(now_us, endpoint, sent, packet)`` (a .tlog).

        ``now_us`` is the simulated time of the current update; ``endpoint`` is "gcs" or "api";
        received packets are the good MAVLink messages from other systems.  None removes the tap.
        """
        self._tap = tap
        for ep in self._endpoints:
            ep.tap = None if tap is None else (lambda data, name=ep.name: tap(self._now_us, name, True, data))

    def update(self, now_us: int) -> None:
        """One link iteration at simulated time ``now_us`` (µs): receive, answer, stream."""
        if now_us < self._now_us:  # simulated clock restarted: restart the schedules
            for ep in self._endpoints:
                for s in ep.streams.values():
                    s.next_due_us = now_us
                ep.refresh_next_due()
        self._now_us = now_us
        self._snap_valid = False
        self._built.clear()
        for ep in self._endpoints:
            ep.begin_batch()
        try:
            self._update(now_us)
        finally:
            for ep in self._endpoints:
                ep.flush()

    def _update(self, now_us: int) -> None:
        for ep in self._endpoints:
            for _ in range(RX_DATAGRAMS_PER_UPDATE):
                got = ep.recv()
                if got is None:
                    break
                self._handle_datagram(ep, *got)
        if self._params_changed:
            for name in list(self._params_changed)[:PARAM_BURST]:
                del self._params_changed[name]
                self._broadcast(self._param_value(name))
        for ep in self._endpoints:
            if ep.param_cursor is not None:
                self._send_param_burst(ep)
        events = self.vehicle.pop_events()
        for severity, text in events:
            self.send_statustext(severity, text)
        for ep in self._endpoints:
            if now_us >= ep.next_due_us:
                self._send_due_streams(ep, now_us)

    def send_statustext(self, severity: int, text: str, endpoint: str | None = None) -> None:
        """Send a STATUSTEXT (MAV_SEVERITY) on both endpoints or the named one, chunked past 50 bytes."""
        for msg in self._statustext.messages(severity, text):
            for ep in self._endpoints:
                if endpoint is None or ep.name == endpoint:
                    ep.send(msg)

    def close(self) -> None:
        """Close both sockets (idempotent)."""
        self._closed = True
        for ep in self._endpoints:
            ep.close()

    # ------------------------------------------------------------------ receiving

    def _handle_datagram(self, ep: _Endpoint, data: bytes, addr: tuple[str, int]) -> None:
        msgs, damaged = ep.incoming(data, addr)
        self.rx_errors += damaged
        for msg in msgs:
            mtype = msg.get_type()
            if self._tap is not None:
                self._tap(self._now_us, ep.name, False, bytes(msg.get_msgbuf()))
            handler = self._handlers.get(mtype)
            extra = self._extra_handlers.get(mtype) if handler is None else None
            if handler is None and extra is None:
                continue
            self.rx_messages += 1
            try:
                if handler is not None:
                    handler(ep, msg)
                else:
                    extra(msg)
            except Exception:
                self.rx_errors += 1
                log.exception("gcs_link %s: error handling %s from %s", ep.name, mtype, addr)

    def _for_us(self, msg: mavlink.MAVLink_message) -> bool:
        """Addressed to our system (or broadcast) and component (or all)."""
        return msg.target_system in (0, self.sysid) and msg.target_component in (0, self.compid)

    # -- commands

    def _on_command_long(self, ep: _Endpoint, msg: mavlink.MAVLink_message) -> None:
        """Params go to the vehicle unchanged, with frame MAV_FRAME_GLOBAL (lat/lon deg, alt AMSL)."""
        if not self._for_us(msg):
            return
        params = (msg.param1, msg.param2, msg.param3, msg.param4, msg.param5, msg.param6, msg.param7)
        self._run_command(ep, msg, msg.command, params, mavlink.MAV_FRAME_GLOBAL)

    def _on_command_int(self, ep: _Endpoint, msg: mavlink.MAVLink_message) -> None:
        """x, y: degE7 in global frames, m * 1e4 in local frames, INT32_MAX = unused (NaN)."""
        if not self._for_us(msg):
            return
        if msg.x == INT32_MAX and msg.y == INT32_MAX:
            x = y = math.nan
        elif msg.frame in _GLOBAL_FRAMES:
            x, y = msg.x * 1e-7, msg.y * 1e-7
        elif msg.frame in _LOCAL_FRAMES:
            x, y = msg.x * 1e-4, msg.y * 1e-4
        else:
            x, y = float(msg.x), float(msg.y)
        params = (msg.param1, msg.param2, msg.param3, msg.param4, x, y, msg.z)
        self._run_command(ep, msg, msg.command, params, msg.frame)

    def _run_command(
        self, ep: _Endpoint, msg: mavlink.MAVLink_message, command: int, params: tuple[float, ...], frame: int
    ) -> None:
        """Execute a command (the link's own, or the vehicle's) and send exactly one COMMAND_ACK."""
        try:
            if command == mavlink.MAV_CMD_SET_MESSAGE_INTERVAL:
                result = self._set_message_interval(ep, params[0], params[1])
            elif command == mavlink.MAV_CMD_REQUEST_MESSAGE:
                result = self._request_message(ep, params[0], params[1])
            elif command == mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES:
                ep.send(self._autopilot_version())
                result = mavlink.MAV_RESULT_ACCEPTED
            else:
                result = int(self.vehicle.handle_command(command, params, frame))
        except Exception:
            log.exception("gcs_link: command %d failed", command)
            result = mavlink.MAV_RESULT_FAILED
        self._ack(ep, msg, command, result)

    def _ack(self, ep: _Endpoint, msg: mavlink.MAVLink_message, command: int, result: int) -> None:
        ep.send(
            mavlink.MAVLink_command_ack_message(
                command, result, 0, 0, msg.get_srcSystem(), msg.get_srcComponent()
            )
        )

    def _set_message_interval(self, ep: _Endpoint, msg_id: float, interval_us: float) -> int:
        """MAV_CMD_SET_MESSAGE_INTERVAL on this endpoint: -1 disable, 0 default, > 0 µs."""
        if not (math.isfinite(msg_id) and math.isfinite(interval_us)):
            return mavlink.MAV_RESULT_DENIED
        stream = ep.streams.get(int(msg_id))
        if stream is None:
            return mavlink.MAV_RESULT_UNSUPPORTED
        interval = int(round(interval_us))
        if interval == 0:
            interval = ep.default_intervals_us[int(msg_id)]
        elif interval < -1:
            return mavlink.MAV_RESULT_DENIED
        stream.interval_us = interval
        stream.next_due_us = self._now_us  # first one at the next update
        ep.refresh_next_due()
        return mavlink.MAV_RESULT_ACCEPTED

    def _request_message(self, ep: _Endpoint, msg_id: float, param2: float) -> int:
        """MAV_CMD_REQUEST_MESSAGE: send the message once on this endpoint."""
        if not math.isfinite(msg_id):
            return mavlink.MAV_RESULT_DENIED
        mid = int(msg_id)
        if mid == mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION:
            ep.send(self._autopilot_version())
            return mavlink.MAV_RESULT_ACCEPTED
        if mid == mavlink.MAVLINK_MSG_ID_PARAM_VALUE:
            params = self.vehicle.params
            if not (math.isfinite(param2) and 0 <= param2 < len(params)):
                return mavlink.MAV_RESULT_DENIED
            ep.send(self._param_value(params.name_at(int(param2))))
            return mavlink.MAV_RESULT_ACCEPTED
        builder = self._builders.get(mid)
        if builder is None:
            return mavlink.MAV_RESULT_UNSUPPORTED
        msg = builder(self._snapshot(), self._now_us)
        if msg is None:  # e.g. HOME_POSITION before home is set
            return mavlink.MAV_RESULT_TEMPORARILY_REJECTED
        ep.send(msg)
        return mavlink.MAV_RESULT_ACCEPTED

    def _on_set_mode(self, ep: _Endpoint, msg: mavlink.MAVLink_message) -> None:
        if msg.target_system not in (0, self.sysid):
            return
        try:
            result = int(self.vehicle.handle_set_mode(msg.base_mode, msg.custom_mode))
        except Exception:
            log.exception("gcs_link: SET_MODE failed")
            result = mavlink.MAV_RESULT_FAILED
        self._ack(ep, msg, mavlink.MAVLINK_MSG_ID_SET_MODE, result)

    # -- parameters

    def _on_param_changed(self, name: str, value: float) -> None:
        """ParameterStore listener: every accepted change is broadcast at the next update."""
        if not self._closed:
            self._params_changed[name] = None

    def _param_value(self, name: str) -> mavlink.MAVLink_message:
        """PARAM_VALUE with the current value of ``name`` (byte-wise encoded)."""
        store = self.vehicle.params
        ptype = store.definition(name).ptype
        mav_type = _MAV_PARAM_TYPE[ptype]
        raw = encode_param_bytes(store.get(name), mav_type)
        return _ParamValueMessage(name, raw, mav_type, len(store), store.index(name))

    def _on_param_request_list(self, ep: _Endpoint, msg: mavlink.MAVLink_message) -> None:
        if self._for_us(msg):
            ep.param_cursor = 0  # (re)start; update() sends PARAM_BURST at a time

    def _send_param_burst(self, ep: _Endpoint) -> None:
        store = self.vehicle.params
        names = store.names()
        start = ep.param_cursor or 0
        stop = min(start + PARAM_BURST, len(names))
        for name in names[start:stop]:
            ep.send(self._param_value(name))
        ep.param_cursor = stop if stop < len(names) else None

    def _on_param_request_read(self, ep: _Endpoint, msg: mavlink.MAVLink_message) -> None:
        if not self._for_us(msg):
            return
        store = self.vehicle.params
        if msg.param_index >= 0:
            if msg.param_index >= len(store):
                self.send_statustext(mavlink.MAV_SEVERITY_ERROR, f"unknown parameter index {msg.param_index}", ep.name)
                return
            name = store.name_at(msg.param_index)
        else:
            name = msg.param_id
            if name not in store:
                self.send_statustext(mavlink.MAV_SEVERITY_ERROR, f"unknown parameter {name}", ep.name)
                return
        ep.send(self._param_value(name))

    def _on_param_set(self, ep: _Endpoint, msg: mavlink.MAVLink_message) -> None:
        """Set, then broadcast the value: the new one (via the store listener) or, if refused, the old one."""
        if not self._for_us(msg):
            return
        store = self.vehicle.params
        name = msg.param_id
        if name not in store:
            self.send_statustext(mavlink.MAV_SEVERITY_ERROR, f"unknown parameter {name}", ep.name)
            return
        try:
            value = decode_param_bytes(raw_param_value(msg), msg.param_type)
        except ValueError:  # an 8-byte type: refused by the store's type check below
            value = math.nan
        try:
            store.set(name, value, _ptype_name(msg.param_type))
        except ParamError as e:
            self._broadcast(self._param_value(name))
            self.send_statustext(mavlink.MAV_SEVERITY_ERROR, str(e), ep.name)

    # -- missions (not implemented yet: answer so that clients never wait)

    def _on_mission_request_list(self, ep: _Endpoint, msg: mavlink.MAVLink_message) -> None:
        if self._for_us(msg):
            ep.send(mavlink.MAVLink_mission_count_message(msg.get_srcSystem(), msg.get_srcComponent(), 0, msg.mission_type))

    def _on_mission_clear_all(self, ep: _Endpoint, msg: mavlink.MAVLink_message) -> None:
        if self._for_us(msg):
            self._mission_ack(ep, msg, mavlink.MAV_MISSION_ACCEPTED)

    def _on_mission_count(self, ep: _Endpoint, msg: mavlink.MAVLink_message) -> None:
        if self._for_us(msg):
            self._mission_ack(ep, msg, mavlink.MAV_MISSION_ACCEPTED if msg.count == 0 else mavlink.MAV_MISSION_UNSUPPORTED)

    def _mission_ack(self, ep: _Endpoint, msg: mavlink.MAVLink_message, result: int) -> None:
        ep.send(mavlink.MAVLink_mission_ack_message(msg.get_srcSystem(), msg.get_srcComponent(), result, msg.mission_type))

    def _on_timesync(self, ep: _Endpoint, msg: mavlink.MAVLink_message) -> None:
        """Answer a request (tc1 == 0) with our clock in ns, echoing ts1."""
        if msg.tc1 == 0:
            ep.send(mavlink.MAVLink_timesync_message(self._now_us * 1000, msg.ts1))

    # ------------------------------------------------------------------ sending

    def _broadcast(self, msg: mavlink.MAVLink_message) -> None:
        for ep in self._endpoints:
            ep.send(msg)

    def _snapshot(self) -> TelemetrySnapshot:
        """The vehicle's snapshot, fetched at most once per update()."""
        if not self._snap_valid:
            self._snap = self.vehicle.snapshot()
            self._snap_valid = True
            self._check_home(self._snap)
        return self._snap

    def _check_home(self, snap: TelemetrySnapshot) -> None:
        """A new or moved home goes out at once, not at the next 0.5 Hz slot."""
        home = snap.home
        key = None if home is None else (home.lat_deg, home.lon_deg, home.alt_amsl_m)
        if key == self._home_key:
            return
        self._home_key = key
        if key is None:
            return
        for ep in self._endpoints:
            stream = ep.streams.get(mavlink.MAVLINK_MSG_ID_HOME_POSITION)
            if stream is not None and stream.interval_us > 0:
                stream.next_due_us = min(stream.next_due_us, self._now_us)
                ep.next_due_us = min(ep.next_due_us, self._now_us)

    def _send_due_streams(self, ep: _Endpoint, now_us: int) -> None:
        for mid, stream in ep.streams.items():
            if stream.interval_us <= 0 or now_us < stream.next_due_us:
                continue
            stream.next_due_us += stream.interval_us
            if stream.next_due_us <= now_us:  # fell behind (first call, time jump): no bursts
                stream.next_due_us = now_us + stream.interval_us
            msg = self._build(mid, now_us)
            if msg is not None:
                ep.send(msg)
        ep.refresh_next_due()

    def _build(self, mid: int, now_us: int) -> mavlink.MAVLink_message | None:
        """A stream message from the current snapshot, or None if there is nothing to report.

        Built once per update() and packed for each endpoint that streams it."""
        if mid in self._built:
            return self._built[mid]
        try:
            msg = self._built[mid] = self._builders[mid](self._snapshot(), now_us)
            return msg
        except Exception:
            if mid not in self._build_failures:  # one report per message, not one per iteration
                self._build_failures.add(mid)
                log.exception("gcs_link: cannot build message %d", mid)
            self.tx_build_errors += 1
            return None

    # -- message builders: TelemetrySnapshot (SI) -> MAVLink units

    def _autopilot_version(self) -> mavlink.MAVLink_message:
        return mavlink.MAVLink_autopilot_version_message(**self._version)

    def _heartbeat(self, s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message:
        return mavlink.MAVLink_heartbeat_message(
            s.mav_type, mavlink.MAV_AUTOPILOT_PX4, s.base_mode & 0xFF, s.custom_mode & 0xFFFFFFFF, s.system_status, 3
        )

    def _sys_status(self, s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message:
        b = s.battery
        voltage_mv = _int(b.voltage_v * 1000.0, 0, UINT16_MAX - 1, UINT16_MAX) if b.voltage_v > 0 else UINT16_MAX
        current_ca = _int(b.current_a * 100.0, 0, INT16_MAX, -1) if b.current_a >= 0 else -1
        remaining = _int(b.remaining_frac * 100.0, 0, 100, -1) if b.remaining_frac >= 0 else -1
        mask = 0xFFFFFFFF
        return mavlink.MAVLink_sys_status_message(
            s.sensors_present & mask, s.sensors_enabled & mask, s.sensors_health & mask,
            REPORTED_LOAD_PERMILLE, voltage_mv, current_ca, remaining, 0, 0, 0, 0, 0, 0,
        )  # fmt: skip

    def _extended_sys_state(self, s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message:
        return mavlink.MAVLink_extended_sys_state_message(mavlink.MAV_VTOL_STATE_UNDEFINED, int(s.landed_state))

    def _attitude(self, s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
        e = s.estimate
        if e is None:
            return None
        roll, pitch, yaw = to_euler(e.q_wxyz)
        p, q, r = (float(v) for v in e.rate_frd_rad_s)
        return mavlink.MAVLink_attitude_message(_time_boot_ms(now_us), roll, pitch, yaw, p, q, r)

    def _attitude_quaternion(self, s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
        e = s.estimate
        if e is None:
            return None
        w, x, y, z = (float(v) for v in e.q_wxyz)
        p, q, r = (float(v) for v in e.rate_frd_rad_s)
        return mavlink.MAVLink_attitude_quaternion_message(_time_boot_ms(now_us), w, x, y, z, p, q, r, [0.0] * 4)

    def _attitude_target(self, s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
        """The attitude, body-rate and collective-thrust setpoints of the cascade (type_mask 0: all valid)."""
        c = s.control
        if c is None:
            return None
        q = [float(v) for v in c.q_sp_wxyz]
        p, q_rate, r = (float(v) for v in c.rate_sp_frd_rad_s)
        thrust = min(max(c.thrust_frac, 0.0), 1.0) if math.isfinite(c.thrust_frac) else 0.0
        return mavlink.MAVLink_attitude_target_message(_time_boot_ms(now_us), 0, q, p, q_rate, r, thrust)

    def _position_target_local_ned(self, s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
        """Position, velocity and acceleration setpoints (NED, estimator origin) and yaw; NaN parts flagged ignored."""
        c = s.control
        if c is None:
            return None
        values = [float(v) for v in (*c.pos_ned_m, *c.vel_ned_m_s, *c.acc_ned_m_s2)] + [float(c.yaw_rad)]
        mask = mavlink.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE  # no yaw-rate setpoint in NED
        for value, bit in zip(values, _POSITION_TARGET_IGNORE_BITS):
            if not math.isfinite(value):
                mask |= bit
        return mavlink.MAVLink_position_target_local_ned_message(
            _time_boot_ms(now_us), mavlink.MAV_FRAME_LOCAL_NED, mask, *values, math.nan)

    def _servo_output_raw(self, s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
        """Motor commands 0..1 as PWM microseconds (PWM_MIN_US..PWM_MAX_US; PWM_DISARMED_US when disarmed)."""
        if not s.motor_outputs:
            return None
        span = PWM_MAX_US - PWM_MIN_US
        pwm = [_int(PWM_MIN_US + span * c, PWM_MIN_US, PWM_MAX_US, PWM_MIN_US) if s.armed else PWM_DISARMED_US
               for c in s.motor_outputs[:16]]
        pwm += [0] * (16 - len(pwm))  # 0: output not used
        return mavlink.MAVLink_servo_output_raw_message(now_us & 0xFFFFFFFF, 0, *pwm)

    def _global_position_int(self, s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
        e = s.estimate
        if e is None or not e.position_valid:
            return None
        lat, lon, alt = ned_to_geodetic(e.pos_ned_m, e.origin_lat_deg, e.origin_lon_deg, e.origin_alt_amsl_m)
        rel_alt_m = float(s.home.pos_ned_m[2] - e.pos_ned_m[2]) if s.home is not None else 0.0
        vn, ve, vd = (_int(v * 100.0, -INT16_MAX - 1, INT16_MAX, 0) for v in e.vel_ned_m_s)
        yaw = to_euler(e.q_wxyz)[2]
        int32 = (-(2**31), INT32_MAX, 0)
        return mavlink.MAVLink_global_position_int_message(
            _time_boot_ms(now_us), _degE7(lat), _degE7(lon), _int(alt * 1000.0, *int32),
            _int(rel_alt_m * 1000.0, *int32), vn, ve, vd, _cdeg_0_36000(yaw),
        )  # fmt: skip

    def _local_position_ned(self, s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
        e = s.estimate
        if e is None or not e.position_valid:
            return None
        x, y, z = (float(v) for v in e.pos_ned_m)
        vx, vy, vz = (float(v) for v in e.vel_ned_m_s)
        return mavlink.MAVLink_local_position_ned_message(_time_boot_ms(now_us), x, y, z, vx, vy, vz)

    def _gps_raw_int(self, s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
        g = s.gps
        if g is None:
            return None
        vn, ve = float(g.vel_ned_m_s[0]), float(g.vel_ned_m_s[1])
        speed = math.hypot(vn, ve)

        def acc_cm(x_m: float) -> int:
            return _int(x_m * 100.0, 0, UINT16_MAX - 1, UINT16_MAX) if x_m >= 0 else UINT16_MAX

        def acc_mm(x_m: float) -> int:
            return _int(x_m * 1000.0, 0, 2**32 - 1, 0) if x_m >= 0 else 0

        return mavlink.MAVLink_gps_raw_int_message(
            g.timestamp_us, g.fix_type, _degE7(g.lat_deg), _degE7(g.lon_deg),
            _int(g.alt_amsl_m * 1000.0, -(2**31), INT32_MAX, 0), acc_cm(g.eph_m), acc_cm(g.epv_m),
            _int(speed * 100.0, 0, UINT16_MAX - 1, UINT16_MAX), _cdeg_0_36000(math.atan2(ve, vn)),
            _int(g.satellites, 0, 255, 255), 0, acc_mm(g.eph_m), acc_mm(g.epv_m), 0, 0, 0,
        )  # fmt: skip

    def _estimator_status(self, s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
        st = s.estimator_status
        if st is None:
            return None
        return mavlink.MAVLink_estimator_status_message(
            now_us, st.flags, st.vel_ratio, st.pos_horiz_ratio, st.pos_vert_ratio, st.mag_ratio,
            0.0, 0.0, st.pos_horiz_accuracy_m, st.pos_vert_accuracy_m)

    def _vfr_hud(self, s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
        e = s.estimate
        if e is None:
            return None
        vn, ve, vd = (float(v) for v in e.vel_ned_m_s)
        speed = math.hypot(vn, ve)
        yaw = to_euler(e.q_wxyz)[2]
        heading_deg = int(round(math.degrees(yaw) % 360.0)) % 360 if math.isfinite(yaw) else 0
        throttle = _int(s.throttle_frac * 100.0, 0, 100, 0)
        return mavlink.MAVLink_vfr_hud_message(speed, speed, heading_deg, throttle, e.alt_amsl_m, -vd)

    def _home_position(self, s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
        h = s.home
        if h is None:
            return None
        x, y, z = (float(v) for v in h.pos_ned_m)
        q_yaw = [math.cos(h.yaw_rad / 2.0), 0.0, 0.0, math.sin(h.yaw_rad / 2.0)]  # as PX4: heading only
        return mavlink.MAVLink_home_position_message(
            _degE7(h.lat_deg), _degE7(h.lon_deg), _int(h.alt_amsl_m * 1000.0, -(2**31), INT32_MAX, 0),
            x, y, z, q_yaw, 0.0, 0.0, 0.0, now_us,
        )  # fmt: skip

    def _battery_status(self, s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message:
        b = s.battery
        voltages = [UINT16_MAX] * 10
        if b.voltage_v > 0 and math.isfinite(b.voltage_v):
            cells = min(max(int(b.cell_count), 1), 10)
            cell_mv = _int(b.voltage_v * 1000.0 / cells, 0, UINT16_MAX - 1, UINT16_MAX)
            voltages[:cells] = [cell_mv] * cells
        current_ca = _int(b.current_a * 100.0, 0, INT16_MAX, -1) if b.current_a >= 0 else -1
        if b.remaining_frac >= 0:
            remaining = _int(b.remaining_frac * 100.0, 0, 100, -1)
            charge_state = (
                mavlink.MAV_BATTERY_CHARGE_STATE_CRITICAL if b.remaining_frac < 0.07
                else mavlink.MAV_BATTERY_CHARGE_STATE_LOW if b.remaining_frac < 0.15
                else mavlink.MAV_BATTERY_CHARGE_STATE_OK
            )  # fmt: skip
        else:
            remaining, charge_state = -1, mavlink.MAV_BATTERY_CHARGE_STATE_UNDEFINED
        return mavlink.MAVLink_battery_status_message(
            0, mavlink.MAV_BATTERY_FUNCTION_UNKNOWN, mavlink.MAV_BATTERY_TYPE_LIPO, INT16_MAX, voltages,
            current_ca, _int(b.consumed_mah, 0, 2**31 - 1, -1) if b.consumed_mah >= 0 else -1, -1, remaining, 0,
            charge_state, [0, 0, 0, 0], 0, 0,
        )  # fmt: skip
