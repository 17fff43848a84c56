"""mavsim_core.param_encoding: the one ParamType enum and PX4's byte-wise parameter encoding.

An integer parameter travels in PARAM_VALUE's float32 field as its own 4 bytes (little-endian),
not converted to float: INT32 1 is the float 1.4e-45.  The bytes are the exact form; a Python
float loses the signalling-NaN bit patterns, which is why the byte helpers exist.
"""

from __future__ import annotations

import math
import os
import struct

import numpy as np
import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v10 import common as mavlink1
from pymavlink.dialects.v20 import common as mavlink

from mavsim_core.param_encoding import (
    INT8,
    INT16,
    INT32,
    REAL32,
    TYPE_NAMES,
    UINT8,
    UINT16,
    UINT32,
    ParamType,
    decode_param_bytes,
    decode_param_float,
    encode_param_bytes,
    encode_param_float,
    is_integer_type,
    raw_param_value,
)

INT_RANGES = {
    UINT8: (0, 255),
    INT8: (-128, 127),
    UINT16: (0, 65535),
    INT16: (-32768, 32767),
    UINT32: (0, 2**32 - 1),
    INT32: (-(2**31), 2**31 - 1),
}
# INT32 values whose bytes are a float32 signalling NaN: 0x7F800001..0x7FBFFFFF and 0xFF800001..0xFFBFFFFF
SIGNALLING_NAN_INT32 = tuple(
    struct.unpack("<i", struct.pack("<I", bits))[0]
    for bits in (0x7F800001, 0x7FA00000, 0x7FBFFFFF, 0xFF800001, 0xFFBFFFFF)
)


# --------------------------------------------------------------------------- ParamType


def test_param_type_is_its_name_and_maps_to_mav_param_type():
    assert ParamType.INT32 == "INT32" and ParamType.REAL32 == "REAL32"
    assert str(ParamType.INT32) == "INT32" and f"{ParamType.REAL32}" == "REAL32"
    assert ParamType("INT32") is ParamType.INT32 and [t.value for t in ParamType] == ["INT32", "REAL32"]
    assert ParamType.INT32.mav_type == mavlink.MAV_PARAM_TYPE_INT32 == INT32 == 6
    assert ParamType.REAL32.mav_type == mavlink.MAV_PARAM_TYPE_REAL32 == REAL32 == 9
    for t in ParamType:
        assert ParamType.from_mav_type(t.mav_type) is t
        assert TYPE_NAMES[t.mav_type] == t.value


@pytest.mark.parametrize("mav_type", [UINT8, INT8, UINT16, INT16, UINT32, 0, 8, 10, 99])
def test_param_type_refuses_other_mav_types(mav_type):
    with pytest.raises(ValueError, match=f"unsupported MAV_PARAM_TYPE {mav_type}"):
        ParamType.from_mav_type(mav_type)


# --------------------------------------------------------------------------- byte-wise encoding


def test_int32_travels_as_its_bytes_not_as_a_float():
    assert encode_param_bytes(1, INT32) == b"\x01\x00\x00\x00"
    assert encode_param_float(1, INT32) == pytest.approx(1.401298464324817e-45, rel=1e-6)  # the float of those bytes
    assert encode_param_bytes(-1, INT32) == b"\xff\xff\xff\xff"
    assert encode_param_bytes(4001, INT32) == struct.pack("<i", 4001)
    assert encode_param_bytes(1.5, REAL32) == struct.pack("<f", 1.5)
    assert encode_param_bytes(200, UINT8) == b"\xc8\x00\x00\x00"  # narrow types padded to 4 bytes
    assert encode_param_bytes(-2, INT16) == b"\xfe\xff\x00\x00"


@pytest.mark.parametrize("mav_type", sorted(INT_RANGES))
def test_integer_round_trips_through_bytes_and_floats(mav_type):
    lo, hi = INT_RANGES[mav_type]
    rng = np.random.default_rng(mav_type)
    values = [lo, hi, 0, *(int(v) for v in rng.integers(lo, hi, 300, endpoint=True))]
    assert is_integer_type(mav_type)
    for v in values:
        raw = encode_param_bytes(v, mav_type)
        assert len(raw) == 4
        back = decode_param_bytes(raw, mav_type)
        assert back == v and isinstance(back, int)
        if mav_type != INT32 or not _is_signalling_nan(raw):
            assert decode_param_float(encode_param_float(v, mav_type), mav_type) == v


