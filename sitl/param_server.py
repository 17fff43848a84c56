"""The simulator as a MAVLink component: ``SIM_*`` parameters on its ground-truth UDP port.

:class:`SimParamServer` owns one bound, non-blocking UDP socket (:class:`UdpEndpoint`).  Everything the
simulator sends on it (HEARTBEAT, ground truth, parameter answers) goes to the
default peer (127.0.0.1:14740 + instance) and to every address that has sent it a
MAVLink packet (the few most recent), as PX4's UDP endpoints do.  It serves:

* HEARTBEAT at 1 Hz of wall time: MAV_TYPE_GENERIC, MAV_AUTOPILOT_GENERIC, from
  sysid 1, compid 51 (the simulator's identity in ``sitl.lockstep``).  A generic
  autopilot (not INVALID) and a type that is not GCS/gimbal/ADSB/onboard controller
  is what pymavlink (``probably_vehicle_heartbeat``) and MAVProxy
  (``heartbeat_is_from_autopilot``) lock onto as their target; it does not claim
  to be a PX4 vehicle, which the flight controller (compid 1) is.
* the parameter protocol: PARAM_REQUEST_LIST, PARAM_REQUEST_READ (by name when
  ``param_index`` is negative, else by 0-based index), PARAM_SET.  Values travel
  C-cast (MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_C_CAST: an INT32 of 3 is the float
  3.0), the encoding ground stations assume for a component that is not PX4; the
  flight controller (compid 1, PX4) keeps PX4's byte-wise encoding.  A PARAM_SET
  is always answered with a PARAM_VALUE carrying the value now in force; a refused
  one also gets a STATUSTEXT with the reason.  The value is validated against the
  parameter, so a fractional value for an INT32 parameter is refused.
* COMMAND_LONG / COMMAND_INT: REQUEST_MESSAGE for HEARTBEAT, AUTOPILOT_VERSION and
  PARAM_VALUE (by index), REQUEST_AUTOPILOT_CAPABILITIES; everything else is
  acknowledged MAV_RESULT_UNSUPPORTED, never left unanswered.
* FILE_TRANSFER_PROTOCOL (MAVFTP, which MAVProxy tries first for a parameter
  download): answered with a NAK "unknown command", so clients fall back to the
  parameter protocol at once instead of after a timeout.

The process loop calls :meth:`SimParamServer.poll` often; it does all the
non-blocking work and costs one ``poll(2)`` system call (under 1 us) when
nothing arrived.
Malformed datagrams are counted (``rx_errors``) and ignored.
"""

from __future__ import annotations

import math
import select
from typing import Callable, Iterable

from pymavlink.dialects.v20 import common as mavlink

from mavsim_core.mavlink_udp import Address, UdpEndpoint
from mavsim_core.param_types import ParamType
from mavsim_core.sim_api_codec import numeric_layout
from mavsim_core.statustext import StatustextChunker
from sitl.sim_params import SimParam, SimParamError, SimParameters

SIM_SYSID, SIM_COMPID = 1, 51  # 51 = MAV_COMP_ID_USER27, the simulator component
UGV_COMPID = 52  # MAV_COMP_ID_USER28: the ground vehicle's truth (sitl.ugv_world), same socket
HEARTBEAT_PERIOD_S = 1.0
MAX_DATAGRAMS_PER_POLL = 64  # a flood of requests cannot stall the simulation

_MAV_PARAM_TYPE = {t: t.mav_type for t in ParamType}
CAPABILITIES = (
    mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
    | mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_C_CAST
    | mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2
)
# MAVFTP (FILE_TRANSFER_PROTOCOL payload): header offsets and codes used for the NAK
_FTP_OPCODE, _FTP_SIZE, _FTP_REQ_OPCODE = 3, 4, 5
_FTP_HEADER_LEN = 12
_FTP_ACK, _FTP_NAK, _FTP_ERR_UNKNOWN_COMMAND = 128, 129, 7

