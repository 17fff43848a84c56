"""PROTOCOL_VERSION (message 300), which pymavlink's generated dialects leave out (it is marked
work-in-progress in common.xml, so pymavlink skips it; MAVLink's C library, MAVSDK and
QGroundControl have it).

:class:`MAVLink_protocol_version_message` packs and decodes it like a generated pymavlink class
(fields in wire order: three uint16, two uint8[8]; CRC extra 217, computed from the message's
definition by pymavlink's own ``mavparse``).  :func:`register` teaches a pymavlink dialect module to
decode it (the tests' clients).  The flight controller answers MAV_CMD_REQUEST_PROTOCOL_VERSION and
REQUEST_MESSAGE 300 with it, as PX4: MAVLink 2 in use (200), versions 1 to 2 understood (100..200),
the specification and library hashes unknown (zeros).
"""

from __future__ import annotations

import struct
from types import ModuleType
from typing import Sequence

from pymavlink.dialects.v20 import common as mavlink

MAVLINK_MSG_ID_PROTOCOL_VERSION = 300
VERSION, MIN_VERSION, MAX_VERSION = 200, 100, 200  # MAVLink version * 100, as PX4 reports them


class MAVLink_protocol_version_message(mavlink.MAVLink_message):
    """Version and capability of the MAVLink protocol spoken (common.xml's PROTOCOL_VERSION)."""

    id = MAVLINK_MSG_ID_PROTOCOL_VERSION
    msgname = "PROTOCOL_VERSION"
    fieldnames = ["version", "min_version", "max_version", "spec_version_hash", "library_version_hash"]
    ordered_fieldnames = fieldnames
    fieldtypes = ["uint16_t", "uint16_t", "uint16_t", "uint8_t", "uint8_t"]
    fielddisplays_by_name: dict[str, str] = {}
    fieldenums_by_name: dict[str, str] = {}
    fieldunits_by_name: dict[str, str] = {}
    native_format = bytearray(b"<HHHBB")
    orders = [0, 1, 2, 3, 4]
    lengths = [1, 1, 1, 8, 8]
    array_lengths = [0, 0, 0, 8, 8]
    crc_extra = 217
    unpacker = struct.Struct("<HHH8B8B")
    instance_field = None
    instance_offset = -1

    def __init__(
        self,
        version: int,
        min_version: int,
        max_version: int,
        spec_version_hash: Sequence[int],
        library_version_hash: Sequence[int],
    ) -> None:
        mavlink.MAVLink_message.__init__(self, self.id, self.msgname)
        self._fieldnames = self.fieldnames
        self._instance_field = self.instance_field
        self._instance_offset = self.instance_offset
        self.version = version
        self.min_version = min_version
        self.max_version = max_version
        self.spec_version_hash = spec_version_hash
        self.library_version_hash = library_version_hash

    def pack(self, mav: mavlink.MAVLink, force_mavlink1: bool = False) -> bytes:
        payload = self.unpacker.pack(
            self.version, self.min_version, self.max_version, *self.spec_version_hash, *self.library_version_hash
        )
        return self._pack(mav, self.crc_extra, payload, force_mavlink1=force_mavlink1)


def protocol_version() -> MAVLink_protocol_version_message:
    """PROTOCOL_VERSION as this flight controller answers it (module docstring)."""
    return MAVLink_protocol_version_message(VERSION, MIN_VERSION, MAX_VERSION, [0] * 8, [0] * 8)


def register(dialect: ModuleType = mavlink) -> None:
    """Let ``dialect``'s parsers decode PROTOCOL_VERSION (a pymavlink dialect module's ``mavlink_map``)."""
    dialect.mavlink_map.setdefault(MAVLINK_MSG_ID_PROTOCOL_VERSION, MAVLink_protocol_version_message)
