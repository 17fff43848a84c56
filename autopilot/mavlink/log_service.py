"""The MAVLink log protocol: list, download and erase the flight controller's ULogs, as PX4 serves them.

* LOG_REQUEST_LIST (start, end) -> one LOG_ENTRY per log in the range: ids 0..N-1 oldest first
  (PX4's numbering; MAVSDK and QGroundControl index their tables by it), ``time_utc`` the UTC time
  of arming (from the file name, else the file's time), ``size`` in bytes, ``num_logs`` N,
  ``last_log_num`` N-1.  No logs: one LOG_ENTRY with id 0 and num_logs 0 (the spec's answer).
  The list is scanned again for a request wider than the list (a new listing, as PX4 decides);
  a client re-asking for a few ids gets the same numbering.
* LOG_REQUEST_DATA (id, ofs, count; 0xFFFFFFFF = to the end) -> LOG_DATA of 90 bytes each from
  ``ofs``, up to ``count`` bytes or the file's size then.  An offset at or past the end, or an id
  not in the list, is answered with one LOG_DATA of count 0 (the protocol's "end of log"; PX4 is
  silent on an unknown id).
* LOG_ERASE: every listed log of this instance is deleted (the flight's ``.ulg`` with its ``.tlog``
  and, of a flight logged before the ULog was the only log, its ``.fc.npy``), except the one being written; ids
  start again from 0 at the next listing.
* LOG_REQUEST_END: the endpoint's transfer stops.

The log being written (the flight in progress, or its second after disarming) is listed like the
others with its size on disk then; the recorder flushes it every simulated second, so a
download gets the flight up to about then.  Only this instance's logs are listed
(``YYYY-MM-DD_HH-MM-SS[_i<N>][_<k>].ulg``, :mod:`mavsim_core.log_naming`), so instances may
share a log directory.

Throughput: each endpoint's transfer sends up to BURST_BYTES of LOG_DATA per :meth:`update` (the
link's 50 Hz update, and every poll that received something), which the endpoint packs into
full datagrams; a request is answered within the step it arrives in.
"""

from __future__ import annotations

import logging
import re
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, BinaryIO, Callable

from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink.link_service import Handler, ServiceCommand

if TYPE_CHECKING:
    from autopilot.mavlink.endpoint import LinkEndpoint

log = logging.getLogger(__name__)

LOG_DATA_LEN = 90  # bytes of data in one LOG_DATA
# LOG_DATA payload per endpoint and update: whole messages only, so every LOG_DATA of a request starts at
# ofs + k*90 (MAVSDK drops a LOG_DATA whose offset is not a multiple of 90); 364 messages, ~3.5 ms to encode.
BURST_BYTES = 364 * LOG_DATA_LEN
ENTRIES_PER_UPDATE = 200  # LOG_ENTRY messages per endpoint and update
TO_THE_END = 0xFFFFFFFF
SUFFIX = ".ulg"
COMPANIONS = (".tlog", ".fc.npy")  # the same flight's other files, erased with it (.fc.npy: older flights')
_NAME = re.compile(r"^(\d{4}-\d\d-\d\d_\d\d-\d\d-\d\d)(?:_i(\d+))?(?:_(\d+))?\.ulg$")
_ZEROS = bytes(LOG_DATA_LEN)


@dataclass(frozen=True)
class LogFile:
    """One log as listed: its file, the UTC time of arming (s since the epoch) and its order key."""

    path: Path
    time_utc: int
    key: tuple[str, int]


def list_logs(log_dir: Path | None, instance: int) -> list[LogFile]:
    """This instance's ULogs in ``log_dir``, oldest first (empty if there is no such directory)."""
    if log_dir is None or not log_dir.is_dir():
        return []
    out = []
    for p in log_dir.iterdir():
        m = _NAME.match(p.name)
        if m is None or int(m.group(2) or 0) != instance or not p.is_file():
            continue
        try:
            t = int(time.mktime(time.strptime(m.group(1), "%Y-%m-%d_%H-%M-%S")))  # names use local time
        except (ValueError, OverflowError):
            t = int(p.stat().st_mtime)
        out.append(LogFile(p, t, (m.group(1), int(m.group(3) or 1))))
    return sorted(out, key=lambda f: f.key)


def _size(path: Path) -> int | None:
    try:
        return path.stat().st_size
    except OSError:
        return None


@dataclass
class _Transfer:
    """What one endpoint is being sent: LOG_ENTRY ids still to list, and a LOG_DATA range."""

    ep: LinkEndpoint
    entries: list[int] = field(default_factory=list)
    log_id: int = -1
    file: BinaryIO | None = None
    ofs: int = 0
    remaining: int = 0

    def close_file(self) -> None:
        if self.file is not None:
            self.file.close()
        self.file, self.log_id, self.remaining = None, -1, 0


