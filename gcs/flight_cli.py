"""``gcs arm | disarm | takeoff | goto | land | rtl | mode``: the flight commands of the ``gcs`` CLI.

Each sends its command (again until its COMMAND_ACK comes), then waits until the vehicle is seen
doing it (armed, at the altitude, at the point, landed and disarmed, in the mode) and prints one line
saying where it is.  A refusal or an effect that does not come raises (:mod:`gcs.errors`); ``gcs``'s
``main`` prints it in one line with its exit code.  Timeouts are wall seconds (``--timeout`` or
:data:`EFFECT_TIMEOUT_S`), positions degrees and metres, altitudes metres above home unless AMSL.
"""

from __future__ import annotations

import argparse
import math
import sys
import time

from mavsim_core import px4_modes as modes

from .client import VehicleClient, mavlink
from .errors import EXIT_OK, CommandAborted, CommandResult, GcsError
from .geo import global_to_ned

# Default wall-clock waits for each command's effect, when --timeout is not given.
EFFECT_TIMEOUT_S = {
    "arm": 10.0,
    "disarm": 10.0,
    "mode": 10.0,
    "takeoff": 90.0,
    "goto": 600.0,
    "land": 180.0,
    "rtl": 600.0,
}
ARRIVED_M = 1.0  # goto: within this many metres of the point, horizontally and vertically ...
STILL_M_S = 0.5  # ... and slower than this, horizontally and vertically
PROGRESS_S = 1.0  # goto prints the distance left this often (wall seconds)


class FlightCommands:
    """The flight sub-commands over one client, with the command line's timeouts."""

    def __init__(self, client: VehicleClient, args: argparse.Namespace) -> None:
        self.client = client
        self.args = args

    def effect_timeout(self, command: str) -> float:
        return self.args.timeout if self.args.timeout is not None else EFFECT_TIMEOUT_S[command]

    # ------------------------------------------------------------- arming

    def arm(self) -> int:
        c = self.client
        checked(c.arm())
        c.wait_armed(True, self.effect_timeout("arm"))
        print(f"armed (mode {c.mode_name()})")
        return EXIT_OK

    def disarm(self) -> int:
        c = self.client
        checked(c.disarm(force=self.args.force))
        c.wait_armed(False, self.effect_timeout("disarm"))
        print("disarmed")
        return EXIT_OK

    # ------------------------------------------------------------- flight

    def takeoff(self) -> int:
        c = self.client
        timeout = self.effect_timeout("takeoff")
        home = c.wait_home(timeout)
        if self.args.arm and not c.armed():
            checked(c.arm())
            c.wait_armed(True, self.effect_timeout("arm"))
            print("armed")
        if math.isnan(self.args.alt):
            alt_amsl = math.nan
            try:
                target = float(c.param_get("MIS_TAKEOFF_ALT", timeout_s=3.0))
            except GcsError:
                target = None
        else:
            target = self.args.alt
            alt_amsl = home.alt_amsl_m + target
        if not c.armed():
            print("note: the vehicle is disarmed; it will not climb until armed (use --arm)", file=sys.stderr)
        checked(c.takeoff(alt_amsl))
        what = f"takeoff to {target:g} m above home" if target is not None else "takeoff (climb to stop)"
        print(
            f"taking off: target {target:g} m above home"
            if target is not None
            else "taking off to the vehicle's MIS_TAKEOFF_ALT",
            flush=True,
        )
        c.wait_until(lambda: c.takeoff_done(target), timeout, what)
        print(f"at {c.relative_alt_m():.2f} m above home (mode {c.mode_name()})")
        return EXIT_OK

    def goto(self) -> int:
        """DO_REPOSITION as COMMAND_INT (ALT above home: MAV_FRAME_GLOBAL_RELATIVE_ALT_INT; ``--amsl``:
        MAV_FRAME_GLOBAL_INT), then wait until there (:class:`Arrival`)."""
        c, a = self.client, self.args
        home = c.wait_home()
        rel_alt_m = a.alt - home.alt_amsl_m if a.amsl else a.alt
        frame = mavlink.MAV_FRAME_GLOBAL_INT if a.amsl else mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
        speed = -1.0 if a.speed is None else a.speed  # DO_REPOSITION param1: -1 the vehicle's default
        yaw = math.nan if a.yaw is None else a.yaw
        arrival = Arrival(c, a.lat, a.lon, rel_alt_m)
        checked(c.goto_global(a.lat, a.lon, a.alt, ground_speed_m_s=speed, yaw_deg=yaw, frame=frame))
        print(f"going to {a.lat:.7f} {a.lon:.7f} at {rel_alt_m:.1f} m above home: {arrival.progress()}", flush=True)
        c.wait_until(arrival, self.effect_timeout("goto"), f"the vehicle to reach {a.lat:.7f} {a.lon:.7f}")
        print(f"arrived: {arrival.progress()} (mode {c.mode_name()})")
        return EXIT_OK

    def land(self) -> int:
        c = self.client
        precision = {None: 0, "opportunistic": 1, "required": 2}[self.args.precision]
        checked(c.land(precision=precision))
        print("precision landing" if precision else "landing", flush=True)
        return self._wait_landed_disarmed(self.effect_timeout("land"))

    def rtl(self) -> int:
        c = self.client
        checked(c.return_to_launch())
        print("returning to launch", flush=True)
        return self._wait_landed_disarmed(self.effect_timeout("rtl"))

    def _wait_landed_disarmed(self, timeout: float) -> int:
        c = self.client
        c.wait_until(c.landed_and_disarmed, timeout, "the vehicle to land and disarm")
        pos = c.position_ned()
        where = f" at N {pos[0]:.2f} m E {pos[1]:.2f} m ({math.hypot(pos[0], pos[1]):.2f} m from home)" if pos else ""
        print(f"landed and disarmed{where}")
        return EXIT_OK

    def mode(self) -> int:
        c = self.client
        target = modes.lookup_mode(self.args.name)
        checked(c.set_mode(target.name))
        c.wait_mode(target.name, self.effect_timeout("mode"))
        print(f"mode {target.name} ({target.px4_name})")
        return EXIT_OK


