"""Drive a held simulation in slices of simulated time, so a flight script is reproducible.

A script that commands the vehicle when the wall clock says so lands its commands on different simulated
steps from run to run.  :class:`SimStepper` instead keeps the simulator held (``SIM_HOLD_MS``,
``sitl/hold.py``) and moves the hold on in slices: :meth:`SimStepper.advance` sets the hold ``sim_s``
later and waits until the simulator holds there; :meth:`SimStepper.run_until` advances in slices of
``check_every_s`` until a condition holds, evaluated only while held.  Commands are sent only while held
and each is waited for (its COMMAND_ACK) before the next advance, so it acts from the step after the hold.

What a condition may read, all fixed by the seed and the hold times:

* the simulator's truth at the hold time (``truth.at(stepper.time_ms, 0)``), which arrives before the
  simulator's "held" report (:meth:`gcs.sim_client.SimClient.wait_held`);
* the flight controller's telemetry: it finished the step before the hold (hold - 4 ms) and streams nothing
  while held.  On entering a hold it sends what its last steps queued, then its HEARTBEAT and SYSTEM_TIME
  with ``time_unix_usec`` 0 and ``time_boot_ms`` the hold time (``autopilot/lockstep_loop.py``); the stepper
  waits for that report, so (one socket, in order) everything the flight controller sent up to the hold has
  arrived and the latest HEARTBEAT is the state at the hold.  The first hold, which the flight controller
  entered before this client listened, is met with two round trips instead (TIMESYNC, then REQUEST_MESSAGE
  HEARTBEAT: the second answer leaves after everything the first one's link iteration sent).

The ground station's HEARTBEAT goes out once a simulated second, from a hold (an advance is cut into holds at
most a second apart): a flight controller that ages its inputs on simulated time alone (``autopilot
--input-clock sim``) then hears the link the same way in every run, however many wall seconds a slice takes.

The simulated time of the run is the hold time (:attr:`SimStepper.time_s`), not the telemetry's.  Wall
time only bounds each wait (``timeout_s``, a safety net); a condition not met within ``max_sim_s`` of
simulated time raises :class:`SimTimeout`, the same in every run.
"""

from __future__ import annotations

import math
import time
from typing import Callable

from pymavlink.dialects.v20 import common as mavlink

from ..client import VehicleClient
from ..errors import GcsTimeout
from ..sim_client import SimClient, SimParamError

HOLD_PARAM = "SIM_HOLD_MS"
CHECK_EVERY_S = 0.1  # default slice: the conditions' resolution in simulated time
HEARTBEAT_EVERY_MS = 1000  # the longest hold-to-hold step of an advance: a HEARTBEAT may be due at each hold
HEARTBEAT_CHECK_S = 0.25  # wall seconds: how often a slice's wait looks whether the ground station's HEARTBEAT is due


class SimTimeout(GcsTimeout):
    """A condition did not hold within its simulated-time budget (deterministic, unlike a wall timeout)."""


class NotHeld(GcsTimeout):
    """The simulator is not held (``SIM_HOLD_MS`` 0 at start): a run cannot be reproduced from its start."""


