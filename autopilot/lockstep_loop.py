"""The flight-controller process loop: lockstep with the simulator, the ground-station link in between.

Receive the simulator's messages; on each HIL_SENSOR run one iteration of the
flight controller and answer with HIL_ACTUATOR_CONTROLS; then, while the
simulator steps its physics, run the 50 Hz outer loops (``after_step``) and, in
another 4 ms period, let the ground-station link receive, stream telemetry and
send events; in the other periods the link only answers what has arrived
(``poll``).  HIL_GPS and BATTERY_STATUS are kept for the next step.  Times are
the simulator's (``time_usec`` of HIL_SENSOR, microseconds).

The simulator link is watched (:class:`autopilot.sim_link_watch.SimLinkWatch`): when it closes or
stays silent for SIM_LOSS_TIMEOUT_S of wall-clock time it is lost, the flight controller says so
(:meth:`FlightController.on_sim_link_lost`: STATUSTEXT CRITICAL, HEARTBEAT MAV_STATE_CRITICAL) and
the ground-station link goes on at 50 Hz of wall-clock time while the loop reconnects, so ground
stations keep getting HEARTBEAT and STATUSTEXT.  A connection counts only once the simulator has
answered within HANDSHAKE_TIMEOUT_S (:meth:`SimLink.connect`).

A simulator that *holds* (``SIM_HOLD_MS``, ``sitl/hold.py``) sends a HEARTBEAT (``custom_mode``: the hold
time, ms) instead of sensors: the flight controller is then alive and paused (:class:`HeldService`).  On
entering a hold it runs one ground-station link iteration at its latest sensor time (what its last steps
queued goes out: STATUSTEXTs, due streams), then sends its HEARTBEAT and SYSTEM_TIME with ``time_unix_usec``
0 and ``time_boot_ms`` the hold time: "held here, and everything before has been sent" (on the same socket,
so a client that has this has all the rest; ``gcs/launcher/sim_stepper.py`` waits for it).  While held it
waits on the simulator link and the ground-station sockets together, answers whatever comes at once (a
command is handled and acknowledged now and acts from the next step), streams nothing, and repeats that
HEARTBEAT and SYSTEM_TIME at 1 Hz of wall time and in answer to a ground station's HEARTBEAT, so clients
keep seeing the vehicle through a hold of any length.  All of it happens at the same simulated times in
every run through the same holds.
"""

from __future__ import annotations

import select
import time
from typing import TYPE_CHECKING

from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink.sim_link import battery_from_msg, gps_from_msg, imu_from_msg
from autopilot.mavlink.telemetry_more import link_builders
from autopilot.sim_link_watch import SimLinkWatch
from mavsim_core.constants import LOCKSTEP_DT_US

if TYPE_CHECKING:  # types only: the process imports these where it builds them (the recorder only when logging)
    from autopilot.flight_controller import FlightController
    from autopilot.flight_recorder import FlightRecorder
    from autopilot.mavlink.link import GcsLink
    from autopilot.mavlink.sim_link import SimLink

LINK_EVERY, LINK_PHASE = 5, 2  # ground-station link at 50 Hz of simulated time, off the outer loop's period
HANDSHAKE_TIMEOUT_S = 5.0  # wall seconds for the simulator's first message after connecting (it drops a
# silent peer after 2 s, sitl/peer_accept.py, so one squatter ahead of us in its queue is survived)
IDLE_PERIOD_S = 0.02  # while the simulator is away, the ground-station link runs at 50 Hz of wall time
HELD_SLICE_S = 0.05  # while the simulator holds: the longest wait on its link and the ground stations' sockets
HELD_HEARTBEAT_S = 1.0  # while the simulator holds: our HEARTBEAT at least this often (wall seconds)


class HeldService:
    """The ground-station link while the simulator holds (see the module docstring)."""

    def __init__(self, link: GcsLink, fc: FlightController) -> None:
        self.link, self.fc = link, fc
        self._heartbeat = link_builders(link.identity)[mavlink.MAVLINK_MSG_ID_HEARTBEAT]
        self._next_heartbeat_s = 0.0
        self._gcs_seen: object = None  # the latest ground-station HEARTBEAT answered
        self._held_here: tuple = ()  # our HEARTBEAT as of the hold's start, and "held at" (SYSTEM_TIME)

    def enter(self, hold_ms: int, now_us: int) -> None:
        """The simulator holds at ``hold_ms``: what the last steps queued goes out, then "held here".  The
        HEARTBEAT is built once, here: repeating it later costs no telemetry snapshot, whose bookkeeping
        (arming and take-off times) would then depend on how long the hold lasted."""
        self.link.update(now_us)
        self._held_here = (
            self._heartbeat(self.link.vehicle.snapshot(), now_us),
            mavlink.MAVLink_system_time_message(0, hold_ms),  # unix time 0: "held at" (the module docstring)
        )
        self._next_heartbeat_s = 0.0
        self.send_heartbeat_if_due(time.monotonic())

    def wait(self, sim: SimLink, now_us: int) -> bool:
        """Wait up to HELD_SLICE_S for the simulator or a ground station, answer the ground stations (time
        ``now_us``, the latest sensor time); True if the simulator link has something to read."""
        assert sim.sock is not None  # (connected: it was held)
        socks = [sim.sock] + [ep.sock for ep in self.link.endpoints]
        readable, _, _ = select.select(socks, [], [], HELD_SLICE_S)
        self.link.serve_held(now_us)
        self.send_heartbeat_if_due(time.monotonic())
        return sim.sock in readable

    def send_heartbeat_if_due(self, wall_s: float) -> None:
        """The hold's HEARTBEAT and "held at", if HELD_HEARTBEAT_S has passed or a ground station's came."""
        gcs = self.fc.commander.inputs.gcs_heartbeat  # (time, wall time) of a ground station's latest HEARTBEAT
        if wall_s < self._next_heartbeat_s and gcs == self._gcs_seen:
            return
        self._gcs_seen, self._next_heartbeat_s = gcs, wall_s + HELD_HEARTBEAT_S
        for msg in self._held_here:
            for ep in self.link.endpoints:
                ep.send(msg)


