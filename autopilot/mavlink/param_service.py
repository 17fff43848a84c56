"""The MAVLink parameter protocol on top of the flight controller's :class:`ParameterStore`.

PARAM_REQUEST_LIST (served PARAM_BURST values per link update), PARAM_REQUEST_READ (by
name or index), PARAM_SET (set, then the value is broadcast: the new one, or the old one
with a STATUSTEXT saying why the set was refused; a parameter that applies at the next start,
e.g. MAV_SYS_ID, says so in a STATUSTEXT), and every accepted change made
elsewhere (a parameter file, another ground station) broadcast at the next update.
A name or index that does not exist is answered with PARAM_ERROR (MAV_PARAM_ERROR_DOES_NOT_EXIST)
and a STATUSTEXT; those STATUSTEXTs are rate-limited per endpoint (:data:`UNKNOWN_TEXT_PERIOD_S` of wall
time: a client flooding reads of unknown names must not flood the pilot's screen), the ones held back
counted in one STATUSTEXT once the period is over.

Saved before acknowledged: with ``persist`` set (the process's state saver, ``--state-dir``:
:class:`autopilot.param_storage.ParamSaver`), the changes since the last update are handed to the
saver's thread in one snapshot, and their PARAM_VALUEs (and the answers to reads of them) go out
at the first update after that write is done: the control loop never waits on the disk, and no
value is acknowledged before it is on the disk.  A write that fails is reported by a STATUSTEXT
and the values are still echoed and used until a restart, as PX4 keeps a parameter it could not
save.

Values travel byte-wise encoded, as PX4 sends them (:mod:`mavsim_core.param_encoding`):
an INT32's 4 bytes are copied into the float field, never converted.
"""

from __future__ import annotations

import math
import struct
import time
from typing import Callable, Protocol

from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink.endpoint import LinkEndpoint
from autopilot.parameters import ParamError, ParameterStore
from mavsim_core.param_encoding import ParamType, decode_param_bytes, encode_param_bytes, raw_param_value

PARAM_BURST = 20  # PARAM_VALUEs sent per update() while a list request is being served
UNKNOWN_TEXT_PERIOD_S = 1.0  # at most one "unknown parameter" STATUSTEXT per endpoint this often (wall s)


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


def param_type_name(mav_param_type: int) -> str:
    """MAV_PARAM_TYPE number -> ParamType-style name ("INT32", "REAL32", "UINT8", ...)."""
    try:
        return ParamType.from_mav_type(mav_param_type).value
    except ValueError:
        entry = mavlink.enums["MAV_PARAM_TYPE"].get(mav_param_type)
        return entry.name.removeprefix("MAV_PARAM_TYPE_") if entry else f"type {mav_param_type}"


def param_value(store: ParameterStore, name: str) -> mavlink.MAVLink_message:
    """PARAM_VALUE with the current value of ``name`` (byte-wise encoded)."""
    mav_type = ParamType(store.definition(name).ptype).mav_type
    raw = encode_param_bytes(store.get(name), mav_type)
    return _ParamValueMessage(name, raw, mav_type, len(store), store.index(name))


class SaveResult(Protocol):
    ok: bool
    reason: str


class ParamPersistence(Protocol):
    """What the parameter service needs of a saver (:class:`autopilot.param_storage.ParamSaver`)."""

    def request_save(self) -> int: ...

    def save_outcome(self, ticket: int) -> SaveResult | None: ...


