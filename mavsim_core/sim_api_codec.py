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

import struct
from typing import Iterable, Sequence

from pymavlink.dialects.v20 import common as mavlink

STX_V2 = 0xFD
HEADER_LEN = 10  # STX, len, incompat, compat, seq, sysid, compid, msgid (3 bytes)
CRC_LEN = 2
_HEADER = struct.Struct("<BBBBBBBHB")
_CRC = struct.Struct("<H")


class MessageLayout:
    """Wire layout of one MAVLink message class, precomputed from pymavlink's definition."""

    def __init__(self, cls: type[mavlink.MAVLink_message]) -> None:
        self.cls = cls
        self.msgid = cls.id
        self.crc_extra = bytes([cls.crc_extra])
        self.struct = cls.unpacker
        self.size = cls.unpacker.size
        starts, at = [], 0
        for length in cls.lengths:  # wire order
            starts.append(at)
            at += length
        # For each field in definition order: (index in the unpacked tuple, array length or 0).
        self.fields = [(starts[w], cls.array_lengths[w]) for w in cls.orders]
        self.wire = [(i, cls.array_lengths[w]) for w, i in sorted((w, i) for i, w in enumerate(cls.orders))]

    def decode(self, packet: bytes | bytearray, plen: int) -> mavlink.MAVLink_message:
        """The message of a whole packet whose CRC has been checked."""
        payload = bytes(packet[HEADER_LEN : HEADER_LEN + plen])
        if plen < self.size:
            payload += bytes(self.size - plen)  # MAVLink 2 trims trailing zero bytes
        t = self.struct.unpack(payload[: self.size])
        values = [t[i] if n == 0 else list(t[i : i + n]) for i, n in self.fields]
        msg = self.cls(*values)
        msg._header = mavlink.MAVLink_header(self.msgid, 0, packet[3], plen, packet[4], packet[5], packet[6])
        msg._msgbuf = bytearray(packet)
        return msg

    def encode(self, mav: mavlink.MAVLink, values: Sequence) -> bytes:
        """A packet of this message from field values in definition order (arrays as sequences)."""
        flat: list = []
        for i, n in self.wire:
            if n == 0:
                flat.append(values[i])
            else:
                flat.extend(values[i])
        payload = self.struct.pack(*flat)
        plen = len(payload)
        while plen > 1 and payload[plen - 1] == 0:
            plen -= 1
        head = _HEADER.pack(
            STX_V2, plen, 0, 0, mav.seq, mav.srcSystem, mav.srcComponent, self.msgid & 0xFFFF, self.msgid >> 16
        )
        body = head[1:] + payload[:plen]
        crc = mavlink.x25crc(body + self.crc_extra).crc
        mav.seq = (mav.seq + 1) % 256
        mav.total_packets_sent += 1
        return b"\xfd" + body + _CRC.pack(crc)


class StreamParser:
    """``mav.parse_buffer`` for a byte stream, with a fast path for the given message classes.

    ``mav`` is the pymavlink parser everything else goes to (set ``robust_parsing`` on it
    to get damaged bytes back as BAD_DATA).  Packets come back in the order they arrived.
    """

    def __init__(self, mav: mavlink.MAVLink, fast: Iterable[type[mavlink.MAVLink_message]]) -> None:
        self.mav = mav
        self.layouts = {cls.id: MessageLayout(cls) for cls in fast}
        self._buf = bytearray()  # the start of a packet waiting for its remaining bytes

    def parse(self, data: bytes | bytearray) -> list[mavlink.MAVLink_message]:
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
            if mavlink.x25crc(bytes(buf[i + 1 : end - CRC_LEN]) + layout.crc_extra).crc != crc:
                slow_from = i  # damaged: pymavlink resynchronises and reports it
                break
            out.append(layout.decode(buf[i:end], plen))
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
