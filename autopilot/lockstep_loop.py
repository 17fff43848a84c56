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
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

from autopilot.mavlink.sim_link import battery_from_msg, gps_from_msg, imu_from_msg
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


def run_lockstep(sim: SimLink, fc: FlightController, link: GcsLink, recorder: FlightRecorder | None) -> None:
    """Connect to the simulator and fly in lockstep with it; reconnect when it closes the link or goes silent.

    Returns only by an exception (KeyboardInterrupt, SystemExit from SIGTERM); the caller closes
    ``link`` and ``recorder``.  While the simulator is away the ground stations are still answered.
    """
    watch = SimLinkWatch()

    def serve_ground() -> None:
        link.update(watch.link_time_us(time.monotonic()))

    sim.connect(on_wait=serve_ground, handshake_timeout_s=HANDSHAKE_TIMEOUT_S)
    print("[autopilot] connected to the simulator", flush=True)
    gps = None
    while True:
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
                fc.wall_s = wall_s  # the input-loss timers also measure the clients' clock
                fc.after_step()
                if (now_us // LOCKSTEP_DT_US) % LINK_EVERY == LINK_PHASE:
                    link.update(now_us)
                else:
                    link.poll(now_us)  # requests are answered within a step, streams stay at 50 Hz
            elif t == "HIL_GPS":
                gps = gps_from_msg(m)
            elif t == "BATTERY_STATUS":
                fc.commander.set_battery(battery_from_msg(m))
            elif t == "LANDING_TARGET":  # the simulated companion computer's (sitl/companion.py)
                fc.on_landing_target(m, m.get_srcSystem())
