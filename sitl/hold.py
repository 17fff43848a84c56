"""Holding the simulation at a simulated time (``SIM_HOLD_MS``), so a client acts between two steps.

A run driven from the ground (a benchmark, a campaign) is reproducible only if every command lands on the
same simulated step whatever the wall clock does.  So a client sets ``SIM_HOLD_MS`` (INT32, ms of
simulated time, 0 = never hold) on the simulator's UDP component; when the simulated clock reaches it,
the lockstep loop calls :meth:`SimHold.wait` *before* sending the sensors of that time: the physics is at
the hold time, the flight controller has finished the step before it (its clock reads hold - 4 ms), and
nothing steps until ``SIM_HOLD_MS`` moves later (or to 0).  Meanwhile the simulator keeps serving:

* on entering the hold, on UDP (14740 + instance): the ground truth at the hold time (HIL_STATE_QUATERNION,
  LOCAL_POSITION_NED, the UGV's), then SYSTEM_TIME with ``time_boot_ms`` = the hold time and
  ``time_unix_usec`` 0: "held here" (sent again every :data:`KEEPALIVE_S` of wall time while held);
* on the lockstep TCP link: a HEARTBEAT every :data:`KEEPALIVE_S` of wall time (the first at once), its
  ``custom_mode`` the hold time in ms, which the flight controller takes for "alive, held"
  (``autopilot/sim_link_watch.py``, ``autopilot/lockstep_loop.py``) instead of a lost simulator; its
  ``SIM_*`` requests on that link (failure injection) are answered as between two steps;
* the ``SIM_*`` parameter service and the 1 Hz heartbeat of :mod:`sitl.param_server`.

One world, one clock, one hold: :data:`WORLD_HOLD` is the process's hold setting, part of every vehicle's
``SIM_*`` list (:class:`sitl.sim_params.SimParameters`), so a hold set on any vehicle's component stops the
whole world.  Its range is what an INT32 parameter carries exactly (2**23 - 1 ms: 2 h 19 min 48 s).

A hold does not change what the simulation computes: the same seed and the same holds give the same
steps, whether a hold lasts a millisecond or a minute.
"""

from __future__ import annotations

import select
import socket
import time
from dataclasses import dataclass
from typing import Protocol, Sequence

from pymavlink.dialects.v20 import common as mavlink

from mavsim_core.param_types import ParamType
from sitl.sim_settings import sim_param

KEEPALIVE_S = 0.2  # wall seconds between two HEARTBEATs to the flight controller (and "held" reports) while held
HOLD_PARAM = "SIM_HOLD_MS"


@dataclass
class HoldSettings:
    """The hold time (ms of simulated time; 0: never hold)."""

    hold_ms: int = sim_param(
        HOLD_PARAM,
        0,
        0,
        2**23 - 1,  # sitl.sim_params.INT32_FLOAT_SAFE: exact in a float32
        "ms",
        "Hold the simulation when its clock reaches this time, until set later (0 = never); docs/simulator.md",
        ParamType.INT32,
    )


WORLD_HOLD = HoldSettings()  # the process simulates one world: one clock, one hold (see the module docstring)


class HeldServer(Protocol):
    """What :meth:`SimHold.wait` uses of a vehicle's lockstep server (:class:`sitl.lockstep.LockstepServer`)."""

    conn: socket.socket | None  # the lockstep TCP link to the flight controller (None: not connected)
    parser: object  # its StreamParser (keeps a partial frame between reads)
    link_params: object  # sitl.link_params.LinkParams: the flight controller's SIM_* requests
    param_server: object  # sitl.param_server.SimParamServer, or None
    sim: object  # the vehicle's Simulation / VehicleView: ``truth()``

    def _pack(self, msg: mavlink.MAVLink_message) -> bytes: ...

    def send_heartbeat(self, state: int, time_us: int) -> None: ...

    def _send_truth(self, truth: object) -> None: ...


class SimHold:
    """The hold of one world (``settings``: :data:`WORLD_HOLD` unless given): see the module docstring."""

    def __init__(self, settings: HoldSettings = WORLD_HOLD) -> None:
        self.settings = settings
        self.holds = 0  # holds entered (a counter for logs and tests)

    def reached(self, time_us: int) -> bool:
        """True when the simulated clock (µs) is at or past a hold that is set."""
        hold_ms = self.settings.hold_ms
        return hold_ms > 0 and time_us >= hold_ms * 1000

    def wait(self, servers: Sequence[HeldServer], time_us: int) -> float:
        """Serve every vehicle's links without stepping until the hold moves past ``time_us`` (or is 0), or a
        flight controller's TCP link closes (the loop then finds it closed); the wall seconds spent."""
        start = time.monotonic()
        self.holds += 1
        links = [_HeldLink(s) for s in servers]
        for link in links:
            link.keepalive(time_us, with_truth=True)
        next_keepalive = start + KEEPALIVE_S
        while self.reached(time_us):
            socks = [s for link in links for s in link.sockets()]
            now = time.monotonic()
            select.select(socks, [], [], max(0.0, next_keepalive - now))
            now = time.monotonic()
            if not all(link.serve(now) for link in links):
                break
            if now >= next_keepalive:
                for link in links:
                    link.keepalive(time_us, with_truth=False)
                next_keepalive = now + KEEPALIVE_S
        return time.monotonic() - start


class _HeldLink:
    """One vehicle's links while held: its TCP link to the flight controller and its UDP component."""

    def __init__(self, server: HeldServer) -> None:
        self.server = server

    def sockets(self) -> list[socket.socket]:
        s = self.server
        out = [s.conn] if s.conn is not None else []
        if s.param_server is not None:
            out.append(s.param_server.sock)
        return out

    def keepalive(self, time_us: int, with_truth: bool) -> None:
        """HEARTBEAT to the flight controller; ("held here" and, on entering, the truth) on UDP."""
        s = self.server
        s.send_heartbeat(mavlink.MAV_STATE_STANDBY, time_us)  # custom_mode: the hold time, ms
        server = s.param_server
        if server is not None:
            if with_truth:
                s._send_truth(s.sim.truth())
            server.send(server.encode([mavlink.MAVLink_system_time_message(0, time_us // 1000)]))

    def serve(self, now_wall_s: float) -> bool:
        """The UDP component's work, then the flight controller's requests; False if its TCP link closed."""
        s = self.server
        if s.param_server is not None:
            s.param_server.poll(now_wall_s)
        if s.conn is None:
            return True
        while True:
            try:
                data = s.conn.recv(65536, socket.MSG_DONTWAIT)
            except BlockingIOError:
                return True
            except OSError:
                return False
            if not data:
                return False
            replies = []
            for msg in s.parser.parse(data):
                if msg.get_type() != "HIL_ACTUATOR_CONTROLS":  # (none comes: no sensors were sent)
                    replies += s.link_params.handle(msg)
            if replies:
                s.conn.sendall(b"".join(s._pack(r) for r in replies))