ParamChangeCallback = Callable[[str, "int | float", Address], None]


def param_value_message(params: SimParameters, p: SimParam) -> mavlink.MAVLink_message:
    """PARAM_VALUE with the current value of ``p``, C-cast encoded (also on the lockstep link: sitl.link_params).

    Exact for integers: SimParameters keeps INT32 limits inside +-2**23, which a float32 holds.
    """
    value, mav_type = float(params.get(p.name)), _MAV_PARAM_TYPE[p.type]
    return mavlink.MAVLink_param_value_message(p.name.encode("ascii"), value, mav_type, len(params), p.index)


class SimParamServer:
    """MAVLink component of the simulator on one UDP socket (see the module docstring).

    ``bind``: local address (port 0: chosen by the OS; see :attr:`local_address`); loopback by default, so
    only this machine can set ``SIM_*`` parameters (``sitl --bind`` widens it).
    ``default_peer``: where everything goes even before anyone has talked to us.
    ``on_param_set(name, value, addr)``: called after a PARAM_SET changed a value.
    Counters: ``rx_messages`` (packets handled), ``rx_errors`` (damaged datagrams,
    failed handlers), ``tx_errors`` (failed sends), ``params_set`` (accepted sets).
    """

    def __init__(
        self,
        params: SimParameters,
        *,
        bind: Address = ("127.0.0.1", 0),
        default_peer: Address = ("127.0.0.1", 14740),
        sysid: int = SIM_SYSID,
        compid: int = SIM_COMPID,
        heartbeat_period_s: float = HEARTBEAT_PERIOD_S,
        on_param_set: ParamChangeCallback | None = None,
    ) -> None:
        self.params = params
        self.sysid = sysid
        self.compid = compid
        self.heartbeat_period_s = heartbeat_period_s
        self.on_param_set = on_param_set
        self.endpoint = UdpEndpoint("sim param server", bind, default_peer, sysid, compid)
        self.sock = self.endpoint.sock  # (the process loop waits on it)
        # poll(0) on this is the idle fast path: ~0.6 us, a failed recvfrom plus its exception ~2 us.
        self._poller = select.poll()
        self._poller.register(self.sock, select.POLLIN)
        self.mav = mavlink.MAVLink(None, sysid, compid)  # the one encoder: continuous sequence numbers
        self._others: dict[int, mavlink.MAVLink] = {}  # encoders of other components (encode(compid=...))
        self._next_heartbeat_s = -math.inf
        self._statustext = StatustextChunker()
        self._addr: Address = default_peer  # sender of the datagram being handled
        self.rx_messages = 0
        self.rx_errors = 0
        self.params_set = 0
        self._handlers: dict[str, Callable[[mavlink.MAVLink_message], None]] = {
            "PARAM_REQUEST_LIST": self._on_param_request_list,
            "PARAM_REQUEST_READ": self._on_param_request_read,
            "PARAM_SET": self._on_param_set,
            "COMMAND_LONG": self._on_command_long,
            "COMMAND_INT": self._on_command_int,
            "FILE_TRANSFER_PROTOCOL": self._on_file_transfer_protocol,
            "MANUAL_CONTROL": self._on_manual_control,
        }
        # MANUAL_CONTROL addressed to this system drives the ground vehicle (set by the process loop).
        self.on_manual_control: Callable[[mavlink.MAVLink_message], None] | None = None

    # ------------------------------------------------------------------ public API

    @property
    def local_address(self) -> Address:
        """(host, port) the socket is bound to."""
        return self.endpoint.local_address

    @property
    def destinations(self) -> list[Address]:
        """The default peer and the most recent senders: where everything goes."""
        return self.endpoint.destinations

    @property
    def tx_errors(self) -> int:
        return self.endpoint.tx_errors

    def poll(self, now_wall_s: float) -> None:
        """All pending non-blocking work: heartbeat if due, then read and answer every waiting datagram.

        ``now_wall_s`` is a monotonic wall clock (``time.monotonic()``); it only paces heartbeats.
        """
        if now_wall_s >= self._next_heartbeat_s:
            self._send_heartbeat(now_wall_s)
        if not self._poller.poll(0):
            return
        for _ in range(MAX_DATAGRAMS_PER_POLL):
            got = self.endpoint.recv()
            if got is None:
                return
            self._handle_datagram(*got)

    def send(self, data: bytes) -> None:
        """One datagram to the default peer and every remembered peer (best effort)."""
        self.endpoint.send_datagram(data)

    def encode(self, msgs: Iterable[mavlink.MAVLink_message], compid: int | None = None) -> bytes:
        """Messages packed as this component, or as ``compid`` of the same system (the UGV's truth), each with
        the next sequence number of its encoder (as ``mav.send`` numbers them)."""
        mav = self.mav if compid is None or compid == self.mav.srcComponent else self._others.get(compid)
        if mav is None:
            mav = self._others[compid] = mavlink.MAVLink(None, self.mav.srcSystem, compid)
        out = b""
        for m in msgs:
            layout = numeric_layout(type(m))  # (numbers only: the fast codec, pymavlink's bytes)
            if layout is not None:
                out += layout.encode(mav, layout.values_of(m))
            else:
                out += m.pack(mav)
                mav.seq = (mav.seq + 1) % 256
        return out

    def send_message(self, msg: mavlink.MAVLink_message) -> None:
        self.send(self.encode((msg,)))

    def send_statustext(self, severity: int, text: str) -> None:
        """STATUSTEXT (MAV_SEVERITY), cut into 50-byte chunks with a common id when longer."""
        for msg in self._statustext.messages(severity, text):
            self.send_message(msg)

    def close(self) -> None:
        self.endpoint.close()

    # ------------------------------------------------------------------ receiving

    def _handle_datagram(self, data: bytes, addr: Address) -> None:
        self._addr = addr
        msgs, damaged = self.endpoint.incoming(data, addr)
        self.rx_errors += damaged
        for msg in msgs:
            mtype = msg.get_type()
            handler = self._handlers.get(mtype)
            if handler is None:
                continue
            self.rx_messages += 1
            try:
                handler(msg)
            except Exception:
                self.rx_errors += 1

    def _on_manual_control(self, msg) -> None:
        if msg.target in (0, self.sysid) and self.on_manual_control is not None:
            self.on_manual_control(msg)

    def _for_us(self, msg) -> bool:
        """Addressed to our system (or broadcast) and our component (or all)."""
        return msg.target_system in (0, self.sysid) and msg.target_component in (0, self.compid)

    # -- parameters

    def _param_value(self, p: SimParam) -> mavlink.MAVLink_message:
        return param_value_message(self.params, p)

    def _on_param_request_list(self, msg) -> None:
        if self._for_us(msg):
            for p in self.params:
                self.send_message(self._param_value(p))

    def _on_param_request_read(self, msg) -> None:
        if not self._for_us(msg):
            return
        try:
            p = self.params.param(msg.param_id) if msg.param_index < 0 else self.params.at(msg.param_index)
        except SimParamError as e:
            self.send_statustext(mavlink.MAV_SEVERITY_ERROR, str(e))
            return
        self.send_message(self._param_value(p))

    def _on_param_set(self, msg) -> None:
        if not self._for_us(msg):
            return
        name = msg.param_id
        if name not in self.params:
            self.send_statustext(mavlink.MAV_SEVERITY_ERROR, f"{name}: unknown parameter")
            return
        p = self.params.param(name)
        refused = None
        before = self.params.get(name)
        try:
            value = self.params.set(name, float(msg.param_value))  # C-cast: the float is the value
        except SimParamError as e:
            refused = str(e)
        else:
            self.params_set += 1
            if value != before and self.on_param_set is not None:
                self.on_param_set(name, value, self._addr)
        if refused is not None:  # the reason first: a client reacting to the PARAM_VALUE has it
            self.send_statustext(mavlink.MAV_SEVERITY_ERROR, refused)
        self.send_message(self._param_value(p))  # the value in force, new or old

    # -- commands

    def _on_command_long(self, msg) -> None:
        if self._for_us(msg):
            self._run_command(msg, msg.command, msg.param1, msg.param2)

    def _on_command_int(self, msg) -> None:
        if self._for_us(msg):
            self._run_command(msg, msg.command, msg.param1, msg.param2)

    def _run_command(self, msg, command: int, param1: float, param2: float) -> None:
        if command == mavlink.MAV_CMD_REQUEST_MESSAGE:
            result = self._request_message(param1, param2)
        elif command == mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES:
            self.send_message(self._autopilot_version())
            result = mavlink.MAV_RESULT_ACCEPTED
        else:
            result = mavlink.MAV_RESULT_UNSUPPORTED
        self.send_message(
            mavlink.MAVLink_command_ack_message(command, result, 0, 0, msg.get_srcSystem(), msg.get_srcComponent())
        )

    def _request_message(self, msg_id: float, param2: float) -> int:
        if not math.isfinite(msg_id):
            return mavlink.MAV_RESULT_DENIED
        mid = int(msg_id)
        if mid == mavlink.MAVLINK_MSG_ID_HEARTBEAT:
            self.send_message(self._heartbeat())
        elif mid == mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION:
            self.send_message(self._autopilot_version())
        elif mid == mavlink.MAVLINK_MSG_ID_PARAM_VALUE:
            if not (math.isfinite(param2) and 0 <= param2 < len(self.params)):
                return mavlink.MAV_RESULT_DENIED
            self.send_message(self._param_value(self.params.at(int(param2))))
        else:
            return mavlink.MAV_RESULT_UNSUPPORTED
        return mavlink.MAV_RESULT_ACCEPTED

    def _on_file_transfer_protocol(self, msg) -> None:
        """NAK every MAVFTP request: there is no file system here."""
        if not self._for_us(msg):
            return
        req = bytes(msg.payload)
        if len(req) < _FTP_HEADER_LEN or req[_FTP_OPCODE] in (_FTP_ACK, _FTP_NAK):  # never answer an answer
            return
        seq = (req[0] | req[1] << 8) + 1 & 0xFFFF
        reply = bytearray(251)
        reply[0], reply[1], reply[2] = seq & 0xFF, seq >> 8, req[2]  # seq, session
        reply[_FTP_OPCODE], reply[_FTP_SIZE], reply[_FTP_REQ_OPCODE] = _FTP_NAK, 1, req[_FTP_OPCODE]
        reply[_FTP_HEADER_LEN] = _FTP_ERR_UNKNOWN_COMMAND
        self.send_message(
            mavlink.MAVLink_file_transfer_protocol_message(0, msg.get_srcSystem(), msg.get_srcComponent(), list(reply))
        )

    # ------------------------------------------------------------------ sending

    def _heartbeat(self) -> mavlink.MAVLink_message:
        return mavlink.MAVLink_heartbeat_message(
            mavlink.MAV_TYPE_GENERIC, mavlink.MAV_AUTOPILOT_GENERIC, 0, 0, mavlink.MAV_STATE_ACTIVE, 3
        )

    def _send_heartbeat(self, now_wall_s: float) -> None:
        self.send_message(self._heartbeat())
        self._next_heartbeat_s += self.heartbeat_period_s
        if self._next_heartbeat_s <= now_wall_s:  # first one, or the loop was stalled: no burst
            self._next_heartbeat_s = now_wall_s + self.heartbeat_period_s

    def _autopilot_version(self) -> mavlink.MAVLink_message:
        uid = (0x53494D << 24) | (self.sysid << 8) | self.compid  # "SIM", non-zero
        return mavlink.MAVLink_autopilot_version_message(CAPABILITIES, 0, 0, 0, 0, [0] * 8, [0] * 8, [0] * 8, 0, 0, uid)