class SimStepper:
    """Hold-and-advance driver of one simulator + flight controller pair (see the module docstring).

    ``timeout_s``: wall seconds for each wait (the simulator reaching a hold, an answer); a safety net.
    """

    def __init__(self, client: VehicleClient, truth: SimClient, timeout_s: float = 60.0) -> None:
        self.client, self.truth, self.timeout_s = client, truth, timeout_s
        self.time_ms = 0  # the simulated time of the current hold, ms
        self.slices = 0  # advances made
        self.vehicle_held_ms = -1  # the flight controller's latest "held at" report
        self._token = 0
        self._heartbeat_ms = -math.inf  # the hold time of the latest HEARTBEAT sent (_heartbeat_if_due)
        client.add_listener(self._on_message)
        self._listening = True

    def _on_message(self, msg) -> None:
        if msg.get_type() == "SYSTEM_TIME" and msg.time_unix_usec == 0:  # "held at" (autopilot/lockstep_loop.py)
            self.vehicle_held_ms = max(self.vehicle_held_ms, msg.time_boot_ms)

    @property
    def time_s(self) -> float:
        """The simulated time of the current hold, s."""
        return self.time_ms / 1000.0

    def start(self) -> None:
        """Wait until the simulator holds (it must have been started with ``SIM_HOLD_MS``, else NotHeld)."""
        self.truth.wait_connected(self.timeout_s)
        hold_ms = int(self.truth.get(HOLD_PARAM))
        if hold_ms <= 0:
            raise NotHeld(f"the simulator runs free: start it with --param {HOLD_PARAM}=N for a reproducible run")
        self.time_ms = self.truth.wait_held(hold_ms, self.timeout_s)
        self._sync_vehicle()

    def advance(self, sim_s: float) -> None:
        """Move the hold ``sim_s`` seconds of simulated time on and wait until the simulator holds there; in
        holds at most one ground-station HEARTBEAT period apart, each sending the HEARTBEAT that is due."""
        end_ms = self.time_ms + max(1, round(sim_s * 1000))
        while self.time_ms < end_ms:
            self._heartbeat_if_due()
            hold_ms = min(end_ms, self.time_ms + HEARTBEAT_EVERY_MS)
            self.truth.set(HOLD_PARAM, hold_ms, timeout_s=self.timeout_s)
            self.slices += 1
            self.time_ms = self._wait_held(hold_ms)
            t = self.time_ms
            self.client.wait_until(lambda: self.vehicle_held_ms >= t, self.timeout_s, f"the vehicle held at t = {t} ms")

    def _heartbeat_if_due(self) -> None:
        """The ground station's HEARTBEAT once a simulated second (its period, unless infinite: a ground station
        that falls silent), sent while held: a flight controller ageing its inputs on simulated time alone
        (``autopilot --input-clock sim``) hears the same link in every run, however long a slice lasts."""
        period_ms = self.client.heartbeat_period_s * 1000
        if math.isfinite(period_ms) and self.time_ms - self._heartbeat_ms >= period_ms:
            self._heartbeat_ms = self.time_ms
            self.client.send_heartbeat()

    def _wait_held(self, hold_ms: int) -> int:
        """Until the simulator holds at ``hold_ms``; the ground station's HEARTBEAT keeps going meanwhile (a long
        slice on a loaded machine lasts wall seconds: the vehicle would take the silence for a lost data link)."""
        deadline = time.monotonic() + self.timeout_s
        while True:
            try:
                return self.truth.wait_held(hold_ms, min(HEARTBEAT_CHECK_S, max(0.0, deadline - time.monotonic())))
            except SimParamError:
                if time.monotonic() >= deadline:
                    raise
                self.client.keep_alive()

    def run_until(
        self, predicate: Callable[[], object], max_sim_s: float, what: str, check_every_s: float = CHECK_EVERY_S
    ):
        """Advance in slices of ``check_every_s`` until ``predicate()`` (evaluated while held) is truthy; its
        value.  SimTimeout after ``max_sim_s`` of simulated time, GcsTimeout after ``timeout_s`` wall seconds
        (each slice)."""
        end_ms = self.time_ms + round(max_sim_s * 1000)
        while True:
            value = predicate()
            if value:
                return value
            if self.time_ms >= end_ms:
                raise SimTimeout(f"{what}: not within {max_sim_s:g} s of simulated time [{self.client.describe()}]")
            self.advance(min(check_every_s, (end_ms - self.time_ms) / 1000.0))

    def release(self, run_free: bool = True) -> None:
        """Stop listening to the vehicle and, with ``run_free``, let the simulation run free (``SIM_HOLD_MS`` 0;
        best effort).  Without, it stays held where it is until the stack stops, so what the simulator counts
        to the end (its camera's frames and detections) is the same in every run."""
        if self._listening:
            self._listening = False
            self.client.remove_listener(self._on_message)
        if not run_free:
            return
        try:
            self.truth.set(HOLD_PARAM, 0, timeout_s=self.timeout_s)
        except Exception:  # noqa: BLE001 - the stack may be gone already
            pass

    def _sync_vehicle(self) -> None:
        """Two round trips to the flight controller, for the first hold (see the module docstring)."""
        client = self.client
        self._token += 1
        token = self._token
        deadline = time.monotonic() + self.timeout_s
        client.conn.mav.timesync_send(0, token)  # tc1 0: a request; ts1: ours to recognise the answer
        answer = client.recv("TIMESYNC", self.timeout_s, condition=lambda m: m.ts1 == token)
        if answer is None:
            raise GcsTimeout(f"no TIMESYNC answer from the vehicle while held at t = {self.time_s:g} s")
        if answer.tc1 // 1_000_000 >= self.time_ms:  # its clock (ns) must be before the hold
            raise GcsTimeout(f"the vehicle's clock ({answer.tc1 / 1e9:g} s) is past the hold ({self.time_s:g} s)")
        client.command_long(
            mavlink.MAV_CMD_REQUEST_MESSAGE,
            mavlink.MAVLINK_MSG_ID_HEARTBEAT,
            timeout_s=max(0.1, deadline - time.monotonic()),
        ).check()
