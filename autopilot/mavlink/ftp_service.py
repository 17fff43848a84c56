"""MAVLink FTP over the link: read-only access to a :class:`autopilot.mavlink.ftp_files.FileTree`.

Requests (FILE_TRANSFER_PROTOCOL addressed to us) and their answers (:mod:`mavsim_core.mavftp`):

* ListDirectory (path, entry index in ``offset``) -> ACK with as many ``D<name>`` / ``F<name>\\t<size>``
  entries from that index as fit, each NUL terminated; NAK EOF past the last entry.
* OpenFileRO (path) -> ACK with ``size`` 4 and the file's size (uint32) in ``data``; the session is the
  one the request names (clients choose it: MAVSDK always 0, MAVProxy one per transfer), each client
  (endpoint, system, component) having its own sessions, up to MAX_SESSIONS open in all.
* ReadFile (session, offset, size) -> ACK with up to ``size`` bytes from ``offset``; NAK EOF at or past
  the end.
* BurstReadFile (session, offset, size) -> ACKs of ``size`` bytes (239 if 0 or more) from ``offset`` to
  the end of the file, reply seq counting up from the request's + 1, ``burst_complete`` on the last;
  up to BURST_PACKETS per link update (a new burst, terminate or reset of the session stops it);
  NAK EOF if ``offset`` is at or past the end.
* CalcFileCRC32 (path) -> ACK with ``size`` 4 and MAVLink's CRC32 of the file.
* TerminateSession -> ACK, or NAK InvalidSession if not open; ResetSessions -> ACK, the client's
  sessions closed; None -> ACK.
* Writes, creates, removes, renames and truncates -> NAK FileProtected (FileNotFound if the path and,
  for a create, its directory do not exist; InvalidSession for WriteFile without an open session);
  any other opcode -> NAK UnknownCommand; a path not found -> NAK FileNotFound; a ``size`` over 239
  -> NAK InvalidDataSize.

A request sent again (same bytes, as a client resends after a timeout) is answered with the same reply,
unexecuted (a BurstReadFile is started again).  Every reply goes out at once, within the link step
the request arrived in.
"""

from __future__ import annotations

import logging
import struct
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable

from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink.ftp_files import FileTree, FtpError, OpenFile
from autopilot.mavlink.link_service import Handler, ServiceCommand
from mavsim_core.mavftp import MAX_DATA, Err, FtpPayload, Op, ack, declared_size, decode, encode, list_chunk, nak

if TYPE_CHECKING:
    from autopilot.mavlink.endpoint import LinkEndpoint

log = logging.getLogger(__name__)

MAX_SESSIONS = 8  # files open at once, all clients together
SESSION_IDLE_US = 5_000_000  # a session unused this long (simulated µs) may be closed to open another
BURST_PACKETS = 120  # burst packets per link update (~30 kB; the endpoint packs them into datagrams)
_WRITES = {  # refused requests that change the tree -> whether they create their path
    Op.CREATE_FILE: True, Op.OPEN_FILE_WO: True, Op.CREATE_DIRECTORY: True,
    Op.REMOVE_FILE: False, Op.REMOVE_DIRECTORY: False, Op.TRUNCATE_FILE: False, Op.RENAME: False,
}  # fmt: skip


@dataclass
class _Burst:
    """A burst being sent: the request, the next offset, the next packet's index, the file's end."""

    req: FtpPayload
    offset: int
    k: int
    end: int


@dataclass
class _Session:
    file: OpenFile
    used_us: int
    burst: _Burst | None = None


@dataclass
class _Client:
    """One client (endpoint, system, component): its sessions and, per session number, its last request
    (as sent) with the replies."""

    ep: LinkEndpoint
    sysid: int
    compid: int
    sessions: dict[int, _Session] = field(default_factory=dict)
    last: dict[int, tuple[bytes, list[FtpPayload]]] = field(default_factory=dict)


