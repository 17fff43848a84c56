"""Low-latency receive for the lockstep link.

In lockstep the two processes take turns: each waits for the other's reply.
Blocking at once lets the CPU go idle, and on virtual machines the wake-up that
follows costs tens of microseconds, more than the work of a step.  So a receive
first polls without blocking for a short spin budget, then blocks.  The spin is
adaptive: if the previous wait was longer than the budget (the peer is paced to
real time, or busy), the next receive blocks immediately and wastes no CPU.

The budget is short (100 us): a flight runs three processes (simulator, flight
controller, the ground station or test) on two cores here, and a longer spin took
CPU from the process that had work.  ``vehicle_benchmark.py`` measured 9.5-9.9x with
a 500 us budget against 9.8-10.6x with 100 us or none (three alternating runs each).
"""

from __future__ import annotations

import socket
import time

SPIN_BUDGET_S = 0.0001  # s


class SpinReceiver:
    def __init__(self, sock: socket.socket, spin_budget_s: float = SPIN_BUDGET_S) -> None:
        self.sock = sock
        self.budget = spin_budget_s
        self._spin = True

    def recv(self, bufsize: int = 65536, timeout_s: float | None = None) -> bytes:
        """Like ``sock.recv``; raises ``socket.timeout`` after ``timeout_s`` (None: wait forever)."""
        start = time.perf_counter()
        if self._spin:
            deadline = start + self.budget
            while True:
                try:
                    return self.sock.recv(bufsize, socket.MSG_DONTWAIT)
                except BlockingIOError:
                    if time.perf_counter() > deadline:
                        break
        self.sock.settimeout(timeout_s)
        data = self.sock.recv(bufsize)
        self._spin = time.perf_counter() - start < self.budget * 2
        return data
