"""Fast MAVLink 2 framing of the lockstep link's per-period messages.

Every 4 ms of simulated time the simulator sends HIL_SENSOR and the flight
controller answers HIL_ACTUATOR_CONTROLS.  pymavlink's generic path (a byte-wise
parser state machine, then a decoder that works out each message's layout at run
time) costs 20-30 us per packet in the running processes: as much as the rate
controller and the mixer together, on the critical path of every period.

This module frames exactly the messages it is given, with the layouts pymavlink
generated for them (``unpacker``, ``orders``, ``lengths``, ``crc_extra``) and
pymavlink's CRC (``x25crc``, which uses fastcrc when installed), and builds the
same pymavlink message objects.  Every other packet, and anything it does not
recognise (MAVLink 1, signed packets, bad CRC, stray bytes), goes to pymavlink's
own parser, so the behaviour on those is pymavlink's.  The encoder writes what
``msg.pack(mav)`` writes (MAVLink 2, trailing zeros of the payload trimmed) and
advances the sequence number as ``mav.send`` does.
"""

from __future__ import annotations

import operator
import struct
from typing import Callable, Iterable, Sequence

from pymavlink.dialects.v20 import common as mavlink

STX_V2 = 0xFD
HEADER_LEN = 10  # STX, len, incompat, compat, seq, sysid, compid, msgid (3 bytes)
CRC_LEN = 2
_HEADER = struct.Struct("<BBBBBBHB")  # the header after STX: what the CRC covers, with the payload
_CRC = struct.Struct("<H")
_MCRF4XX = getattr(mavlink, "mcrf4xx", None)  # fastcrc's CRC-16/MCRF4XX, which pymavlink's x25crc wraps


def x25_crc(data: bytes) -> int:
    """MAVLink's CRC (CRC-16/MCRF4XX) of ``data``: ``mavlink.x25crc(data).crc``, without its wrapper object."""
    if _MCRF4XX is not None:
        return _MCRF4XX(data, 0xFFFF)
    return mavlink.x25crc(data).crc


def _field_getter(names: list[str]) -> Callable[[object], tuple]:
    """One call reading these attributes of an object as a tuple (``attrgetter`` of one name gives no tuple)."""
    if len(names) == 1:
        one = operator.attrgetter(names[0])
        return lambda obj: (one(obj),)
    return operator.attrgetter(*names) if names else (lambda obj: ())


class MessageLayout:
    """Wire layout of one MAVLink message class, precomputed from pymavlink's definition."""

    def __init__(self, cls: type[mavlink.MAVLink_message]) -> None:
        self.cls = cls
        self.msgid = cls.id
        self.crc_extra = bytes([cls.crc_extra])
        self.struct = cls.unpacker
        self.size = cls.unpacker.size
        self._padding = bytes(self.size)
        starts, at = [], 0
        for length in cls.lengths:  # wire order
            starts.append(at)
            at += length
        # For each field in definition order: (index in the unpacked tuple, array length or 0).
        self.fields = [(starts[w], cls.array_lengths[w]) for w in cls.orders]
        self.wire = [(i, cls.array_lengths[w]) for w, i in sorted((w, i) for i, w in enumerate(cls.orders))]
        # A message's field values in definition order, read from the message (what encode() takes).
        self.values_of = _field_getter(list(getattr(cls, "fieldnames", ())))
        plain = len(self.fields) > 1 and not any(n for _, n in self.fields)
        # No arrays: the unpacked tuple in definition order, and the values in wire order, by one itemgetter each.
        self._to_fields = operator.itemgetter(*[i for i, _ in self.fields]) if plain else None
        in_order = [i for i, _ in self.wire] == list(range(len(self.wire)))  # wire order = definition order
        self._to_wire = operator.itemgetter(*[i for i, _ in self.wire]) if plain and not in_order else None
        self._pack_as_given = plain and in_order

    def field_index(self, name: str) -> int:
        """Where field ``name`` starts in the tuple :meth:`unpack` gives (an array's elements follow in order)."""
        return self.fields[list(self.cls.fieldnames).index(name)][0]

    def unpack(self, buf: bytearray, at: int, plen: int) -> tuple:
        """The payload of the packet at ``buf[at:]`` (CRC checked) as the wire-order tuple of ``struct``: no message
        object, arrays flattened (:meth:`field_index` says where a field is)."""
        if plen < self.size:  # MAVLink 2 trims trailing zero bytes
            start = at + HEADER_LEN
            return self.struct.unpack(bytes(buf[start : start + plen]) + self._padding[plen:])
        return self.struct.unpack_from(buf, at + HEADER_LEN)

    def decode(self, packet: bytearray, plen: int) -> mavlink.MAVLink_message:
        """The message of a whole packet whose CRC has been checked (``packet`` is kept as its ``_msgbuf``)."""
        if plen < self.size:  # MAVLink 2 trims trailing zero bytes
            t = self.struct.unpack(bytes(packet[HEADER_LEN : HEADER_LEN + plen]) + self._padding[plen:])
        else:
            t = self.struct.unpack_from(packet, HEADER_LEN)
        if self._to_fields is not None:
            values = self._to_fields(t)
        else:
            values = [t[i] if n == 0 else list(t[i : i + n]) for i, n in self.fields]
        msg = self.cls(*values)  # (its __init__ beats filling a bare instance's __dict__: shared-key dicts)
        msg._header = mavlink.MAVLink_header(self.msgid, 0, packet[3], plen, packet[4], packet[5], packet[6])
        msg._msgbuf = packet if type(packet) is bytearray else bytearray(packet)
        return msg

    def encode(self, mav: mavlink.MAVLink, values: Sequence) -> bytes:
        """A packet of this message from field values in definition order (arrays as sequences)."""
        if self._pack_as_given:
            payload = self.struct.pack(*values)
        elif self._to_wire is not None:
            payload = self.struct.pack(*self._to_wire(values))
        else:
            flat: list = []
            for i, n in self.wire:
                if n == 0:
                    flat.append(values[i])
                else:
                    flat.extend(values[i])
            payload = self.struct.pack(*flat)
        return self.frame(mav, payload.rstrip(b"\0") or payload[:1])  # MAVLink 2 trims trailing zeros, keeps one

    def frame(self, mav: mavlink.MAVLink, payload: bytes) -> bytes:
        """An unsigned MAVLink 2 packet of this message around ``payload`` (already packed and trimmed), with
        ``mav``'s ids and next sequence number (advanced, as ``mav.send`` does)."""
        msgid = self.msgid
        body = _HEADER.pack(len(payload), 0, 0, mav.seq, mav.srcSystem, mav.srcComponent, msgid & 0xFFFF, msgid >> 16)
        body += payload
        crc = x25_crc(body + self.crc_extra)
        mav.seq = (mav.seq + 1) % 256
        mav.total_packets_sent += 1
        return b"\xfd" + body + _CRC.pack(crc)


