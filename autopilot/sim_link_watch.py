"""Whether the simulator link is up, and the clock the ground-station link runs on while it is not.

In lockstep the flight controller's clock is the simulator's (HIL_SENSOR ``time_usec``): when the
simulator dies or hangs that clock stops, and with it every stream of the ground-station link,
HEARTBEAT included.  :class:`SimLinkWatch` declares the link lost when it closes or when no HIL_SENSOR
has come for :data:`SIM_LOSS_TIMEOUT_S` of wall-clock time, and from then on gives the ground-station
link a time that goes on with the wall clock from the latest sensor time, so ground stations keep
getting HEARTBEAT (1 Hz) and STATUSTEXT and see what happened.  The next HIL_SENSOR regains the link;
whether the flight controller's state is still good then is decided by the sensor time itself
(:meth:`autopilot.flight_controller.FlightController.step`: a clock that restarted means a new world).

A simulator *held* at a simulated time (``SIM_HOLD_MS``, ``sitl/hold.py``) sends no sensors but a HEARTBEAT
on the link every 0.2 s of wall time: :meth:`SimLinkWatch.on_held` takes it for "alive, held", so a hold of
any length is never a loss, and the ground-station link's time stays at the latest sensor time (nothing
streams while held: the streams stay where the simulated time puts them).  A simulator that waits for its own
camera's frame longer than that (a loaded machine) sends a HEARTBEAT with MAV_STATE_ACTIVE instead:
:meth:`SimLinkWatch.on_busy`, alive and not held, so a slow frame never changes what the flight controller does.

Pure: wall-clock (s, time.monotonic) and simulated (µs) times are inputs.
"""

from __future__ import annotations

SIM_LOSS_TIMEOUT_S = 1.0  # wall seconds without a HIL_SENSOR on an open link: the simulator is lost


class SimLinkWatch:
    """Lost/regained state of the simulator link (see the module docstring)."""

    def __init__(self, loss_timeout_s: float = SIM_LOSS_TIMEOUT_S) -> None:
        self.loss_timeout_s = loss_timeout_s
        self.sim_us = 0  # time of the latest HIL_SENSOR, simulated µs
        self.sensor_wall_s: float | None = None  # wall time it arrived (None: none yet)
        self.alive_wall_s: float | None = None  # wall time of the latest HIL_SENSOR or held HEARTBEAT
        self.lost = False
        self.held = False  # the simulator holds (its HEARTBEATs come, its sensors do not)

    def on_sensor(self, sim_us: int, wall_s: float) -> bool:
        """A HIL_SENSOR stamped ``sim_us`` arrived at ``wall_s``; True if it ends a loss (the link is regained)."""
        regained = self.lost
        self.sim_us, self.sensor_wall_s, self.lost, self.held = sim_us, wall_s, False, False
        self.alive_wall_s = wall_s
        return regained

    def on_held(self, wall_s: float) -> bool:
        """A HEARTBEAT from the simulator (it holds) at ``wall_s``; True if it ends a loss."""
        regained = self.lost
        self.alive_wall_s, self.lost, self.held = wall_s, False, True
        return regained

    def on_busy(self, wall_s: float) -> None:
        """A HEARTBEAT with MAV_STATE_ACTIVE from the simulator at ``wall_s``: it is alive and stepping, but waits
        for something of its own (a camera frame on a loaded machine, sitl/lockstep.py) before the next sensors:
        not lost, not held; the link's clock stays the simulated one."""
        self.alive_wall_s = wall_s

    def check(self, wall_s: float, closed: bool) -> bool:
        """True when the link is lost from now on: it ``closed``, or nothing (sensor data, a held HEARTBEAT)
        came for the timeout.
        Nothing is lost before the first HIL_SENSOR (the simulator was never there)."""
        if closed:
            self.held = False  # a new connection says for itself whether it holds
        if self.lost or self.sensor_wall_s is None or self.alive_wall_s is None:  # (both set by the first sensor)
            return False
        if closed or wall_s - self.alive_wall_s >= self.loss_timeout_s:
            self.lost, self.held = True, False
            return True
        return False

    def link_time_us(self, wall_s: float) -> int:
        """The ground-station link's time, µs: the latest sensor time, carried on by the wall clock while
        the link is lost (streams stay at their rates); the latest sensor time otherwise."""
        if not self.lost or self.sensor_wall_s is None:
            return self.sim_us
        return self.sim_us + max(0, round((wall_s - self.sensor_wall_s) * 1e6))
