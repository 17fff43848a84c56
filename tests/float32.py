"""A value as float32 holds it: what a vehicle reports over MAVLink (PARAM_VALUE carries a float32)."""

from __future__ import annotations

import struct


def f32(x: float) -> float:
    return struct.unpack("<f", struct.pack("<f", x))[0]
