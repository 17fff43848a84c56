"""Low-latency receive for the lockstep link.

In lockstep the two processes take turns: each waits for the other's reply.
Blocking at once lets the CPU go idle, and on virtual machines the wake-up that
follows costs tens of microseconds, more than the work of a step.  So a receive
first polls without blocking for a short spin budget, then blocks.  The spin is
adaptive: if the previous wait was longer than the budget (the peer is paced to
real time, or busy), the next receive blocks immediately and wastes no CPU.

The budget is 300 us while most spins catch the data, else 100 us.  At 10x (2026-11) a
longer spin took CPU from the process that had work (a flight runs three processes on two
cores here): ``vehicle_benchmark.py`` measured 9.5-9.9x with 500 us against 9.8-10.6x with
100 us.  At ~25x (2026-11-28, after the issue 21 speed work) the simulator waits ~100-115 us
for the flight controller's answer, just past a 100 us budget, so every step paid a blocking
wake-up on both sides (~30 us each way, per-phase timers in both loops).
``flight_benchmark.py --hover 20``, five alternating rounds on a quiet machine (whole flight,
median): 100 us 29.4x, 150 us 30.5x, 300 us 33.0x.  But two stacks on two cores (the landing
benchmark's ``--jobs 2``, camera on) lost to the long spin: 2.8x against 3.2-3.5x.  So the spin
yields the core between tries (``sched_yield``: another stack's process runs first) and falls
back to 100 us when fewer than 80 % of recent spins caught the data: the landing benchmark then
ran 3.3-3.6x (49e60b3, before all this: 3.4-3.8x in the same session) and the flight benchmark
28-32x.

Where more stacks than cores share the machine (the test suite: three workers' stacks on two cores),
no spin at all does more simulated seconds per CPU second: ``MAVSIM_LOCKSTEP_SPIN_US`` (microseconds,
read when a receiver is made, so a stack's children inherit it) sets the budget, 0 turns the spin off.
Measured 2026-12-01 (N stacks idling on the ground at ``--speed max`` together, 15-20 wall s each,
simulated seconds per CPU second of the stacks' processes): one stack 6.4-6.6 with the spin, 7.3-7.8
without (but 15 % slower in wall time: the spin is for one flight on an idle machine); two stacks
7.0 against 8.0; three 5.7-6.1 against 6.3-7.0.
"""

from __future__ import annotations

import math
import os
import select
import socket
import time
from typing import Mapping

SPIN_BUDGET_S = 0.0003  # s, unless MAVSIM_LOCKSTEP_SPIN_US says otherwise
SPIN_ENV = "MAVSIM_LOCKSTEP_SPIN_US"
SHORT_SPIN_S = 0.0001  # s, while fewer than HIT_RATE_FOR_LONG_SPIN of the spins catch the data
HIT_RATE_FOR_LONG_SPIN = 0.8
HIT_RATE_GAIN = 0.05


def spin_budget_from_env(environ: Mapping[str, str] = os.environ) -> float:
    """The spin budget, s: ``MAVSIM_LOCKSTEP_SPIN_US`` (microseconds, >= 0) if set, else SPIN_BUDGET_S.
    A value that is not a number, or negative, is a ValueError naming the variable."""
    text = environ.get(SPIN_ENV)
    if text is None or not text.strip():
        return SPIN_BUDGET_S
    try:
        micros = float(text)
    except ValueError:
        raise ValueError(f"{SPIN_ENV}={text!r}: not a number of microseconds") from None
    if not math.isfinite(micros) or micros < 0:
        raise ValueError(f"{SPIN_ENV}={text!r}: must be a finite number of microseconds >= 0")
    return micros * 1e-6


class SpinReceiver:
    """Receives on a blocking socket: spins on non-blocking reads for the budget, then waits in ``poll``.

    The socket stays blocking (its timeout None) so that ``sendall`` on it blocks as usual; the waits
    with a timeout are ``poll`` calls, never ``settimeout`` (a socket with a timeout makes even a
    MSG_DONTWAIT read wait up to the timeout first, which turned the spin into a sleep).
    """

    def __init__(self, sock: socket.socket, spin_budget_s: float | None = None) -> None:
        """``spin_budget_s``: None for :func:`spin_budget_from_env`; 0 never spins."""
        self.sock = sock
        self.budget = spin_budget_from_env() if spin_budget_s is None else spin_budget_s
        self._spin = self.budget > 0
        self._hits = 1.0  # running share of spins that caught the data (HIT_RATE_GAIN per receive)
        self._poll = select.poll()
        self._poll.register(sock, select.POLLIN)

    @property
    def spin_budget_s(self) -> float:
        """How long the next receive spins (if it spins at all): the budget, or SHORT_SPIN_S while few spins
        catch the data."""
        if self.budget <= 0:
            return 0.0
        return self.budget if self._hits >= HIT_RATE_FOR_LONG_SPIN else SHORT_SPIN_S

    def recv(self, bufsize: int = 65536, timeout_s: float | None = None) -> bytes:
        """Like ``sock.recv``; raises ``socket.timeout`` after ``timeout_s`` (None: wait forever)."""
        if self.sock.gettimeout() is not None:
            self.sock.settimeout(None)  # blocking (someone set a timeout on it since)
        start = time.perf_counter()
        if self._spin:
            deadline = start + self.spin_budget_s
            while True:
                try:
                    data = self.sock.recv(bufsize, socket.MSG_DONTWAIT)
                    self._hits += HIT_RATE_GAIN * (1.0 - self._hits)
                    return data
                except BlockingIOError:
                    if time.perf_counter() > deadline:
                        break
                    os.sched_yield()  # a process with work on this core (another stack's) runs first
            self._hits -= HIT_RATE_GAIN * self._hits
        wait_ms = None if timeout_s is None else max(0, math.ceil(timeout_s * 1000.0))
        if not self._poll.poll(wait_ms):
            raise TimeoutError("timed out")  # socket.timeout is TimeoutError
        data = self.sock.recv(bufsize)  # readable (or closed: b"", or an error raised)
        self._spin = self.budget > 0 and time.perf_counter() - start < self.budget * 2
        return data
