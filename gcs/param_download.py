"""Download every parameter of a vehicle, as QGroundControl does.

PARAM_REQUEST_LIST makes the vehicle send one PARAM_VALUE per parameter, each
carrying ``param_index`` (0-based) and ``param_count``.  UDP can lose some, so
when the stream goes quiet the indices still missing are asked for one by one
with PARAM_REQUEST_READ by index, a few at a time, until all are in or the
(wall-clock) timeout passes.  The stream is checked on the way: one
``param_count`` throughout, each index always the same name, each name at one
index.

Timeouts and the quiet interval are wall-clock seconds (a user tool).
"""

from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Callable

from .client import GcsError, GcsTimeout, VehicleClient

QUIET_S = 0.25  # no new parameter for this long: ask for the missing ones
READ_BATCH = 10  # PARAM_REQUEST_READs sent per quiet interval
LIST_RETRIES = 3  # PARAM_REQUEST_LISTs sent if no PARAM_VALUE at all comes back
NO_INDEX = 65535  # param_index of a PARAM_VALUE that is not part of the list (MAVLink: -1 as uint16)


class ParamListError(GcsError):
    """The vehicle's parameter stream was inconsistent (count changed, an index renamed...)."""


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


class _Collector:
    """Listener that files PARAM_VALUEs by index and notes the first inconsistency."""

    def __init__(self, client: VehicleClient, progress: Callable[[int, int], None] | None) -> None:
        self.client = client
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
        name = VehicleClient._text(msg.param_id)
        value = VehicleClient._decode_param_value(msg)
        self.client._param_types[name] = msg.param_type
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


def download_parameters(client: VehicleClient, progress: Callable[[int, int], None] | None = None,
                        timeout_s: float | None = None, stats: DownloadStats | None = None) -> list[VehicleParam]:
    """Every parameter of the vehicle, in index order.

    ``progress(received, count)`` is called for each new index.  Raises
    :class:`ParamListError` if the stream is inconsistent and
    :class:`GcsTimeout` (naming the missing indices) if it is not complete
    within ``timeout_s`` wall seconds (default: the client's timeout).
    """
    c = client
    timeout = c._timeout(timeout_s)
    start = time.monotonic()
    deadline = start + timeout
    col = _Collector(c, progress)
    lists_sent = 0
    re_requested = 0
    c.drain()  # what is queued belongs to earlier exchanges
    c.add_listener(col)
    try:
        c.conn.mav.param_request_list_send(c.target_system, c.target_component)
        lists_sent = 1
        col.last_new = time.monotonic()
        while col.count is None or len(col.by_index) < col.count:
            if col.error is not None:
                raise ParamListError(f"inconsistent parameter list from the vehicle: {col.error}")
            now = time.monotonic()
            if now >= deadline:
                raise GcsTimeout(_timeout_text(col, timeout))
            c.pump(min(0.05, deadline - now))
            if time.monotonic() - col.last_new < QUIET_S:
                continue
            if col.count is None:
                if lists_sent < LIST_RETRIES:
                    c.conn.mav.param_request_list_send(c.target_system, c.target_component)
                    lists_sent += 1
            else:
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
    return (f"timed out after {timeout:g} s downloading parameters: {len(col.by_index)} of {col.count} "
            f"received, missing indices {shown}")