class LogService:
    """The log protocol over the link (a :class:`autopilot.mavlink.link_service.LinkService`).

    ``log_dir``: where the recorder writes (None: logging is off, the list is empty);
    ``writing``: the ULog being written now, or None (never erased).
    """

    def __init__(self, log_dir: Path | None, instance: int, writing: Callable[[], Path | None] = lambda: None) -> None:
        self.log_dir = log_dir
        self.instance = instance
        self.writing = writing
        self._logs: list[LogFile] | None = None  # the numbering of the latest listing
        self._transfers: dict[str, _Transfer] = {}
        self.bytes_sent = 0  # LOG_DATA payload sent so far (for throughput figures)

    def handlers(self) -> dict[str, Handler]:
        return {
            "LOG_REQUEST_LIST": self._on_request_list,
            "LOG_REQUEST_DATA": self._on_request_data,
            "LOG_ERASE": self._on_erase,
            "LOG_REQUEST_END": self._on_request_end,
        }

    def commands(self) -> dict[int, ServiceCommand]:
        return {}

    # -- requests -------------------------------------------------------------------
    def _transfer(self, ep: LinkEndpoint) -> _Transfer:
        t = self._transfers.get(ep.name)
        if t is None:
            t = self._transfers[ep.name] = _Transfer(ep)
        t.ep = ep
        return t

    def _listing(self) -> list[LogFile]:
        if self._logs is None:
            self._logs = list_logs(self.log_dir, self.instance)
        return self._logs

    def _on_request_list(self, ep: LinkEndpoint, msg: mavlink.MAVLink_message) -> None:
        if self._logs is None or msg.end - msg.start > len(self._logs):
            self._logs = None  # a new listing
        n = len(self._listing())
        t = self._transfer(ep)
        if n == 0:
            t.entries = [-1]  # "no logs"
            return
        start, end = min(msg.start, n - 1), min(msg.end, n - 1)
        t.entries = list(range(start, end + 1))

    def _on_request_data(self, ep: LinkEndpoint, msg: mavlink.MAVLink_message) -> None:
        logs = self._listing()
        t = self._transfer(ep)
        t.entries = []  # PX4: a data request ends a listing
        size = _size(logs[msg.id].path) if msg.id < len(logs) else None
        if size is None or msg.ofs >= size:
            t.close_file()
            ep.send(mavlink.MAVLink_log_data_message(msg.id, msg.ofs, 0, _ZEROS))
            return
        if t.log_id != msg.id or t.file is None:
            t.close_file()
            try:
                t.file = open(logs[msg.id].path, "rb")
            except OSError:
                ep.send(mavlink.MAVLink_log_data_message(msg.id, msg.ofs, 0, _ZEROS))
                return
            t.log_id = msg.id
        t.ofs = msg.ofs
        t.remaining = min(msg.count, size - msg.ofs)

    def _on_erase(self, ep: LinkEndpoint, msg: mavlink.MAVLink_message) -> None:
        for t in self._transfers.values():
            t.close_file()
            t.entries = []
        self._logs = None
        keep = self.writing()
        for f in list_logs(self.log_dir, self.instance):
            if keep is not None and f.path.resolve() == keep.resolve():
                continue
            stem = f.path.name[: -len(SUFFIX)]
            for p in [f.path] + [f.path.parent / (stem + s) for s in COMPANIONS]:
                try:
                    p.unlink(missing_ok=True)
                except OSError as exc:
                    log.warning("log_service: cannot erase %s: %s", p, exc)

    def _on_request_end(self, ep: LinkEndpoint, msg: mavlink.MAVLink_message) -> None:
        t = self._transfers.pop(ep.name, None)
        if t is not None:
            t.close_file()
        self._logs = None

    # -- sending --------------------------------------------------------------------
    def update(self, now_us: int) -> None:
        for t in list(self._transfers.values()):
            if t.entries:
                self._send_entries(t)
            if t.file is not None and t.remaining > 0:
                self._send_data(t)

    def _send_entries(self, t: _Transfer) -> None:
        logs = self._listing()
        todo, t.entries = t.entries[:ENTRIES_PER_UPDATE], t.entries[ENTRIES_PER_UPDATE:]
        for i in todo:
            if i < 0 or i >= len(logs):
                t.ep.send(mavlink.MAVLink_log_entry_message(0, 0, 0, 0, 0))
                continue
            size = _size(logs[i].path) or 0
            t.ep.send(mavlink.MAVLink_log_entry_message(i, len(logs), len(logs) - 1, logs[i].time_utc, size))

    def _send_data(self, t: _Transfer) -> None:
        assert t.file is not None
        try:
            t.file.seek(t.ofs)
            data = t.file.read(min(t.remaining, BURST_BYTES))
        except OSError as exc:
            log.warning("log_service: reading log %d failed: %s", t.log_id, exc)
            data = b""
        send, log_id, ofs = t.ep.send, t.log_id, t.ofs
        for i in range(0, len(data), LOG_DATA_LEN):
            piece = data[i : i + LOG_DATA_LEN]
            send(mavlink.MAVLink_log_data_message(log_id, ofs + i, len(piece), piece.ljust(LOG_DATA_LEN, b"\0")))
        self.bytes_sent += len(data)
        t.ofs += len(data)
        t.remaining -= len(data)
        if not data:  # the file shrank (erased, rewritten): the end of the log
            send(mavlink.MAVLink_log_data_message(log_id, t.ofs, 0, _ZEROS))
            t.remaining = 0
        if t.remaining <= 0:
            t.close_file()