class ParamService:
    """Serves one :class:`ParameterStore` on the link's endpoints.

    ``statustext(severity, text, endpoint_name)`` reports refusals to the asking endpoint;
    ``broadcast(msg)`` sends on every endpoint.  Messages reach the handlers only when
    addressed to this system and component (the link checks).
    """

    def __init__(
        self,
        store: ParameterStore,
        statustext: Callable[[int, str, str | None], None],
        broadcast: Callable[[mavlink.MAVLink_message], None],
    ) -> None:
        self.store = store
        self._statustext = statustext
        self._broadcast = broadcast
        self._changed: dict[str, None] = {}  # ordered set of names changed, not yet handed to the saver
        self._writing: tuple[int, list[str]] | None = None  # (save ticket, names) being written
        self._held_reads: list[tuple[LinkEndpoint, str]] = []  # reads of names not saved yet
        self._ready: dict[str, None] = {}  # ordered set of names to broadcast (saved, or nothing is saved)
        self.closed = False
        # The process's saver: changes are on the disk before they are acknowledged; None: not saved.
        self.persist: ParamPersistence | None = None
        # "unknown parameter" STATUSTEXTs per endpoint: (wall s of the last sent, how many held back since)
        self.clock: Callable[[], float] = time.monotonic
        self._unknown_said: dict[str, tuple[float, int]] = {}
        store.subscribe(self._on_param_changed)

    def _on_param_changed(self, name: str, value: float) -> None:
        """ParameterStore listener: every accepted change is broadcast at the next update."""
        if not self.closed:
            self._changed[name] = None

    def update(self, endpoints: list[LinkEndpoint]) -> None:
        """Once per link update: save changed values, broadcast the saved ones, continue list requests (PARAM_BURST
        values each)."""
        self._advance_saves()
        self._report_held_back()
        for name in list(self._ready)[:PARAM_BURST]:
            del self._ready[name]
            self._broadcast(param_value(self.store, name))
        for ep in endpoints:
            if ep.param_cursor is not None:
                self._send_burst(ep)

    def _advance_saves(self) -> None:
        """Release what the last write saved (STATUSTEXT if it failed), then hand the next changes to the saver."""
        if self.persist is None:
            self._ready.update(self._changed)
            self._changed.clear()
            return
        if self._writing is not None:
            ticket, names = self._writing
            outcome = self.persist.save_outcome(ticket)
            if outcome is None:
                return  # still writing
            if not outcome.ok:
                more = f" (and {len(names) - 1} more)" if len(names) > 1 else ""
                text = f"{names[0]}{more} set but not saved: {outcome.reason}; in use until a restart"
                self._statustext(mavlink.MAV_SEVERITY_CRITICAL, text, None)
            self._ready.update(dict.fromkeys(names))
            self._writing = None
        if self._changed:
            self._writing = (self.persist.request_save(), list(self._changed))
            self._changed.clear()
        unsaved = set(self._changed) | set(self._writing[1] if self._writing else ())
        held, self._held_reads = self._held_reads, []
        for ep, name in held:
            if name in unsaved:
                self._held_reads.append((ep, name))
            else:
                ep.send(param_value(self.store, name))

    def _send_burst(self, ep: LinkEndpoint) -> None:
        names = self.store.names()
        start = ep.param_cursor or 0
        stop = min(start + PARAM_BURST, len(names))
        for name in names[start:stop]:
            ep.send(param_value(self.store, name))
        ep.param_cursor = stop if stop < len(names) else None

    # -- messages
    def on_request_list(self, ep: LinkEndpoint, msg: mavlink.MAVLink_message) -> None:
        ep.param_cursor = 0  # (re)start; update() sends PARAM_BURST at a time

    def on_request_read(self, ep: LinkEndpoint, msg: mavlink.MAVLink_message) -> None:
        store = self.store
        if msg.param_index >= 0:
            if msg.param_index >= len(store):
                self._no_such(ep, msg, msg.param_id, msg.param_index, f"unknown parameter index {msg.param_index}")
                return
            name = store.name_at(msg.param_index)
        else:
            name = msg.param_id
            if name not in store:
                self._no_such(ep, msg, name, -1, f"unknown parameter {name}")
                return
        unsaved = name in self._changed or (self._writing is not None and name in self._writing[1])
        if unsaved and self.persist is not None:
            self._held_reads.append((ep, name))  # not saved yet: answered once it is
            return
        ep.send(param_value(store, name))

    def _no_such(self, ep: LinkEndpoint, msg: mavlink.MAVLink_message, name: str, index: int, text: str) -> None:
        """PARAM_ERROR (DOES_NOT_EXIST) to the asker and a STATUSTEXT saying so, on the asking endpoint."""
        name_b = name.encode("ascii", "replace")[:16]
        error = mavlink.MAV_PARAM_ERROR_DOES_NOT_EXIST
        index = max(-1, min(index, 32767))  # int16 on the wire
        ep.send(mavlink.MAVLink_param_error_message(msg.get_srcSystem(), msg.get_srcComponent(), name_b, index, error))
        last = self._unknown_said.get(ep.name)
        if last is not None and self.clock() - last[0] < UNKNOWN_TEXT_PERIOD_S:
            self._unknown_said[ep.name] = (last[0], last[1] + 1)  # held back: counted in _report_held_back
            return
        self._unknown_said[ep.name] = (self.clock(), 0)
        self._statustext(mavlink.MAV_SEVERITY_ERROR, text, ep.name)

    def _report_held_back(self) -> None:
        """Once an endpoint's period is over: how many "unknown parameter" STATUSTEXTs were held back in it."""
        now = self.clock()
        for name, (said_s, held) in list(self._unknown_said.items()):
            if now - said_s < UNKNOWN_TEXT_PERIOD_S:
                continue
            if held:
                self._unknown_said[name] = (now, 0)  # (a period starts: the next unknown name waits for it)
                more = "request" if held == 1 else "requests"
                self._statustext(mavlink.MAV_SEVERITY_ERROR, f"{held} more {more} for unknown parameters", name)
            else:
                del self._unknown_said[name]

    def on_set(self, ep: LinkEndpoint, msg: mavlink.MAVLink_message) -> None:
        """Set, then broadcast the value: the new one (via the store listener) or, if refused, the old one."""
        store = self.store
        name = msg.param_id
        if name not in store:
            self._no_such(ep, msg, name, -1, f"unknown parameter {name}")
            return
        try:
            value = decode_param_bytes(raw_param_value(msg), msg.param_type)
        except ValueError:  # an 8-byte type: refused by the store's type check below
            value = math.nan
        try:
            old, new = store.get(name), store.set(name, value, param_type_name(msg.param_type))
        except ParamError as e:
            self._broadcast(param_value(store, name))
            self._statustext(mavlink.MAV_SEVERITY_ERROR, str(e), ep.name)
            return
        if store.definition(name).reboot_required and new != old:  # (as PX4: stored and reported, used later)
            self._statustext(mavlink.MAV_SEVERITY_INFO, f"{name} {new:g} applies at the next start", ep.name)

    def request_message(self, ep: LinkEndpoint, index: float) -> int:
        """MAV_CMD_REQUEST_MESSAGE for PARAM_VALUE: the parameter at ``index`` (param2); a MAV_RESULT."""
        if not (math.isfinite(index) and 0 <= index < len(self.store)):
            return mavlink.MAV_RESULT_DENIED
        ep.send(param_value(self.store, self.store.name_at(int(index))))
        return mavlink.MAV_RESULT_ACCEPTED
