"""Param plugin: read, set and download a vehicle's parameters.

Reads and sets use PARAM_REQUEST_READ / PARAM_SET and the PARAM_VALUE answer,
with PX4's byte-wise encoding of integers (:mod:`mavsim_core.param_encoding`).  As the
parameter protocol asks, the request is sent again every PARAM_TRY_S without an answer (MAVSDK's
per-try timeout) until one comes or the caller's timeout has passed; a set is done when the
vehicle echoes the value.  A name the vehicle does not have is told by its PARAM_ERROR
(MAV_PARAM_ERROR_DOES_NOT_EXIST) or its STATUSTEXT "unknown parameter NAME":
:class:`~gcs.errors.ParamUnknown`; no answer at all is :class:`~gcs.errors.NoAnswer`.

The full download (:func:`download_parameters`) works as QGroundControl's:
PARAM_REQUEST_LIST makes the vehicle send one PARAM_VALUE per parameter, each
carrying ``param_index`` (0-based) and ``param_count``.  UDP can lose some, so
when the stream goes quiet the indices still missing are asked for one by one
with PARAM_REQUEST_READ by index, a few at a time, until all are in or the
(wall-clock) timeout passes.  The stream is checked on the way: one
``param_count`` throughout, each index always the same name, each name at one
index.

Timeouts and the quiet interval are wall-clock seconds (a user tool).  Values
are int for integer types, float for REAL32.
"""

from __future__ import annotations

import math
import struct
import sys
import time
from dataclasses import dataclass
from typing import Callable

from pymavlink.dialects.v20 import common as mavlink2

from mavsim_core import param_encoding
from params import param_file

from ..connection import Connection
from ..errors import GcsTimeout, NoAnswer, ParamListError, ParamRefused, ParamUnknown

QUIET_S = 0.25  # no new parameter for this long: ask for the missing ones
READ_BATCH = 10  # PARAM_REQUEST_READs sent per quiet interval
LIST_TRY_S = 0.5  # PARAM_REQUEST_LIST sent again this often (wall s) while no PARAM_VALUE at all comes back
NO_INDEX = 65535  # param_index of a PARAM_VALUE that is not part of the list (MAVLink: -1 as uint16)
PARAM_ID_LEN = 16  # bytes of a MAVLink parameter name
PARAM_TRY_S = 0.5  # wall seconds a try waits for its PARAM_VALUE before the request goes again (as MAVSDK)
UNKNOWN_TEXT = "unknown parameter {}"  # the STATUSTEXT of a vehicle without PARAM_ERROR (and ours, with it)


@dataclass(frozen=True)
class VehicleParam:
    """One parameter as the vehicle reported it (int for integer types, float for REAL32)."""

    name: str
    value: int | float
    mav_type: int  # MAV_PARAM_TYPE
    index: int


@dataclass
class DownloadStats:
    """How a download went: PARAM_VALUEs received, indices asked for again, wall seconds."""

    received: int = 0
    re_requested: int = 0
    elapsed_s: float = 0.0


def param_id_text(value) -> str:
    """A PARAM_VALUE's ``param_id`` as text (pymavlink gives str or NUL-padded bytes)."""
    return value.decode("ascii", "replace").rstrip("\0") if isinstance(value, (bytes, bytearray)) else value


def decode_param_value(msg) -> int | float:
    """A PARAM_VALUE's value: int for integer types (byte-wise), float for REAL32."""
    if not param_encoding.is_integer_type(msg.param_type):
        return msg.param_value
    return param_encoding.decode_param_bytes(param_encoding.raw_param_value(msg), msg.param_type)


def _param_error_name(error: int) -> str:
    """``VALUE_OUT_OF_RANGE`` for a MAV_PARAM_ERROR number (the name without its prefix)."""
    entry = mavlink2.enums["MAV_PARAM_ERROR"].get(error)
    return entry.name.removeprefix("MAV_PARAM_ERROR_") if entry is not None else f"MAV_PARAM_ERROR {error}"


def _param_id(name: str) -> bytes:
    name_b = name.encode("ascii")
    if not name_b or len(name_b) > PARAM_ID_LEN:
        raise ValueError(f"parameter name must be 1..16 characters: {name!r}")
    return name_b


