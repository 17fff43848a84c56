"""ULog files, PX4's flight log format, written as the flight goes.

The format (PX4's "ULog File Format" document; read by pyulog, Flight Review, PlotJuggler):
little-endian throughout; a 16-byte file header (``ULog`` 0x01 0x12 0x35, format version 1,
uint64 start time in µs), then messages, each ``uint16 payload size, uint8 type`` + payload.

* definitions section: ``B`` flag bits (must come first), ``F`` formats
  (``"name:type field;type[N] field;..."``), ``I`` info (``"char[7] sys_name"`` = ``"PX4"``...),
  ``P`` initial parameters (``"int32_t NAME"`` / ``"float NAME"``), ``Q`` parameter defaults;
* data section, from the first ``A``: ``A`` subscriptions (multi id, msg id, format name), ``D``
  data (msg id + the packed fields), ``L`` logged strings (level ``'0'``-``'7'``, µs, text),
  ``P`` parameter changes, ``I`` info, ``S`` sync markers.

Fields are packed in the order the format lists them, with no padding; the first field of every
logged format is ``uint64_t timestamp`` (µs on the log's clock).  Nested formats are not
supported (nothing here needs them).

Cost: each format's :class:`struct.Struct` (file header fields included) is built once, and a
data message is one ``pack_into`` into a preallocated buffer that goes to the file when full or
on :meth:`ULogWriter.flush`; the samples of several subscriptions taken at once can be one
``pack_into`` (:meth:`ULogWriter.write_group`).  This is file I/O for the process loops; nothing here reads a clock.
"""

from __future__ import annotations

import struct
from pathlib import Path
from typing import BinaryIO, Sequence

MAGIC = b"ULog\x01\x12\x35"
VERSION = 1
SYNC_MAGIC = bytes((0x2F, 0x73, 0x13, 0x20, 0x25, 0x0C, 0xBB, 0x12))
COMPAT_DEFAULT_PARAMETERS = 1  # compat_flags[0] bit 0: the log has 'Q' parameter-default messages
DEFAULT_SYSTEM, DEFAULT_CONFIGURATION = 1, 2  # 'Q' default_types bits: system-wide, this airframe's

# ULog field type -> struct code
FIELD_TYPES: dict[str, str] = {
    "int8_t": "b", "uint8_t": "B", "int16_t": "h", "uint16_t": "H", "int32_t": "i", "uint32_t": "I",
    "int64_t": "q", "uint64_t": "Q", "float": "f", "double": "d", "bool": "?", "char": "c",
}  # fmt: skip
_MSG_HEADER = struct.Struct("<HB")
_FILE_HEADER = struct.Struct("<7sBQ")
_DATA_HEADER = "<HBH"  # payload size, 'D', msg_id: the start of every data message's Struct
_NAME_OK = frozenset("abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ0123456789_")


class ULogFormat:
    """One message format: a name and fields written like PX4's (``"float[4] q"``, ``"uint64_t timestamp"``).

    ``values`` is how many values :meth:`ULogWriter.write` takes for it, arrays flattened
    (``char[N]`` is one ``bytes`` value).
    """

    def __init__(self, name: str, fields: Sequence[str]) -> None:
        if not name or not set(name) <= _NAME_OK:
            raise ValueError(f"bad ULog format name {name!r}")
        codes, self.values, names = [], 0, set()
        for f in fields:
            ftype, _, fname = f.partition(" ")
            base, bracket, count_text = ftype.partition("[")
            count = int(count_text.rstrip("]")) if bracket else 0
            if base not in FIELD_TYPES or not fname or not set(fname) <= _NAME_OK or fname in names:
                raise ValueError(f"{name}: bad field {f!r}")
            if bracket and count < 1:
                raise ValueError(f"{name}: bad array size in {f!r}")
            names.add(fname)
            if base == "char" and count:
                codes.append(f"{count}s")
                self.values += 1
            else:
                codes.append(f"{count}{FIELD_TYPES[base]}" if count else FIELD_TYPES[base])
                self.values += max(count, 1)
        if not fields or fields[0] != "uint64_t timestamp":
            raise ValueError(f"{name}: the first field must be 'uint64_t timestamp'")
        self.name = name
        self.fields = tuple(fields)
        self.codes = "".join(codes)
        self.size = struct.calcsize("<" + self.codes)  # bytes of one sample

    @property
    def text(self) -> str:
        """The 'F' message's payload: ``name:field;field;``."""
        return self.name + ":" + "".join(f + ";" for f in self.fields)