_NUMERIC: dict[type, MessageLayout | None] = {}


def numeric_layout(cls: type) -> MessageLayout | None:
    """The layout of a message class pymavlink generated whose fields are all numbers (no ``char`` arrays,
    which pymavlink's ``pack`` encodes from ``str``); None for any other class (one that packs itself, a
    subclass).  Its :meth:`MessageLayout.encode` writes what pymavlink's ``msg.pack(mav)`` writes."""
    try:
        return _NUMERIC[cls]
    except KeyError:
        generated = mavlink.mavlink_map.get(getattr(cls, "id", None)) is cls
        unpacker = getattr(cls, "unpacker", None)  # pymavlink's struct.Struct of the wire layout
        layout = MessageLayout(cls) if generated and unpacker is not None and "s" not in unpacker.format else None
        _NUMERIC[cls] = layout
        return layout


class StreamParser:
    """``mav.parse_buffer`` for a byte stream, with a fast path for the given message classes.

    ``mav`` is the pymavlink parser everything else goes to (set ``robust_parsing`` on it
    to get damaged bytes back as BAD_DATA).  Packets come back in the order they arrived: with
    ``parse(data, raw=True)``, a packet of a fast-path class as ``(msgid, tuple)`` (:meth:`MessageLayout.unpack`),
    which costs a third of building its message object; everything else as pymavlink's message objects.
    """

    def __init__(self, mav: mavlink.MAVLink, fast: Iterable[type[mavlink.MAVLink_message]]) -> None:
        self.mav = mav
        self.layouts = {cls.id: MessageLayout(cls) for cls in fast}
        self._buf = bytearray()  # the start of a packet waiting for its remaining bytes

    def parse(self, data: bytes | bytearray, raw: bool = False) -> list:
        """The packets that ``data`` completes, in order (``raw``: the fast path's as ``(msgid, tuple)``)."""
        if self.mav.buf_len() > 0:  # pymavlink is inside a packet: it reads on
            return self._slow(data)
        buf = self._buf
        buf += data
        out: list = []
        i, n = 0, len(buf)
        slow_from = None
        while n - i >= 3:
            if buf[i] != STX_V2 or buf[i + 2] != 0:  # not MAVLink 2, or signed: not ours
                slow_from = i
                break
            if n - i < HEADER_LEN:
                break
            plen = buf[i + 1]
            end = i + HEADER_LEN + plen + CRC_LEN
            if end > n:
                break
            msgid = buf[i + 7] | buf[i + 8] << 8 | buf[i + 9] << 16
            layout = self.layouts.get(msgid)
            if layout is None:
                out.extend(self._slow(bytes(buf[i:end])))
                i = end
                continue
            crc = _CRC.unpack_from(buf, end - CRC_LEN)[0]
            if x25_crc(bytes(buf[i + 1 : end - CRC_LEN]) + layout.crc_extra) != crc:
                slow_from = i  # damaged: pymavlink resynchronises and reports it
                break
            out.append((msgid, layout.unpack(buf, i, plen)) if raw else layout.decode(buf[i:end], plen))
            i = end
        if slow_from is not None:
            rest = bytes(buf[slow_from:])
            self._buf = bytearray()
            out.extend(self._slow(rest))
        else:
            self._buf = buf[i:]
        return out

    def _slow(self, data: bytes | bytearray) -> list[mavlink.MAVLink_message]:
        try:
            return self.mav.parse_buffer(data) or []
        except mavlink.MAVError:
            return []