class Arrival:
    """``gcs goto``'s wait: true once the vehicle is at the point (GLOBAL_POSITION_INT within ARRIVED_M
    horizontally and vertically, slower than STILL_M_S); prints the distance left every PROGRESS_S; raises
    :class:`CommandAborted` if the vehicle disarms, or leaves AUTO.LOITER after it was seen in it."""

    def __init__(self, client: VehicleClient, lat_deg: float, lon_deg: float, rel_alt_m: float) -> None:
        self.client = client
        self.lat_deg, self.lon_deg, self.rel_alt_m = lat_deg, lon_deg, rel_alt_m
        self.loitering = False
        self.next_print = time.monotonic() + PROGRESS_S

    def errors_m(self) -> tuple[float, float] | None:
        """(horizontal, vertical) metres from the point, or None before a position is known."""
        pos, alt = self.client.global_position(), self.client.relative_alt_m()
        if pos is None or alt is None:
            return None
        north, east, _ = global_to_ned(self.lat_deg, self.lon_deg, 0.0, pos[0], pos[1], 0.0)
        return math.hypot(north, east), alt - self.rel_alt_m

    def progress(self) -> str:
        """``12.3 m to go (alt 9.8 m, 4.9 m/s)``: what is left, as a phrase."""
        c, errors = self.client, self.errors_m()
        if errors is None:
            return "position not known yet"
        gs = c.ground_speed_m_s() or 0.0
        return f"{math.hypot(*errors):.1f} m to go (alt {c.relative_alt_m():.1f} m, {gs:.1f} m/s)"

    def __call__(self) -> bool:
        c = self.client
        in_loiter = c.mode() == modes.lookup_mode("LOITER")
        self.loitering |= in_loiter
        if not c.armed() and c.latest("HEARTBEAT") is not None:
            raise CommandAborted(f"the vehicle disarmed before reaching the point [{c.describe()}]")
        if self.loitering and not in_loiter:
            raise CommandAborted(f"the vehicle left AUTO.LOITER for {c.mode_name()} [{c.describe()}]")
        if time.monotonic() >= self.next_print:
            self.next_print += PROGRESS_S
            print(f"  {self.progress()}", flush=True)
        errors, vel = self.errors_m(), c.velocity_ned_m_s()
        if errors is None or vel is None or not in_loiter:
            return False
        near = errors[0] < ARRIVED_M and abs(errors[1]) < ARRIVED_M
        return near and math.hypot(vel[0], vel[1]) < STILL_M_S and abs(vel[2]) < STILL_M_S


def checked(result: CommandResult) -> CommandResult:
    """The result if accepted (CommandRefused otherwise), with a note when no COMMAND_ACK came back."""
    result.check()
    if not result.acknowledged:
        note = f"note: no acknowledgement of {result.command_name} came back; the vehicle was seen doing it"
        print(note, file=sys.stderr)
    return result