def test_real32_round_trips_float32_values():
    rng = np.random.default_rng(1)
    values = [0.0, -0.0, 1.0, -2.5, 1e-38, 3.4e38, math.inf, -math.inf, *rng.standard_normal(200) * 1e3]
    assert not is_integer_type(REAL32)
    for v in values:
        v32 = float(np.float32(v))
        back = decode_param_bytes(encode_param_bytes(v, REAL32), REAL32)
        assert back == v32 and isinstance(back, float)
        assert decode_param_float(encode_param_float(v, REAL32), REAL32) == v32
    assert math.isnan(decode_param_bytes(encode_param_bytes(math.nan, REAL32), REAL32))


def _is_signalling_nan(raw: bytes) -> bool:
    (bits,) = struct.unpack("<I", raw)
    return (bits & 0x7FC00000) == 0x7F800000 and (bits & 0x003FFFFF) != 0


def test_signalling_nan_patterns_survive_only_as_bytes():
    """The reason for the byte helpers: these INT32 values are exact as bytes, while a round trip
    through a Python float may quieten the NaN (CPython 3.11 does) and change the integer."""
    for v in SIGNALLING_NAN_INT32:
        raw = encode_param_bytes(v, INT32)
        assert _is_signalling_nan(raw)
        assert decode_param_bytes(raw, INT32) == v


@pytest.mark.parametrize(
    "value, mav_type, why",
    [
        (2.5, INT32, "not an integer"),
        (2**31, INT32, "out of range for INT32"),
        (-(2**31) - 1, INT32, "out of range for INT32"),
        (256, UINT8, "out of range for UINT8"),
        (-1, UINT32, "out of range for UINT32"),
        (1, 99, "unsupported MAV_PARAM_TYPE 99"),
    ],
)
def test_encoding_refuses_what_does_not_fit(value, mav_type, why):
    with pytest.raises(ValueError, match=why):
        encode_param_bytes(value, mav_type)


def test_decoding_refuses_unknown_types_and_pads_short_input():
    with pytest.raises(ValueError, match="unsupported MAV_PARAM_TYPE 10"):
        decode_param_bytes(b"\0\0\0\0", 10)
    assert decode_param_bytes(b"\x05", INT32) == 5  # fewer than 4 bytes: zero-padded


# --------------------------------------------------------------------------- from a received frame


@pytest.mark.parametrize("wire_version", [1, 2])
def test_raw_param_value_reads_the_bytes_of_the_frame(wire_version):
    """PARAM_VALUE packed by pymavlink and parsed back: the 4 wire bytes, for v1 and v2 frames."""
    dialect = mavlink1 if wire_version == 1 else mavlink
    sender = dialect.MAVLink(None, 1, 1)
    cases = [
        (encode_param_float(4001, INT32), INT32, struct.pack("<i", 4001)),
        (encode_param_float(-7, INT32), INT32, struct.pack("<i", -7)),
        (0.95, REAL32, struct.pack("<f", 0.95)),
        (0.0, REAL32, b"\0\0\0\0"),
    ]  # a zero value: MAVLink 2 trims no byte of it (type follows)
    for value, mav_type, expected in cases:
        frame = dialect.MAVLink_param_value_message(b"MPC_XY_P", value, mav_type, 100, 3).pack(sender)
        assert frame[0] == (0xFE if wire_version == 1 else 0xFD)
        receiver = mavlink.MAVLink(None, 255, 190)
        (msg,) = receiver.parse_buffer(frame)
        assert raw_param_value(msg) == expected
        assert decode_param_bytes(raw_param_value(msg), mav_type) == decode_param_float(value, mav_type)


def test_raw_param_value_without_a_frame_repacks_the_float():
    msg = mavlink.MAVLink_param_set_message(1, 1, b"MPC_XY_P", 1.25, REAL32)  # never packed: no buffer
    assert raw_param_value(msg) == struct.pack("<f", 1.25)
