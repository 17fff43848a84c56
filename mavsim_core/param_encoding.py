"""PX4's byte-wise encoding of parameter values in MAVLink's float ``param_value``.

PARAM_VALUE / PARAM_SET carry every value in a float32 field.  PX4 (and the
flight controller here) does not convert integers to float: it copies the
integer's bytes into the field (MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE),
so an INT32 of 1 travels as the float 1.4e-45.

One module for the three users: the flight controller's parameter service, the
simulator's (``sitl.param_server``) and the bundled ground station (``gcs``).
:class:`ParamType` (:mod:`mavsim_core.param_types`) is the one parameter-type enum.

The exact form is the 4 little-endian wire bytes.  Helpers working on Python
floats are provided too, but note that a Python float cannot keep every bit
pattern: int32 values whose bytes form a *signalling* NaN (0x7F800001..0x7FBFFFFF
and 0xFF800001..0xFFBFFFFF) are changed by a float round trip, so the client
sends and decodes the raw bytes (and so do the two parameter services).
"""

from __future__ import annotations

import struct

from pymavlink.dialects.v20 import common as mavlink

from mavsim_core.param_types import ParamType

# MAV_PARAM_TYPE numbers, as the MAVLink spec (and pymavlink) defines them
UINT8 = mavlink.MAV_PARAM_TYPE_UINT8
INT8 = mavlink.MAV_PARAM_TYPE_INT8
UINT16 = mavlink.MAV_PARAM_TYPE_UINT16
INT16 = mavlink.MAV_PARAM_TYPE_INT16
UINT32 = mavlink.MAV_PARAM_TYPE_UINT32
INT32 = mavlink.MAV_PARAM_TYPE_INT32
REAL32 = mavlink.MAV_PARAM_TYPE_REAL32

__all__ = ["ParamType"]  # re-exported: the encoding and the type travel together


_INT_FORMATS: dict[int, str] = {UINT8: "<B", INT8: "<b", UINT16: "<H", INT16: "<h", UINT32: "<I", INT32: "<i"}

TYPE_NAMES: dict[int, str] = {
    UINT8: "UINT8",
    INT8: "INT8",
    UINT16: "UINT16",
    INT16: "INT16",
    UINT32: "UINT32",
    INT32: "INT32",
    REAL32: "REAL32",
}


def is_integer_type(param_type: int) -> bool:
    """True for the MAV_PARAM_TYPE integer types that fit the 4-byte field."""
    return param_type in _INT_FORMATS


def encode_param_bytes(value: float | int, param_type: int) -> bytes:
    """The 4 wire bytes of ``param_value`` for a value of the given MAV_PARAM_TYPE."""
    if param_type == REAL32:
        return struct.pack("<f", float(value))
    fmt = _INT_FORMATS.get(param_type)
    if fmt is None:
        raise ValueError(f"unsupported MAV_PARAM_TYPE {param_type}")
    if float(value) != int(value):
        raise ValueError(f"{value!r} is not an integer ({TYPE_NAMES[param_type]} parameter)")
    try:
        raw = struct.pack(fmt, int(value))
    except struct.error:
        raise ValueError(f"{value!r} out of range for {TYPE_NAMES[param_type]}") from None
    return raw.ljust(4, b"\0")


def decode_param_bytes(raw: bytes, param_type: int) -> int | float:
    """A value from the 4 wire bytes of ``param_value``: int for integer types, float for REAL32."""
    raw = bytes(raw[:4]).ljust(4, b"\0")
    if param_type == REAL32:
        return struct.unpack("<f", raw)[0]
    fmt = _INT_FORMATS.get(param_type)
    if fmt is None:
        raise ValueError(f"unsupported MAV_PARAM_TYPE {param_type}")
    return struct.unpack(fmt, raw[: struct.calcsize(fmt)])[0]


def encode_param_float(value: float | int, param_type: int) -> float:
    """``param_value`` as a Python float (see the module note on signalling NaNs)."""
    return struct.unpack("<f", encode_param_bytes(value, param_type))[0]


def decode_param_float(param_value: float, param_type: int) -> int | float:
    """Decode a ``param_value`` already unpacked to a Python float."""
    return decode_param_bytes(struct.pack("<f", param_value), param_type)


def raw_param_value(msg) -> bytes:
    """The 4 wire bytes of ``param_value`` of a received PARAM_VALUE or PARAM_SET.

    Read from the raw MAVLink frame (the value is the first payload field of
    both), because the unpacked float may have lost a signalling-NaN bit
    pattern (and pymavlink's ``get_payload`` is offset for MAVLink 2 frames).
    Falls back to re-packing the float if the frame is unavailable.
    """
    buf = msg.get_msgbuf() if hasattr(msg, "get_msgbuf") else None
    if buf:
        header_len = 10 if buf[0] == 0xFD else 6
        payload_len = buf[1]
        return bytes(buf[header_len : header_len + min(4, payload_len)]).ljust(4, b"\0")
    return struct.pack("<f", msg.param_value)
