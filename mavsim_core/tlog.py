"""Telemetry logs (``.tlog``): MAVLink packets, each after its 8-byte timestamp.

The format QGroundControl and MAVProxy write and pymavlink reads
(``mavutil.mavlink_connection("flight.tlog")``, ``mavlogdump.py flight.tlog``): for
every packet, the time in microseconds since the Unix epoch as a big-endian uint64,
then the packet's bytes as they went over the link.

Timestamps: readers expect wall-clock epoch microseconds, but in lockstep the
flight runs on simulated time, often many times faster than real time.  So the
caller maps simulated time onto the epoch (see :class:`SimEpochClock`): the log starts
at the wall-clock time of arming and advances with simulated time, so the intervals
between packets are the vehicle's own (they agree with ``time_boot_ms``), and at
``--speed 1`` the stamps are the wall clock.
"""

from __future__ import annotations

import struct
import time
from pathlib import Path
from typing import BinaryIO

SUFFIX = ".tlog"
MAVLINK2_STX = 0xFD
MAVLINK2_HEADER_LEN = 10
_TIMESTAMP = struct.Struct(">Q")


class SimEpochClock:
    """Simulated µs -> epoch µs, anchored at one wall-clock instant."""

    def __init__(self, sim_us: int, epoch_us: int | None = None) -> None:
        self.sim_anchor_us = int(sim_us)
        self.epoch_anchor_us = int(epoch_us if epoch_us is not None else time.time_ns() // 1000)

    def __call__(self, sim_us: int) -> int:
        return self.epoch_anchor_us + (int(sim_us) - self.sim_anchor_us)


def packet_id_and_payload(packet: bytes) -> tuple[int, bytes] | None:
    """(message id, payload) of a MAVLink 2 packet; None for anything else."""
    if len(packet) < MAVLINK2_HEADER_LEN or packet[0] != MAVLINK2_STX:
        return None
    msgid = packet[7] | packet[8] << 8 | packet[9] << 16
    return msgid, bytes(packet[MAVLINK2_HEADER_LEN : MAVLINK2_HEADER_LEN + packet[1]])


class TlogWriter:
    """Append (timestamp, packet) records to a ``.tlog``; flushed to the OS every ``flush_every_us``.

    Timestamps are epoch microseconds (callers convert simulated time with a
    :class:`SimEpochClock`).  ``flush_every_us`` counts in the timestamps' time.
    """

    def __init__(self, path: str | Path, flush_every_us: int = 500_000) -> None:
        self.path = Path(path)
        self._f: BinaryIO | None = open(self.path, "wb")  # None once closed
        self.flush_every_us = flush_every_us
        self._last_flush_us: int | None = None
        self.packets = 0

    def write(self, epoch_us: int, packet: bytes) -> None:
        f = self._f
        if f is None:
            return
        f.write(_TIMESTAMP.pack(epoch_us) + packet)
        self.packets += 1
        if self._last_flush_us is None:
            self._last_flush_us = epoch_us
        elif epoch_us - self._last_flush_us >= self.flush_every_us:
            f.flush()
            self._last_flush_us = epoch_us

    def flush(self) -> None:
        if self._f is not None:
            self._f.flush()

    def close(self) -> None:
        if self._f is not None:
            self._f.close()
            self._f = None

    @property
    def closed(self) -> bool:
        return self._f is None
