"""The ground-station link's receive loop: drain every socket each call, handle what fits a time budget.

Each call (:meth:`RxDrain.drain`, from every :meth:`GcsLink.update` and :meth:`GcsLink.poll`) reads
every datagram waiting on both sockets (up to RX_READ_MAX each) and sorts it by its headers
(:func:`autopilot.mavlink.rx_triage.triage`, ~2 µs a datagram) before parsing anything:

* not whole MAVLink packets: dropped, counted as damage (``rx_errors``);
* every packet addressed to another system: dropped unparsed (``rx_foreign``);
* the rest is parsed and handled (~20 µs a datagram) in arrival order while the call's time budget
  RX_BUDGET_S lasts, shared by the sockets (a flood on one cannot take the other's time), and the
  first RX_MIN_HANDLED of each socket whatever the budget (a link's usual traffic is one or two a call);
* past the budget, commands and SET_MODE for us are still handled: RX_KEEP_PER_SENDER per sender
  address and RX_KEEP_MAX in all per call, so a flood of commands from one address cannot crowd
  out the pilot's; commands over those counts wait for the next call (a backlog of RX_BACKLOG_MAX,
  handled first); everything else is dropped and counted (``rx_dropped``): sticks, setpoints and
  heartbeats are replaced by newer ones, requests are asked again by their protocols' retries.

So a flood costs the flight controller at most the budget plus ~2 µs a datagram per call, its
control loop keeps its rate, and LAND or RTL is answered within the call that reads it.
(PX4 reads its UDP link in a thread of its own and queues commands for the commander: the queue,
not the loop, overflows.)  The budgets are 1 ms per link update (50 Hz) and 0.2 ms per poll (the
other four 4 ms steps of five): at real time at most 9 % of the wall clock goes to handling what
arrives, whatever arrives, and the flight controller's own work takes under 1 ms of each 4 ms step.
"""

from __future__ import annotations

import select
import time
from collections import deque
from dataclasses import dataclass
from typing import Callable, Sequence

from autopilot.mavlink.endpoint import LinkEndpoint
from autopilot.mavlink.rx_triage import Kind, triage

RX_BUDGET_S = 0.001  # CPU time for parsing and handling per link update (50 Hz), both sockets together
RX_POLL_BUDGET_S = 0.0002  # the same per poll (the other steps, 200 Hz)
RX_MIN_HANDLED = 4  # datagrams for us handled per socket and call whatever the budget (a quiet link: all)
RX_READ_MAX = 1000  # datagrams read per socket and call at most (the rest waits in the socket's buffer)
RX_KEEP_MAX = 20  # commands handled per call past the budget
RX_KEEP_PER_SENDER = 5  # of those, from one sender address
RX_BACKLOG_MAX = 200  # commands past those counts kept for the next call; more are dropped

# The budget is measured in the CPU time of the thread (CLOCK_THREAD_CPUTIME_ID, 0.8 µs a reading), not
# on the wall clock: it bounds the link's own work, and a process preempted by another program does not
# lose the few messages of a quiet link to time it did not use.
_clock = time.thread_time

Address = tuple[str, int]
Handle = Callable[[LinkEndpoint, bytes, Address], None]


@dataclass(slots=True)
class RxCounters:
    """What the receive loop counts (the link reports them as its own counters)."""

    rx_errors: int = 0  # damaged datagrams
    rx_dropped: int = 0  # datagrams for us dropped unparsed: no time left (or a full backlog)
    rx_foreign: int = 0  # datagrams addressed to other systems only, dropped unparsed


class RxDrain:
    """The receive loop of a link's ``endpoints``: ``handle(endpoint, datagram, sender)`` parses and handles
    one datagram; the counts go to ``counters``."""

    def __init__(self, sysid: int, endpoints: Sequence[LinkEndpoint], handle: Handle, counters: RxCounters) -> None:
        self.sysid = sysid
        self.endpoints = endpoints
        self.handle = handle
        self.counters = counters
        self.backlog: deque[tuple[LinkEndpoint, bytes, Address]] = deque()  # commands read, not yet handled
        self._kept: dict[Address, int] = {}  # commands handled past the budget in this call, per sender
        self._handled = 0  # datagrams handled in this call from the socket being sorted (or the backlog)
        self.sockets = select.poll()  # every socket: sockets.poll(0) is what can be read (pending())
        for ep in endpoints:
            self.sockets.register(ep.sock, select.POLLIN)

    def pending(self) -> bool:
        """Something to read or a command kept from the last call (one poll(2), no exception)."""
        return bool(self.sockets.poll(0)) or bool(self.backlog)

    def drain(self, poll: bool = False) -> None:
        """Read every socket; handle the backlog, then what came, within the budget of an update (or a
        ``poll``: see the module).  Nothing to read and no backlog: one poll(2), nothing else."""
        if not self.backlog and not self.sockets.poll(0):
            return
        end = _clock() + (RX_POLL_BUDGET_S if poll else RX_BUDGET_S)
        waiting = [(ep, ep.read_waiting(RX_READ_MAX)) for ep in self.endpoints]
        self._kept, self._handled = {}, 0
        backlog, self.backlog = self.backlog, deque()
        for ep, data, addr in backlog:  # read by an earlier call: before anything newer
            self._command(ep, data, addr, end)
        for k, (ep, datagrams) in enumerate(waiting):
            now = _clock()
            deadline = now + max(end - now, 0.0) / (len(waiting) - k)  # the time left, shared by the sockets left
            self._handled = 0
            for data, addr in datagrams:
                self._sort(ep, data, addr, deadline)

    def _sort(self, ep: LinkEndpoint, data: bytes, addr: Address, deadline: float) -> None:
        kind = triage(data, self.sysid)
        if kind is Kind.DAMAGED:
            self.counters.rx_errors += 1
        elif kind is Kind.FOREIGN:
            self.counters.rx_foreign += 1
        elif kind is Kind.COMMAND:
            self._command(ep, data, addr, deadline)
        elif self._in_time(deadline):
            self._handle(ep, data, addr)
        else:
            self.counters.rx_dropped += 1

    def _in_time(self, deadline: float) -> bool:
        """Within the budget, or among the socket's first RX_MIN_HANDLED datagrams of the call."""
        return self._handled < RX_MIN_HANDLED or _clock() < deadline

    def _handle(self, ep: LinkEndpoint, data: bytes, addr: Address) -> None:
        self._handled += 1
        self.handle(ep, data, addr)

    def _command(self, ep: LinkEndpoint, data: bytes, addr: Address, deadline: float) -> None:
        """A datagram holding a command: handled in time, or within the sender's and the call's counts past
        the budget, else kept for the next call (or dropped when the backlog is full)."""
        if not self._in_time(deadline):
            kept = self._kept
            if kept.get(addr, 0) >= RX_KEEP_PER_SENDER or sum(kept.values()) >= RX_KEEP_MAX:
                if len(self.backlog) < RX_BACKLOG_MAX:
                    self.backlog.append((ep, data, addr))
                else:
                    self.counters.rx_dropped += 1
                return
            kept[addr] = kept.get(addr, 0) + 1
        self._handle(ep, data, addr)