class Subscription:
    """A format being logged under one message id (the result of :meth:`ULogWriter.subscribe`)."""

    __slots__ = ("format", "msg_id", "multi_id", "size", "pack_into", "payload_size", "header")

    def __init__(self, fmt: ULogFormat, msg_id: int, multi_id: int) -> None:
        self.format = fmt
        self.msg_id = msg_id
        self.multi_id = multi_id
        s = struct.Struct(_DATA_HEADER + fmt.codes)
        self.size = s.size  # the whole message, its 3-byte header included
        self.payload_size = s.size - 3
        self.pack_into = s.pack_into
        self.header = (self.payload_size, 68, msg_id)  # a data message's header values (68: 'D')


class SubscriptionGroup:
    """Subscriptions whose samples are written together (:meth:`ULogWriter.write_group`): the same 'D' messages,
    one after the other, from one :class:`struct.Struct` for all of them (one pack instead of one per message)."""

    __slots__ = ("subs", "size", "pack_into")

    def __init__(self, subs: Sequence[Subscription]) -> None:
        self.subs = tuple(subs)
        codes = "".join(_DATA_HEADER[1:] + sub.format.codes for sub in self.subs)  # header and fields of each
        self.pack_into = struct.Struct("<" + codes).pack_into
        self.size = sum(sub.size for sub in self.subs)


def _type_of(value: object, type_name: str | None) -> tuple[str, bytes]:
    """(ULog type, packed value) of an info or parameter value."""
    if isinstance(value, str):
        value = value.encode()
    if isinstance(value, bytes):
        return f"char[{len(value)}]", value
    if type_name is None:
        type_name = "int32_t" if isinstance(value, int) else "float"
    if type_name not in FIELD_TYPES or type_name == "char":
        raise ValueError(f"bad ULog value type {type_name!r}")
    return type_name, struct.pack("<" + FIELD_TYPES[type_name], value)


def _key_value(key: str, value: object, type_name: str | None) -> bytes:
    """The ``uint8 key_len, key ("type name"), value`` body shared by 'I', 'P' and 'Q'."""
    if not key or not set(key) <= _NAME_OK:
        raise ValueError(f"bad ULog key {key!r}")
    t, packed = _type_of(value, type_name)
    k = f"{t} {key}".encode()
    return bytes((len(k),)) + k + packed


