"""What a received datagram holds, read from its MAVLink headers before any parsing (the link's flood defence).

Parsing a packet (pymavlink, CRC and all) costs about 15-20 µs; reading its header about 1 µs.  So the
ground-station link (:mod:`autopilot.mavlink.link`) sorts every datagram it drains by :func:`triage`
first: junk that is not whole MAVLink packets and packets all addressed to another system are dropped
unparsed, and when the link's time is spent, commands addressed to us are still handled while the
rest is dropped.  Nothing is *accepted* on a header's word: whatever is kept is parsed, CRC-checked
(and signature-checked) as before; a header only decides what is dropped unread.

A datagram holds whole MAVLink packets (v1 0xFE or v2 0xFD, a v2 packet signed or not), one or several.
The target system of a packet is read at its message's payload offset of ``target_system`` (``target``
for MANUAL_CONTROL), computed once from pymavlink's message definitions; a MAVLink 2 payload
truncated before that offset means 0 (broadcast), as the trailing zero bytes are what v2 trims.
"""

from __future__ import annotations

import re
import struct
from enum import Enum

from pymavlink.dialects.v20 import common as mavlink

# Commands (COMMAND_INT 75, COMMAND_LONG 76) and SET_MODE 11: handled even when the link is out of time.
COMMAND_IDS = frozenset({75, 76, 11})
# Messages a newer one of the same kind replaces: HEARTBEAT 0, MANUAL_CONTROL 69, SET_ATTITUDE_TARGET 82,
# SET_POSITION_TARGET_LOCAL_NED 84, _GLOBAL_INT 86.
SUPERSEDED_IDS = frozenset({0, 69, 82, 84, 86})


class Kind(Enum):
    """What a datagram is, for the link's receive loop."""

    DAMAGED = "damaged"  # not a sequence of whole MAVLink packets: dropped, counted as damage
    FOREIGN = "foreign"  # every packet addressed to another system: dropped unparsed
    COMMAND = "command"  # holds a command or SET_MODE for us (or broadcast): handled even past the budget
    SUPERSEDED = "superseded"  # only messages a newer one replaces (sticks, setpoints, heartbeats)
    OTHER = "other"  # anything else for us: handled while the link has time


def _target_offsets() -> dict[int, int]:
    """Message id -> payload offset (bytes) of its target system field, for every message that has one."""
    offsets = {}
    for msg_id, cls in mavlink.mavlink_map.items():
        names = cls.ordered_fieldnames
        field = "target_system" if "target_system" in names else "target" if msg_id == 69 else None
        if field is None:
            continue
        codes = re.findall(r"\d*[a-zA-Z?]", cls.unpacker.format.lstrip("<"))  # one code per field, wire order
        offsets[msg_id] = struct.calcsize("<" + "".join(codes[: names.index(field)]))
    return offsets


TARGET_OFFSETS = _target_offsets()


def headers(data: bytes) -> list[tuple[int, int | None]] | None:
    """(message id, target system or None if the message has none) of each packet of a datagram, from
    the headers (no CRC check); None if the datagram is not a sequence of whole v1/v2 packets."""
    out, i, n = [], 0, len(data)
    while i < n:
        magic = data[i]
        if magic == 0xFD and i + 10 <= n:  # v2: len, incompat flags (1 = signed), compat, seq, sys, comp, id[3]
            length, start = data[i + 1], i + 10
            msg_id = data[i + 7] | data[i + 8] << 8 | data[i + 9] << 16
            end = start + length + 2 + (13 if data[i + 2] & 1 else 0)
        elif magic == 0xFE and i + 6 <= n:  # v1: len, seq, sys, comp, id
            length, start, msg_id = data[i + 1], i + 6, data[i + 5]
            end = start + length + 2
        else:
            return None
        if end > n:
            return None
        offset = TARGET_OFFSETS.get(msg_id)
        target = None if offset is None else data[start + offset] if offset < length else 0
        out.append((msg_id, target))
        i = end
    return out


def triage(data: bytes, sysid: int) -> Kind:
    """The :class:`Kind` of a datagram received by the vehicle of system id ``sysid``."""
    packets = headers(data)
    if not packets:
        return Kind.DAMAGED
    ours = [msg_id for msg_id, target in packets if target is None or target == 0 or target == sysid]
    if not ours:
        return Kind.FOREIGN
    if any(msg_id in COMMAND_IDS for msg_id in ours):
        return Kind.COMMAND
    if all(msg_id in SUPERSEDED_IDS for msg_id in ours):
        return Kind.SUPERSEDED
    return Kind.OTHER
