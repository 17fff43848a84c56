"""Helpers of the flight-log tests (test_flight_logs.py, test_flight_log_plots.py): MAVLink packing, reading a .tlog."""

from __future__ import annotations

import os
from pathlib import Path

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

EPOCH0_US = 1_750_000_000_000_000  # 2025-06-15, a plausible wall-clock anchor


def make_mav():
    return mavlink.MAVLink(None, 1, 1)


def read_tlog(path: Path) -> list:
    conn = mavutil.mavlink_connection(str(path), dialect="common")
    out = []
    try:
        while (m := conn.recv_match()) is not None:
            if m.get_type() != "BAD_DATA":
                out.append(m)
    finally:
        conn.close()
    return out