class ULogWriter:
    """Write one ULog file at ``path``; ``start_us`` is the header's start time (µs, the data's clock).

    Definitions first (:meth:`add_format`, :meth:`add_info`, :meth:`add_parameter`,
    :meth:`add_default_parameter`); the first :meth:`subscribe` starts the data section, after
    which :meth:`write`, :meth:`log`, :meth:`sync`, :meth:`add_parameter` (a change) and
    :meth:`add_info` may follow.  ``buffer_bytes``: data held before it goes to the file.
    """

    def __init__(
        self, path: str | Path, start_us: int, buffer_bytes: int = 65536, default_parameters: bool = True
    ) -> None:
        self.path = Path(path)
        self._cap = max(1024, int(buffer_bytes))
        self._buf = bytearray(self._cap)
        self._n = 0
        self._formats: dict[str, ULogFormat] = {}
        self._subs: list[Subscription] = []
        self.data_started = False
        self.bytes_written = 0  # in the file so far (flushed to the OS)
        self._f: BinaryIO | None = open(self.path, "wb")  # None once closed
        flags = bytes((COMPAT_DEFAULT_PARAMETERS if default_parameters else 0,)) + bytes(7 + 8 + 24)
        self._put(_FILE_HEADER.pack(MAGIC, VERSION, int(start_us)))
        self._message("B", flags)

    # -- definitions ----------------------------------------------------------------
    def add_format(self, fmt: ULogFormat) -> None:
        """An 'F' message (definitions section only)."""
        if self.data_started:
            raise ValueError(f"format {fmt.name} after the data section started")
        if fmt.name in self._formats:
            raise ValueError(f"format {fmt.name} defined twice")
        self._formats[fmt.name] = fmt
        self._message("F", fmt.text.encode())

    def add_info(self, key: str, value: str | bytes | int | float, type_name: str | None = None) -> None:
        """An 'I' message: strings as ``char[len]``, ints as ``int32_t`` and floats as ``float`` unless
        ``type_name`` says (``"uint32_t"``, ``"uint64_t"``, ``"double"``...)."""
        self._message("I", _key_value(key, value, type_name))

    def add_parameter(self, name: str, value: float, is_int: bool) -> None:
        """A 'P' message: an initial value in the definitions section, a change in the data section."""
        self._message("P", _key_value(name, int(value) if is_int else float(value), "int32_t" if is_int else "float"))

    def add_default_parameter(self, name: str, value: float, is_int: bool, default_types: int = DEFAULT_SYSTEM) -> None:
        """A 'Q' message: the default of a parameter (``default_types``: DEFAULT_SYSTEM | DEFAULT_CONFIGURATION)."""
        v = int(value) if is_int else float(value)
        self._message("Q", bytes((default_types,)) + _key_value(name, v, "int32_t" if is_int else "float"))

    # -- data -----------------------------------------------------------------------
    def subscribe(self, format_name: str, multi_id: int = 0) -> Subscription:
        """An 'A' message: log ``format_name`` (instance ``multi_id``) under the next message id."""
        fmt = self._formats.get(format_name)
        if fmt is None:
            raise ValueError(f"no format {format_name!r} defined")
        sub = Subscription(fmt, len(self._subs), multi_id)
        if sub.msg_id > 0xFFFF:
            raise ValueError("too many subscriptions")
        self._subs.append(sub)
        self.data_started = True
        self._message("A", struct.pack("<BH", multi_id, sub.msg_id) + format_name.encode())
        return sub

    def write(self, sub: Subscription, *values: object) -> None:
        """A 'D' message: one sample of ``sub`` (values in field order, arrays flattened, timestamp first)."""
        n = self._n
        if n + sub.size > self._cap:
            self._drain()
            n = 0
        sub.pack_into(self._buf, n, sub.payload_size, 68, sub.msg_id, *values)  # 68: 'D'
        self._n = n + sub.size

    def group(self, *subs: Subscription) -> SubscriptionGroup:
        """Subscriptions to write together with :meth:`write_group`."""
        return SubscriptionGroup(subs)

    def write_group(self, group: SubscriptionGroup, *values: object) -> None:
        """One sample of each subscription of ``group``, in its order: the bytes of one :meth:`write` per
        subscription.  ``values``: for each subscription its ``header`` values, then its sample's."""
        n = self._n
        if n + group.size > self._cap:
            self._drain()
            n = 0
        group.pack_into(self._buf, n, *values)
        self._n = n + group.size

    def log(self, level: int, timestamp_us: int, text: str) -> None:
        """An 'L' message: a logged string at ``level`` 0 (emergency) .. 7 (debug), as MAV_SEVERITY."""
        if not 0 <= level <= 7:
            raise ValueError(f"log level {level} outside 0..7")
        body = text.encode("utf-8", "replace")[:65000]
        self._message("L", struct.pack("<BQ", 48 + level, int(timestamp_us)) + body)  # 48: '0'

    def sync(self) -> None:
        """An 'S' message: the sync marker a reader finds again after a damaged stretch."""
        self._message("S", SYNC_MAGIC)

    # -- file -----------------------------------------------------------------------
    def _message(self, mtype: str, payload: bytes) -> None:
        if len(payload) > 0xFFFF:
            raise ValueError(f"ULog '{mtype}' message of {len(payload)} bytes")
        self._put(_MSG_HEADER.pack(len(payload), ord(mtype)) + payload)

    def _put(self, data: bytes) -> None:
        n = self._n
        if n + len(data) > self._cap:
            self._drain()
            n = 0
            if len(data) > self._cap:
                self._write_file(data)
                return
        self._buf[n : n + len(data)] = data
        self._n = n + len(data)

    def _drain(self) -> None:
        if self._n:
            data, self._n = memoryview(self._buf)[: self._n], 0
            self._write_file(data)

    def _write_file(self, data: bytes | memoryview) -> None:
        f = self._f
        if f is None:
            raise ValueError(f"{self.path} is closed")
        f.write(data)
        self.bytes_written += len(data)

    def flush(self) -> None:
        """Everything written so far into the file (and to the OS: a reader sees whole messages)."""
        if self._f is not None:
            self._drain()
            self._f.flush()

    def close(self) -> None:
        if self._f is not None:
            try:
                self.flush()
            finally:
                self._f.close()
                self._f = None

    @property
    def closed(self) -> bool:
        return self._f is None

    def __enter__(self) -> "ULogWriter":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
