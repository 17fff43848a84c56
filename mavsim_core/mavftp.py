"""MAVLink FTP payload codec: the 12-byte header and data inside FILE_TRANSFER_PROTOCOL.payload.

The layout (https://mavlink.io/en/services/ftp.html, as PX4 and QGroundControl use it), little endian:

=====  ==============  ===================================================================
bytes  field           meaning
=====  ==============  ===================================================================
0-1    seq             sequence number; a reply carries the request's seq + 1 (a burst's k-th
                       packet seq + 1 + k); a request sent again keeps its seq
2      session         the open file a read or terminate is for
3      opcode          the command (:class:`Op`), or ACK / NAK in a reply
4      size            bytes used in ``data`` (a NAK: 1, or 2 with FailErrno)
5      req_opcode      in a reply: the opcode it answers
6      burst_complete  in a burst: 1 on the burst's last packet
7      padding
8-11   offset          file offset of a read, entry index of a directory listing
12-    data            up to :data:`MAX_DATA` bytes: a path, file data, a NAK's error code
=====  ==============  ===================================================================

Pure functions and constants only (no sockets): the flight controller's FTP server and the tests'
clients share them.  The CRC of CalcFileCRC32 (and of component metadata files) is MAVLink's CRC32:
the reflected 0x04C11DB7 polynomial started at 0 with no final inversion (:func:`crc32`).
"""

from __future__ import annotations

import struct
import zlib
from dataclasses import dataclass
from enum import IntEnum

PAYLOAD_LEN = 251  # FILE_TRANSFER_PROTOCOL.payload
HEADER = struct.Struct("<HBBBBBxI")
MAX_DATA = PAYLOAD_LEN - HEADER.size  # 239


class Op(IntEnum):
    """Opcodes (MAV_FTP_OPCODE): requests, then the two replies."""

    NONE = 0
    TERMINATE_SESSION = 1
    RESET_SESSIONS = 2
    LIST_DIRECTORY = 3
    OPEN_FILE_RO = 4
    READ_FILE = 5
    CREATE_FILE = 6
    WRITE_FILE = 7
    REMOVE_FILE = 8
    CREATE_DIRECTORY = 9
    REMOVE_DIRECTORY = 10
    OPEN_FILE_WO = 11
    TRUNCATE_FILE = 12
    RENAME = 13
    CALC_FILE_CRC32 = 14
    BURST_READ_FILE = 15
    ACK = 128
    NAK = 129


class Err(IntEnum):
    """NAK error codes (MAV_FTP_ERR), sent in ``data[0]``."""

    NONE = 0
    FAIL = 1
    FAIL_ERRNO = 2
    INVALID_DATA_SIZE = 3
    INVALID_SESSION = 4
    NO_SESSIONS_AVAILABLE = 5
    EOF = 6
    UNKNOWN_COMMAND = 7
    FILE_EXISTS = 8
    FILE_PROTECTED = 9
    FILE_NOT_FOUND = 10


@dataclass(frozen=True)
class FtpPayload:
    """One decoded payload; ``data`` holds exactly ``size`` bytes (``size`` is derived from it)."""

    seq: int
    session: int
    opcode: int
    req_opcode: int = 0
    offset: int = 0
    data: bytes = b""
    burst_complete: bool = False

    @property
    def size(self) -> int:
        return len(self.data)

    def path(self) -> str:
        """``data`` as a path: up to the first NUL (clients may count the NUL in ``size``), ASCII/UTF-8."""
        return self.data.split(b"\0", 1)[0].decode("utf-8", errors="replace")

    def key(self) -> bytes:
        """The request as sent (header and used data): a resent request has the same key."""
        return encode(self)[: HEADER.size + self.size]


def decode(payload: bytes | bytearray | list[int]) -> FtpPayload:
    """The payload of a FILE_TRANSFER_PROTOCOL message (ValueError if shorter than the header).

    A ``size`` larger than the data present (or than :data:`MAX_DATA`) keeps only what is there;
    :func:`declared_size` gives the size as sent, so a server can answer InvalidDataSize."""
    raw = bytes(payload)
    if len(raw) < HEADER.size:
        raise ValueError(f"FTP payload of {len(raw)} bytes: shorter than its {HEADER.size}-byte header")
    seq, session, opcode, size, req_opcode, burst_complete, offset = HEADER.unpack_from(raw)
    data = raw[HEADER.size : HEADER.size + min(size, MAX_DATA)]
    return FtpPayload(seq, session, opcode, req_opcode, offset, data, bool(burst_complete))


def declared_size(payload: bytes | bytearray | list[int]) -> int:
    """The ``size`` byte of a payload as sent."""
    return bytes(payload[4:5])[0]


def encode(p: FtpPayload) -> bytes:
    """The 251-byte payload (zero padded); ValueError if ``data`` is longer than :data:`MAX_DATA`."""
    if p.size > MAX_DATA:
        raise ValueError(f"FTP data of {p.size} bytes: at most {MAX_DATA}")
    header = HEADER.pack(
        p.seq & 0xFFFF, p.session, p.opcode, p.size, p.req_opcode, int(p.burst_complete), p.offset & 0xFFFFFFFF
    )
    return (header + p.data).ljust(PAYLOAD_LEN, b"\0")


def reply_seq(request_seq: int, k: int = 0) -> int:
    """The sequence number of the k-th reply to a request (a burst's packets count up)."""
    return (request_seq + 1 + k) & 0xFFFF


def ack(
    req: FtpPayload, data: bytes = b"", *, offset: int | None = None, k: int = 0, burst_complete: bool = False
) -> FtpPayload:
    """The ``k``-th ACK answering ``req`` (same session; ``offset`` defaults to the request's)."""
    at = req.offset if offset is None else offset
    return FtpPayload(reply_seq(req.seq, k), req.session, Op.ACK, req.opcode, at, data, burst_complete)


def nak(req: FtpPayload, err: Err, errno: int | None = None) -> FtpPayload:
    """A NAK answering ``req``: ``data`` is the error code (and the errno with FailErrno)."""
    data = bytes([int(err)]) if errno is None else bytes([int(err), errno & 0xFF])
    return FtpPayload(reply_seq(req.seq), req.session, Op.NAK, req.opcode, req.offset, data)


def crc32(data: bytes, crc: int = 0) -> int:
    """MAVLink's CRC32 of ``data``, continuing from ``crc`` (0 to start): zlib's CRC32 without its
    initial and final inversion."""
    return zlib.crc32(data, crc ^ 0xFFFFFFFF) ^ 0xFFFFFFFF


@dataclass(frozen=True)
class DirEntry:
    """One entry of a directory listing: a file with its size in bytes, or a directory (size 0)."""

    name: str
    is_dir: bool
    size: int = 0

    def encoded(self) -> bytes:
        """``D<name>\\0`` or ``F<name>\\t<size>\\0``; ``S\\0`` (skip) for a name not in ASCII or too long."""
        try:
            name = self.name.encode("ascii")
        except UnicodeEncodeError:
            return b"S\0"
        text = b"D" + name if self.is_dir else b"F" + name + b"\t" + str(self.size).encode()
        return text + b"\0" if len(text) < MAX_DATA else b"S\0"


def list_chunk(entries: list[DirEntry], first: int) -> tuple[bytes, int]:
    """The ListDirectory reply data from entry index ``first``: as many whole entries as fit in
    :data:`MAX_DATA` bytes, each NUL terminated; returns (data, entries in it)."""
    out, n = b"", 0
    for entry in entries[first:]:
        enc = entry.encoded()
        if len(out) + len(enc) > MAX_DATA:
            break
        out += enc
        n += 1
    return out, n
