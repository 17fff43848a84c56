"""The flight-controller process loop: lockstep with the simulator, the ground-station link in between.

Receive the simulator's messages; on each HIL_SENSOR run one iteration of the
flight controller and answer with HIL_ACTUATOR_CONTROLS; then, while the
simulator steps its physics, run the 50 Hz outer loops (``after_step``) and, in
another 4 ms period, let the ground-station link receive, stream telemetry and
send events; in the other periods the link only answers what has arrived
(``poll``).  HIL_GPS and BATTERY_STATUS are kept for the next step.  Times are
the simulator's (``time_usec`` of HIL_SENSOR, microseconds).
"""

from __future__ import annotations

import time
from typing import TYPE_CHECKING

from autopilot.mavlink.sim_link import battery_from_msg, gps_from_msg, imu_from_msg
from mavsim_core.constants import LOCKSTEP_DT_US

if TYPE_CHECKING:  # types only: the process imports these where it builds them (the recorder only when logging)
    from autopilot.flight_controller import FlightController
    from autopilot.flight_recorder import FlightRecorder
    from autopilot.mavlink.link import GcsLink
    from autopilot.mavlink.sim_link import SimLink

LINK_EVERY, LINK_PHASE = 5, 2  # ground-station link at 50 Hz of simulated time, off the outer loop's period


def run_lockstep(sim: SimLink, fc: FlightController, link: GcsLink, recorder: FlightRecorder | None) -> None:
    """Connect to the simulator and fly in lockstep with it; reconnect when it closes the link.

    Returns only by an exception (KeyboardInterrupt, SystemExit from SIGTERM); the caller closes
    ``link`` and ``recorder``.  While the simulator is away the ground stations are still answered.
    """
    now_us = 0
    sim.connect(on_wait=lambda: link.update(now_us))
    print("[autopilot] connected to the simulator", flush=True)
    gps = None
    while True:
        msgs = sim.receive(timeout_s=0.05)
        if msgs is None:
            print("[autopilot] simulator closed the link; reconnecting", flush=True)
            sim.connect(on_wait=lambda: link.update(now_us))
            continue
        if not msgs:
            link.update(now_us)  # keep answering ground stations while the simulator is paused
            continue
        for m in msgs:
            t = m.get_type()
            if t == "HIL_SENSOR":
                imu = imu_from_msg(m)
                commands = fc.step(imu, gps)
                gps = None
                now_us = imu.timestamp_us
                live = fc.commander.status.armed or fc.commander.motor_test_run is not None  # DO_MOTOR_TEST
                sim.send_actuators(now_us, commands, live)
                if recorder is not None:
                    recorder.on_step(imu)
                # While the simulator steps its physics: the outer loops, and in another
                # period the ground-station link (both 50 Hz), so the two never add up.
                fc.wall_s = time.monotonic()  # the input-loss timers also measure the clients' clock
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