class FtpService:
    """MAVLink FTP server (a :class:`autopilot.mavlink.link_service.LinkService`) over ``tree``;
    ``clock()`` is the link's simulated time (µs)."""

    def __init__(self, tree: FileTree, clock: Callable[[], int]) -> None:
        self.tree = tree
        self.clock = clock
        self._clients: dict[tuple[str, int, int], _Client] = {}

    def handlers(self) -> dict[str, Handler]:
        return {"FILE_TRANSFER_PROTOCOL": self._on_message}

    def commands(self) -> dict[int, ServiceCommand]:
        return {}

    def update(self, now_us: int) -> None:
        """Send the next packets of the bursts in progress."""
        budget = BURST_PACKETS
        for client in self._clients.values():
            for session in client.sessions.values():
                if session.burst is not None and budget > 0:
                    budget -= self._send_burst(client, session, budget)

    @property
    def open_sessions(self) -> int:
        return sum(len(c.sessions) for c in self._clients.values())

    # ------------------------------------------------------------------ requests

    def _on_message(self, ep: LinkEndpoint, msg: mavlink.MAVLink_message) -> None:
        raw = bytes(msg.payload)
        req = decode(raw)
        if req.opcode in (Op.ACK, Op.NAK):  # never answer an answer
            return
        key = (ep.name, msg.get_srcSystem(), msg.get_srcComponent())
        client = self._clients.get(key)
        if client is None:
            client = self._clients[key] = _Client(ep, key[1], key[2])
        client.ep = ep
        req_key = req.key()
        last = client.last.get(req.session)
        if last is not None and last[0] == req_key and req.opcode != Op.BURST_READ_FILE:
            replies = last[1]  # a resent request: the same answer, not executed again
        else:
            try:
                replies = self._answer(client, req, declared_size(raw))
            except FtpError as e:
                replies = [nak(req, e.err)]
            except OSError as e:
                log.warning("MAVLink FTP: opcode %d failed: %s", req.opcode, e)
                replies = [nak(req, Err.FAIL_ERRNO, e.errno or 0)]
            client.last[req.session] = (req_key, replies)
        for reply in replies:
            self._send(client, reply)
        session = client.sessions.get(req.session)
        if session is not None and session.burst is not None and session.burst.req is req:
            self._send_burst(client, session, BURST_PACKETS)  # the first packets at once

    def _answer(self, client: _Client, req: FtpPayload, size: int) -> list[FtpPayload]:
        """The replies to one request (empty for a burst, which :meth:`_send_burst` sends)."""
        if size > MAX_DATA:
            return [nak(req, Err.INVALID_DATA_SIZE)]
        op = req.opcode
        if op == Op.NONE:
            return [ack(req)]
        if op == Op.TERMINATE_SESSION:
            if req.session not in client.sessions:
                return [nak(req, Err.INVALID_SESSION)]
            self._close(client, req.session)
            return [ack(req)]
        if op == Op.RESET_SESSIONS:
            for session_id in list(client.sessions):
                self._close(client, session_id)
            return [ack(req)]
        if op == Op.LIST_DIRECTORY:
            entries = self.tree.list(req.path())
            if req.offset >= len(entries):
                return [nak(req, Err.EOF)]
            return [ack(req, list_chunk(entries, req.offset)[0])]
        if op == Op.OPEN_FILE_RO:
            return [self._open(client, req)]
        if op == Op.CALC_FILE_CRC32:
            return [ack(req, struct.pack("<I", self.tree.crc32(req.path())))]
        if op in (Op.READ_FILE, Op.BURST_READ_FILE, Op.WRITE_FILE):
            return self._session_request(client, req)
        if op in _WRITES:
            return [nak(req, self.tree.write_error(req.path(), _WRITES[Op(op)]))]
        return [nak(req, Err.UNKNOWN_COMMAND)]

    def _open(self, client: _Client, req: FtpPayload) -> FtpPayload:
        """OpenFileRO in the session the request names (a session of this client still open there is
        closed first: the client has given it up)."""
        now = self.clock()
        if req.session in client.sessions:
            self._close(client, req.session)
        elif self.open_sessions >= MAX_SESSIONS and not self._close_idle(now):
            return nak(req, Err.NO_SESSIONS_AVAILABLE)
        f = self.tree.open(req.path())
        client.sessions[req.session] = _Session(f, now)
        return ack(req, struct.pack("<I", min(f.size, 0xFFFFFFFF)))

    def _session_request(self, client: _Client, req: FtpPayload) -> list[FtpPayload]:
        """ReadFile, BurstReadFile and (refused) WriteFile on an open session."""
        session = client.sessions.get(req.session)
        if session is None:
            return [nak(req, Err.INVALID_SESSION)]
        session.used_us = self.clock()
        if req.opcode == Op.WRITE_FILE:
            return [nak(req, Err.FILE_PROTECTED)]
        n = req.size if 0 < req.size <= MAX_DATA else MAX_DATA
        if req.opcode == Op.BURST_READ_FILE:
            session.burst = None
            end = max(session.file.size, req.offset)
            if req.offset >= session.file.size:
                return [nak(req, Err.EOF)]
            session.burst = _Burst(req, req.offset, 0, end)
            return []
        data = session.file.read(req.offset, n)
        return [ack(req, data)] if data else [nak(req, Err.EOF)]

    def _send_burst(self, client: _Client, session: _Session, budget: int) -> int:
        """Up to ``budget`` packets of the session's burst; returns how many were sent."""
        burst = session.burst
        assert burst is not None
        chunk = burst.req.size if 0 < burst.req.size <= MAX_DATA else MAX_DATA
        sent = 0
        while sent < budget:
            try:
                data = session.file.read(burst.offset, min(chunk, burst.end - burst.offset))
            except OSError as e:  # the burst ends there
                self._send(client, nak(burst.req, Err.FAIL_ERRNO, e.errno or 0))
                session.burst = None
                return sent + 1
            last = not data or burst.offset + len(data) >= burst.end
            if not data:  # the file shrank: end the burst with EOF
                self._send(client, nak(burst.req, Err.EOF))
            else:
                self._send(client, ack(burst.req, data, offset=burst.offset, k=burst.k, burst_complete=last))
            sent += 1
            burst.offset += len(data)
            burst.k += 1
            if last:
                session.burst = None
                break
        return sent

    # ------------------------------------------------------------------ sessions and sending

    def _close(self, client: _Client, session_id: int) -> None:
        session = client.sessions.pop(session_id)
        session.file.close()

    def _close_idle(self, now_us: int) -> bool:
        """Close the session unused longest if it has been idle SESSION_IDLE_US; whether one was closed."""
        idle = [
            (s.used_us, c, sid)
            for c in self._clients.values()
            for sid, s in c.sessions.items()
            if now_us - s.used_us >= SESSION_IDLE_US
        ]
        if not idle:
            return False
        _, client, session_id = min(idle, key=lambda t: t[0])
        self._close(client, session_id)
        return True

    def _send(self, client: _Client, reply: FtpPayload) -> None:
        client.ep.send(mavlink.MAVLink_file_transfer_protocol_message(0, client.sysid, client.compid, encode(reply)))
