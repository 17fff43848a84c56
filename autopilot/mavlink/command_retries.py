"""Retransmitted commands are answered, not carried out again (the MAVLink command protocol's ``confirmation``).

A ground station that gets no COMMAND_ACK sends the same COMMAND_LONG again with ``confirmation``
1, 2, ... (MAVSDK, QGroundControl, ``gcs``).  When the first one was carried out and only its ACK
was lost, carrying out the copy may give another answer: a NAV_TAKEOFF repeated once the vehicle
is climbing is "already flying", a reboot would reboot twice.  MAVLink asks that commands be
idempotent where they can be, so a repeat is acknowledged as the first was
(https://mavlink.io/en/guide/redundancy_deduplication.html).  :class:`RetransmittedCommands` keeps,
per sender, the last COMMAND_LONG carried out and its result for RETRANSMIT_WINDOW_S of wall
time; a copy of it (same command, same seven params) with ``confirmation`` above 0 gets that
result again, and nothing else happens.  A first transmission (``confirmation`` 0) is always
carried out, so a user who repeats a command by hand repeats it.  COMMAND_INT has no
``confirmation``: it is always carried out.

Wall time, as the ground station's retries run on it (not the simulated time).
"""

from __future__ import annotations

import struct
import time
from typing import Callable

RETRANSMIT_WINDOW_S = 10.0  # wall seconds a result answers the retransmissions of its command

Sender = tuple[int, int]  # (system id, component id)
Key = tuple[int, bytes]  # (command, its params as bytes: a NaN equals the same NaN)


class RetransmittedCommands:
    """The last COMMAND_LONG of each sender and its MAV_RESULT (``clock``: wall seconds)."""

    def __init__(self, clock: Callable[[], float] = time.monotonic, window_s: float = RETRANSMIT_WINDOW_S) -> None:
        self._clock = clock
        self._window_s = window_s
        self._last: dict[Sender, tuple[Key, int, float]] = {}

    @staticmethod
    def key(command: int, params: tuple[float, ...]) -> Key:
        """A command and its params as a comparable key (the bytes they travelled as)."""
        return command, struct.pack(f"<{len(params)}d", *params)

    def earlier_result(self, sender: Sender, command: int, params: tuple[float, ...], confirmation: int) -> int | None:
        """The result of the command this one repeats (``confirmation`` > 0, same command and params,
        within the window), or None: carry it out."""
        if confirmation <= 0:
            return None
        last = self._last.get(sender)
        if last is None:
            return None
        key, result, when = last
        if key != self.key(command, params) or self._clock() - when > self._window_s:
            return None
        return result

    def carried_out(self, sender: Sender, command: int, params: tuple[float, ...], result: int) -> None:
        """Note a command carried out and its result."""
        self._last[sender] = (self.key(command, params), int(result), self._clock())
        if len(self._last) > 64:  # senders come and go: keep the table small
            now = self._clock()
            self._last = {s: v for s, v in self._last.items() if now - v[2] <= self._window_s}