class Param:
    """Parameters of the vehicle over one connection."""

    def __init__(self, link: Connection) -> None:
        self.link = link

    def type_of(self, name: str) -> int | None:
        """The MAV_PARAM_TYPE of a parameter answered on this link so far, or None."""
        return self.link._param_types.get(name)

    def get(self, name: str, timeout_s: float | None = None, retries: int | None = None) -> int | float:
        """Read a parameter (PARAM_REQUEST_READ, sent again every PARAM_TRY_S, at most ``retries`` times: None
        as often as ``timeout_s`` allows): int for INT32, float for REAL32.

        Raises :class:`ParamUnknown` if the vehicle has no such parameter, :class:`NoAnswer` if it does
        not answer.
        """
        link = self.link
        name_b = _param_id(name)
        link.drain()  # a PARAM_VALUE queued before the request is not its answer
        msg = self._exchange(
            name,
            lambda: link.conn.mav.param_request_read_send(link.target_system, link.target_component, name_b, -1),
            timeout_s,
            retries,
            f"PARAM_VALUE for {name}",
        )
        return decode_param_value(msg)

    def set(
        self,
        name: str,
        value: float | int,
        param_type: int | None = None,
        timeout_s: float | None = None,
        retries: int | None = None,
    ) -> int | float:
        """Set a parameter (PARAM_SET, sent again as :meth:`get`) and return the value the vehicle echoes.

        ``param_type`` is a MAV_PARAM_TYPE (6 INT32, 9 REAL32); if omitted the
        parameter is read first to learn it.  Integers are sent byte-wise
        encoded, as PX4 expects.  Raises :class:`ParamRefused` if the echoed
        value differs (the vehicle kept the old one), with its STATUSTEXT reason;
        :class:`ParamUnknown` and :class:`NoAnswer` as :meth:`get`.
        """
        link = self.link
        name_b = _param_id(name)
        if param_type is None:
            if name not in link._param_types:
                self.get(name, timeout_s)
            param_type = link._param_types[name]
        raw = param_encoding.encode_param_bytes(value, param_type)
        want = param_encoding.decode_param_bytes(raw, param_type)

        def matches(m) -> bool:
            v = decode_param_value(m)
            return v == want or (isinstance(v, float) and math.isnan(v) and math.isnan(want))

        link.drain()  # older PARAM_VALUEs and STATUSTEXTs must not pass for this set's answer
        texts_before = len(link.statustexts)
        others = []

        def answers(m) -> bool:
            """The echo of this set, or a refusal: another value with the vehicle's reason (a STATUSTEXT naming
            the parameter, in the same datagram).  Another value without a reason is a late answer to an earlier
            request (another station's change, a read) unless it comes twice."""
            if matches(m) or any(name in t.text for t in link.statustexts[texts_before:]):
                return True
            others.append(m)
            return len(others) >= 2

        msg = self._exchange(
            name,
            lambda: self._send_set(name_b, raw, param_type),
            timeout_s,
            retries,
            f"PARAM_VALUE echo for {name}",
            answers,
        )
        got = decode_param_value(msg)
        if not matches(msg):
            reason = link.reason_since(texts_before, about=name)
            because = f" ({reason})" if reason else ""
            kept = param_file.format_value(got, param_type if param_encoding.is_integer_type(param_type) else None)
            raise ParamRefused(f"{name} not set to {value!r}: vehicle kept {kept}{because}")
        return got

    def get_all(
        self,
        progress: Callable[[int, int], None] | None = None,
        timeout_s: float | None = None,
        stats: DownloadStats | None = None,
    ) -> list[VehicleParam]:
        """Every parameter of the vehicle in index order (see :func:`download_parameters`)."""
        return download_parameters(self.link, progress, timeout_s, stats)

    def _exchange(
        self,
        name: str,
        send: Callable[[], None],
        timeout_s: float | None,
        retries: int | None,
        what: str,
        answers: Callable[[object], bool] | None = None,
    ):
        """Send every PARAM_TRY_S (at most ``retries`` times) until a PARAM_VALUE named ``name`` (that
        ``answers``) arrives; ParamUnknown if the vehicle says it has no such parameter, NoAnswer if nothing."""
        link = self.link
        timeout = link._timeout(timeout_s)
        texts_before = len(link.statustexts)
        unknown = UNKNOWN_TEXT.format(name)

        def about(m) -> bool:
            mtype = m.get_type()
            if mtype == "STATUSTEXT":
                return any(st.text == unknown for st in link.statustexts[texts_before:])
            return param_id_text(m.param_id) == name and (mtype != "PARAM_VALUE" or answers is None or answers(m))

        start = time.monotonic()
        deadline, next_try, attempts = start + timeout, start, 0
        while (now := time.monotonic()) < deadline:
            if now >= next_try:
                if retries is None or attempts < max(1, retries):
                    send()
                    attempts += 1
                    next_try = now + PARAM_TRY_S
                else:
                    next_try = deadline  # no tries left: listen until the timeout
            msg = link.recv(("PARAM_VALUE", "PARAM_ERROR", "STATUSTEXT"), min(next_try, deadline) - now, about)
            if msg is None:
                continue
            if msg.get_type() == "PARAM_VALUE":
                link._param_types[name] = msg.param_type
                return msg
            if msg.get_type() == "STATUSTEXT" or msg.error == mavlink2.MAV_PARAM_ERROR_DOES_NOT_EXIST:
                raise ParamUnknown(f"{name}: no such parameter on the vehicle ('{unknown}')")
            raise ParamRefused(f"{name}: {_param_error_name(msg.error)}")
        raise NoAnswer(
            f"timed out after {timeout:g} s waiting for {what} ({attempts} request(s), no answer) [{link.describe()}]"
        )

    def _send_set(self, name_b: bytes, raw: bytes, param_type: int) -> None:
        """PARAM_SET with the exact 4 value bytes (a Python float would alter signalling-NaN patterns)."""
        link = self.link
        dialect = sys.modules[type(link.conn.mav).__module__]
        msg = dialect.MAVLink_param_set_message(link.target_system, link.target_component, name_b, 0.0, param_type)
        payload = raw + struct.pack("<BB16sB", link.target_system, link.target_component, name_b, param_type)
        msg.pack = lambda mav, force_mavlink1=False: msg._pack(
            mav, msg.crc_extra, payload, force_mavlink1=force_mavlink1
        )
        link.conn.mav.send(msg)