def run_lockstep(sim: SimLink, fc: FlightController, link: GcsLink, recorder: FlightRecorder | None) -> None:
    """Connect to the simulator and fly in lockstep with it; reconnect when it closes the link or goes silent.

    Returns only by an exception (KeyboardInterrupt, SystemExit from SIGTERM); the caller closes
    ``link`` and ``recorder``.  While the simulator is away the ground stations are still answered.
    """
    watch = SimLinkWatch()
    held = HeldService(link, fc)

    def serve_ground() -> None:
        link.update(watch.link_time_us(time.monotonic()))

    sim.connect(on_wait=serve_ground, handshake_timeout_s=HANDSHAKE_TIMEOUT_S)
    print("[autopilot] connected to the simulator", flush=True)
    gps = None
    while True:
        if watch.held and not sim.pending and not held.wait(sim, watch.sim_us):
            if watch.check(time.monotonic(), closed=False):  # held, yet its HEARTBEATs stopped: lost
                print("[autopilot] nothing from the held simulator: link lost", flush=True)
                fc.on_sim_link_lost()
            continue
        msgs = sim.receive(timeout_s=IDLE_PERIOD_S if watch.lost else 0.05)
        if msgs is None:
            print("[autopilot] simulator closed the link; reconnecting", flush=True)
            if watch.check(time.monotonic(), closed=True):
                fc.on_sim_link_lost()
            sim.close()
            sim.connect(on_wait=serve_ground, handshake_timeout_s=HANDSHAKE_TIMEOUT_S)
            print("[autopilot] connected to the simulator", flush=True)
            gps = None
            continue
        if not msgs:  # the simulator is paused (or hung: lost after SIM_LOSS_TIMEOUT_S); the link still closes
            if watch.check(time.monotonic(), closed=False):  # if it dies, and it may come back on its own
                print("[autopilot] no sensor data from the simulator: link lost", flush=True)
                fc.on_sim_link_lost()
            serve_ground()  # keep answering ground stations
            continue
        for m in msgs:
            t = m.get_type()
            if t == "HIL_SENSOR":
                imu = imu_from_msg(m)
                wall_s = time.monotonic()  # one reading per step: the link watch and the input-loss timers
                if watch.on_sensor(imu.timestamp_us, wall_s):
                    print("[autopilot] sensor data from the simulator again: link regained", flush=True)
                    fc.on_sim_link_regained()
                commands = fc.step(imu, gps)
                gps = None
                now_us = imu.timestamp_us
                live = fc.commander.status.armed or fc.commander.motor_test_run is not None  # DO_MOTOR_TEST
                sim.send_actuators(now_us, commands, live)
                if recorder is not None:
                    recorder.on_step(imu)
                # While the simulator steps its physics: the outer loops, and in another
                # period the ground-station link (both 50 Hz), so the two never add up.
                fc.wall_s = wall_s  # the input-loss timers also measure the clients' clock (but --input-clock sim)
                fc.after_step()
                if (now_us // LOCKSTEP_DT_US) % LINK_EVERY == LINK_PHASE:
                    for device_step in sim.device_steps:  # the gimbal manager's setpoints (link_setup.py)
                        device_step(now_us)
                    link.update(now_us)
                else:
                    link.poll(now_us)  # requests are answered within a step, streams stay at 50 Hz
            elif t == "HIL_GPS":
                gps = gps_from_msg(m)
            elif t == "BATTERY_STATUS":
                fc.commander.set_battery(battery_from_msg(m))
            elif t == "LANDING_TARGET":  # the simulated companion computer's (sitl/companion.py)
                fc.on_landing_target(m, m.get_srcSystem())
            elif t in sim.device_handlers:  # the gimbal device's status (autopilot/mavlink/gimbal_manager.py)
                sim.device_handlers[t](m)
            elif t == "HEARTBEAT" and m.system_status == mavlink.MAV_STATE_ACTIVE:
                watch.on_busy(time.monotonic())  # the simulator waits for its camera (sitl/lockstep.py): alive
            elif t == "HEARTBEAT":  # the simulator holds (sitl/hold.py): alive, no step until its sensors come
                entering = not watch.held
                if watch.on_held(time.monotonic()):
                    print("[autopilot] the simulator holds: link regained", flush=True)
                    fc.on_sim_link_regained()
                if entering:
                    held.enter(m.custom_mode, watch.sim_us)
