"""The simulator process loop of a world of several vehicles (``sitl --count N``): N lockstep links, one world.

Each vehicle k of the :class:`sitl.simulation.World` has its own :class:`sitl.lockstep.LockstepServer`
(over a :class:`sitl.simulation.VehicleView`): its TCP port (4560 + instance), its flight controller,
its sensor messages, its UDP MAVLink component (truth, ``SIM_*`` parameters).  Each period every link
sends its HIL_SENSOR first (the flight controllers compute their steps side by side), then the loop waits
for every HIL_ACTUATOR_CONTROLS, and only then steps the world: the world steps only when EVERY flight
controller has answered, so a run is deterministic for a seed, as with one vehicle.

A hold (``SIM_HOLD_MS``, :mod:`sitl.hold`) stops the whole world, every link served meanwhile.

Start: the loop serves nothing until every flight controller has connected (each link's accept serves
every vehicle's ``SIM_*`` parameters meanwhile).  A flight controller that disconnects pauses the whole
world (the others wait for their next HIL_SENSOR) until it is back; it then gets the period it missed.
"""

from __future__ import annotations

import sys
import time
from typing import Sequence

from sitl.lockstep import PACE_AHEAD_S, LockstepServer
from sitl.simulation import World


def _log(text: str) -> None:
    print(f"[sitl] {text}", file=sys.stderr, flush=True)


class WorldLockstep:
    """The links of ``servers`` (vehicle k's at position k) stepping ``world`` together; ``speed`` as
    :class:`sitl.lockstep.LockstepServer` (None: as fast as lockstep allows)."""

    def __init__(self, world: World, servers: Sequence[LockstepServer], speed: float | None) -> None:
        self.world = world
        self.servers = list(servers)
        for server in self.servers:
            server.prepares = False  # the world's prepare_step once a period (_period), not once per vehicle
        self.speed = speed
        self.steps = 0

    def close(self) -> None:
        for server in self.servers:
            server.close()

    def _others(self, server: LockstepServer) -> list[LockstepServer]:
        return [s for s in self.servers if s is not server]

    def _accept_all(self) -> None:
        for server in self.servers:
            server._accept(self._others(server))

    def _period(self) -> list[LockstepServer]:
        """Sensors to every link, then every link's actuator controls; the links that closed."""
        lost = []
        for server in self.servers:
            try:
                server._send_sensors()
            except OSError:
                lost.append(server)
        self.world.prepare_step()  # (while the flight controllers compute: sitl.lockstep does the same)
        for server in self.servers:
            if server in lost:
                continue
            try:
                alive = server._wait_actuators()
            except OSError:
                alive = False
            if not alive:
                lost.append(server)
        return lost

    def _reconnect(self, server: LockstepServer) -> None:
        """The flight controller of ``server`` is gone: wait for it (or a new one) and serve it the period."""
        while True:
            _log(f"flight controller on TCP port {server.port} disconnected; the world is paused")
            server.conn.close()
            server._accept(self._others(server))
            try:
                server._send_sensors()
                if server._wait_actuators():
                    return
            except OSError:
                pass

    def run(self, duration_s: float | None = None) -> None:
        self._accept_all()
        wall0, sim0 = time.monotonic(), self.world.time_us
        hold = self.servers[0].hold  # one world, one hold (SIM_HOLD_MS, sitl/hold.py), set on any vehicle's component
        while duration_s is None or self.world.time_us < duration_s * 1e6:
            if hold.reached(self.world.time_us):  # before the period's sensors, as sitl.lockstep does for one vehicle
                wall0 += hold.wait(self.servers, self.world.time_us)
            lost = self._period()
            if lost:
                for server in lost:
                    self._reconnect(server)
                wall0, sim0 = time.monotonic(), self.world.time_us
            self.world.step([s.motor_commands for s in self.servers])
            self.steps += 1
            for server in self.servers:
                server.steps += 1
            if self.speed is not None:
                ahead = (self.world.time_us - sim0) / 1e6 / self.speed - (time.monotonic() - wall0)
                if ahead > PACE_AHEAD_S:
                    time.sleep(ahead)