# --------------------------------------------------------------------------- the full download


class _Collector:
    """Listener that files PARAM_VALUEs by index and notes the first inconsistency."""

    def __init__(self, link: Connection, progress: Callable[[int, int], None] | None) -> None:
        self.link = link
        self.progress = progress
        self.count: int | None = None
        self.by_index: dict[int, VehicleParam] = {}
        self.index_of: dict[str, int] = {}
        self.error: str | None = None
        self.received = 0
        self.last_new = time.monotonic()

    def __call__(self, msg) -> None:
        if msg.get_type() != "PARAM_VALUE" or self.error is not None:
            return
        self.received += 1
        name = param_id_text(msg.param_id)
        value = decode_param_value(msg)
        self.link._param_types[name] = msg.param_type
        if self.count is None:
            self.count = msg.param_count
        elif msg.param_count != self.count:
            self.error = f"param_count changed from {self.count} to {msg.param_count} (at {name})"
            return
        index = msg.param_index
        if index == NO_INDEX:
            return  # an answer outside the list (PX4 uses it for some sets): not an index
        if index >= self.count:
            self.error = f"{name} has index {index}, beyond param_count {self.count}"
            return
        old = self.by_index.get(index)
        if old is not None and old.name != name:
            self.error = f"index {index} was {old.name}, now {name}"
            return
        if self.index_of.setdefault(name, index) != index:
            self.error = f"{name} reported at index {self.index_of[name]} and at index {index}"
            return
        self.by_index[index] = VehicleParam(name, value, msg.param_type, index)
        if old is None:
            self.last_new = time.monotonic()
            if self.progress is not None:
                self.progress(len(self.by_index), self.count)


def download_parameters(
    link: Connection,
    progress: Callable[[int, int], None] | None = None,
    timeout_s: float | None = None,
    stats: DownloadStats | None = None,
) -> list[VehicleParam]:
    """Every parameter of the vehicle on ``link``, in index order.

    ``progress(received, count)`` is called for each new index.  Raises
    :class:`ParamListError` if the stream is inconsistent and
    :class:`GcsTimeout` (naming the missing indices) if it is not complete
    within ``timeout_s`` wall seconds (default: the connection's timeout);
    :class:`NoAnswer` if not one PARAM_VALUE came (PARAM_REQUEST_LIST is sent again every
    LIST_TRY_S until one does).
    """
    c = link
    timeout = c._timeout(timeout_s)
    start = time.monotonic()
    deadline = start + timeout
    col = _Collector(c, progress)
    re_requested = 0
    c.drain()  # what is queued belongs to earlier exchanges
    c.add_listener(col)
    try:
        c.conn.mav.param_request_list_send(c.target_system, c.target_component)
        list_sent = col.last_new = time.monotonic()
        while col.count is None or len(col.by_index) < col.count:
            if col.error is not None:
                raise ParamListError(f"inconsistent parameter list from the vehicle: {col.error}")
            now = time.monotonic()
            if now >= deadline:
                raise (NoAnswer if col.count is None else GcsTimeout)(_timeout_text(col, timeout))
            c.pump(min(0.05, deadline - now))
            if col.count is None:  # nothing yet: the request (or every answer) was lost
                if time.monotonic() - list_sent >= LIST_TRY_S:
                    c.conn.mav.param_request_list_send(c.target_system, c.target_component)
                    list_sent = time.monotonic()
                continue
            if time.monotonic() - col.last_new < QUIET_S:
                continue
            missing = [i for i in range(col.count) if i not in col.by_index][:READ_BATCH]
            for i in missing:
                c.conn.mav.param_request_read_send(c.target_system, c.target_component, b"", i)
            re_requested += len(missing)
            col.last_new = time.monotonic()
        if col.error is not None:
            raise ParamListError(f"inconsistent parameter list from the vehicle: {col.error}")
    finally:
        c.remove_listener(col)
        if stats is not None:
            stats.received = col.received
            stats.re_requested = re_requested
            stats.elapsed_s = time.monotonic() - start
    return [col.by_index[i] for i in range(col.count)]


def _timeout_text(col: _Collector, timeout: float) -> str:
    if col.count is None:
        return f"timed out after {timeout:g} s waiting for the parameter list (no PARAM_VALUE received)"
    missing = [i for i in range(col.count) if i not in col.by_index]
    shown = ", ".join(str(i) for i in missing[:20]) + (" ..." if len(missing) > 20 else "")
    return (
        f"timed out after {timeout:g} s downloading parameters: {len(col.by_index)} of {col.count} "
        f"received, missing indices {shown}"
    )
