"""Low-latency receive for the lockstep link.

In lockstep the two processes take turns: each waits for the other's reply.
Blocking at once lets the CPU go idle, and on virtual machines the wake-up that
follows costs tens of microseconds, more than the work of a step.  So a receive
first polls without blocking for a short spin budget, then blocks.  The spin is
adaptive: if the previous wait was longer than the budget (the peer is paced to
real time, or busy), the next receive blocks immediately and wastes no CPU.

The budget is 300 us.  At 10x (2026-11) a longer spin took CPU from the process
that had work (a flight runs three processes on two cores here): ``vehicle_benchmark.py``
measured 9.5-9.9x with 500 us against 9.8-10.6x with 100 us.  At ~25x (2026-11-28, after the
issue 21 speed work) the simulator waits ~100-115 us for the flight controller's answer, just
past a 100 us budget, so every step paid a blocking wake-up on both sides (~30 us each way,
measured with per-phase timers in both loops).  ``flight_benchmark.py --hover 20``, alternating
runs on a noisy machine: 100 us 23.7, 26.9, 22.5, 28.7, 28.5x; 300 us 28.1, 27.9, 30.9, 27.2,
29.8x (whole flight).
"""

from __future__ import annotations

import math
import select
import socket
import time

SPIN_BUDGET_S = 0.0003  # s


class SpinReceiver:
    """Receives on a blocking socket: spins on non-blocking reads for the budget, then waits in ``poll``.

    The socket stays blocking (its timeout None) so that ``sendall`` on it blocks as usual; the waits
    with a timeout are ``poll`` calls, never ``settimeout`` (a socket with a timeout makes even a
    MSG_DONTWAIT read wait up to the timeout first, which turned the spin into a sleep).
    """

    def __init__(self, sock: socket.socket, spin_budget_s: float = SPIN_BUDGET_S) -> None:
        self.sock = sock
        self.budget = spin_budget_s
        self._spin = True
        self._poll = select.poll()
        self._poll.register(sock, select.POLLIN)

    def recv(self, bufsize: int = 65536, timeout_s: float | None = None) -> bytes:
        """Like ``sock.recv``; raises ``socket.timeout`` after ``timeout_s`` (None: wait forever)."""
        if self.sock.gettimeout() is not None:
            self.sock.settimeout(None)  # blocking (someone set a timeout on it since)
        start = time.perf_counter()
        if self._spin:
            deadline = start + self.budget
            while True:
                try:
                    return self.sock.recv(bufsize, socket.MSG_DONTWAIT)
                except BlockingIOError:
                    if time.perf_counter() > deadline:
                        break
        wait_ms = None if timeout_s is None else max(0, math.ceil(timeout_s * 1000.0))
        if not self._poll.poll(wait_ms):
            raise TimeoutError("timed out")  # socket.timeout is TimeoutError
        data = self.sock.recv(bufsize)  # readable (or closed: b"", or an error raised)
        self._spin = time.perf_counter() - start < self.budget * 2
        return data
