"""``gcs ugv``: the simulated ground vehicle, through the simulator's own MAVLink port (UDP 14740+I).

- ``gcs ugv status``: its truth (deck centre, NED m from the multicopter's start; speed; heading).
- ``gcs ugv set --path circle --speed 1 --radius 2``: its ``SIM_UGV_*`` parameters (PARAM_SET);
  ``--follow-target on`` makes it broadcast FOLLOW_TARGET to the flight controller (``SIM_UGV_FLW``).
- ``gcs ugv drive``: drive it from the keyboard, as [F 2.2] drives it with a joystick: MANUAL_CONTROL
  at 10 Hz to the simulator's component (x forward, r yaw, each -1000..1000).  Keys: w / s faster /
  slower (steps of 250), a / d turn left / right (steps of 250), space stop, q quit.  From a
  terminal the keys act at once; from a pipe each character is one key press (tests, scripts),
  read at 10 per second.  The simulator brakes the UGV to a stop 0.5 s after MANUAL_CONTROL stops.
"""

from __future__ import annotations

import argparse
import math
import os
import select
import sys
import time

from pymavlink.dialects.v20 import common as mavlink

from mavsim_core import ports

from . import cli_types
from .errors import EXIT_NO_ANSWER, EXIT_OK, EXIT_REFUSED, EXIT_USAGE
from .sim_client import SimClient, SimParamError

PATHS = {"stop": 0, "line": 1, "circle": 2, "figure8": 3, "random": 4, "manual": 5}
STEP = 250
SEND_PERIOD_S = 0.1


def add_ugv_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("ugv", help="the simulated ground vehicle: status, set its path, drive it")
    u = p.add_subparsers(dest="ugv_command", required=True)
    u.add_parser("status", help="print the UGV's true position, speed and heading")
    s = u.add_parser("set", help="set its path, speed, radius (SIM_UGV_* parameters)")
    s.add_argument("--path", choices=tuple(PATHS), default=None)
    s.add_argument("--speed", type=cli_types.finite, default=None, metavar="M_S", help="m/s along the path (0-4)")
    s.add_argument("--radius", type=cli_types.finite, default=None, metavar="M", help="circle / figure-8 radius, m")
    s.add_argument(
        "--follow-target", choices=("on", "off"), default=None,
        help="broadcast FOLLOW_TARGET to the flight controller, for AUTO.FOLLOW_TARGET (SIM_UGV_FLW)",
    )  # fmt: skip
    d = u.add_parser("drive", help="drive it from the keyboard (w/s faster/slower, a/d turn, space stop, q quit)")
    d.add_argument(
        "--duration", type=cli_types.positive, default=None, metavar="S", help="stop after this many wall seconds"
    )


def run_ugv_command(args: argparse.Namespace) -> int:
    """0 done, 1 refused (no UGV, bad value), 2 usage error, 3 no simulator answering."""
    if args.ugv_command == "set" and not _set_values(args):
        print("gcs: ugv set: give --path, --speed, --radius or --follow-target", file=sys.stderr)
        return EXIT_USAGE
    try:
        with SimClient(ports.sim_component_port(args.instance or 0)) as sim:
            sim.wait_connected(args.timeout or 10.0)
            if args.ugv_command == "status":
                return _status(sim)
            if args.ugv_command == "set":
                return _set(sim, args)
            return _drive(sim, args)
    except SimParamError as exc:
        print(f"gcs: ugv {args.ugv_command}: {exc}", file=sys.stderr)
        return EXIT_NO_ANSWER if "no " in str(exc) else EXIT_REFUSED
    except OSError as exc:
        print(f"gcs: ugv: cannot listen on UDP {ports.sim_component_port(args.instance or 0)}: {exc}", file=sys.stderr)
        return EXIT_REFUSED


def _wait_ugv(sim: SimClient, timeout_s: float = 2.0):
    deadline = time.monotonic() + timeout_s
    while (u := sim.ugv_latest()) is None:
        if time.monotonic() > deadline:
            return None
        time.sleep(0.05)
    return u


def _status(sim: SimClient) -> int:
    u = _wait_ugv(sim)
    if u is None:
        print("gcs: ugv status: the simulator has no UGV (start it with --param SIM_UGV_EN=1)", file=sys.stderr)
        return EXIT_REFUSED
    n, e, d = u.pos_ned_m
    print(
        f"UGV deck N {n:7.2f} E {e:7.2f} m (height {-d:.2f} m)  speed {math.hypot(*u.vel_ned_m_s[:2]):.2f} m/s  "
        f"heading {math.degrees(u.yaw_rad) % 360:5.1f} deg  path {int(sim.get('SIM_UGV_PATH'))}"
    )
    return EXIT_OK


def _set_values(args: argparse.Namespace) -> dict[str, float]:
    """The SIM_UGV_* parameters ``gcs ugv set`` was given, by name."""
    values = {"SIM_UGV_PATH": PATHS.get(args.path), "SIM_UGV_SPD": args.speed, "SIM_UGV_RAD": args.radius}
    values["SIM_UGV_FLW"] = {"on": 1, "off": 0}.get(args.follow_target)
    return {k: v for k, v in values.items() if v is not None}


def _set(sim: SimClient, args: argparse.Namespace) -> int:
    for name, value in _set_values(args).items():
        print(f"{name} = {sim.set(name, value):g}")
    return EXIT_OK


class _Keys:
    """Key presses from a terminal (raw, no echo) or a pipe (one character per key)."""

    def __init__(self) -> None:
        self.tty = sys.stdin.isatty()
        self._saved = None
        if self.tty:
            import termios
            import tty

            self._saved = termios.tcgetattr(sys.stdin.fileno())
            tty.setcbreak(sys.stdin.fileno())
        self.closed = False

    def read(self, timeout_s: float) -> str:
        if self.closed:
            time.sleep(timeout_s)
            return ""
        ready, _, _ = select.select([sys.stdin], [], [], timeout_s)
        if not ready:
            return ""
        ch = os.read(sys.stdin.fileno(), 1).decode(errors="ignore")
        if ch == "":
            self.closed = True  # end of a pipe: keep the last command until --duration or q
        return ch

    def restore(self) -> None:
        if self._saved is not None:
            import termios

            termios.tcsetattr(sys.stdin.fileno(), termios.TCSADRAIN, self._saved)


def _drive(sim: SimClient, args: argparse.Namespace) -> int:
    if _wait_ugv(sim) is None:
        print("gcs: ugv drive: the simulator has no UGV (start it with --param SIM_UGV_EN=1)", file=sys.stderr)
        return EXIT_REFUSED
    keys = _Keys()
    x = r = 0
    start = time.monotonic()
    print("driving the UGV: w/s faster/slower, a/d turn, space stop, q quit", flush=True)
    try:
        while args.duration is None or time.monotonic() - start < args.duration:
            ch = keys.read(SEND_PERIOD_S).lower()
            if ch == "q":
                break
            x, r = _apply_key(ch, x, r)
            sim._send(mavlink.MAVLink_manual_control_message(0, x, 0, 500, r, 0))  # 0: whichever system listens here
            u = sim.ugv_latest()
            if ch and u is not None:
                speed = math.hypot(*u.vel_ned_m_s[:2])
                print(f"x {x:+5d} r {r:+5d}  speed {speed:.2f} m/s  N {u.pos_ned_m[0]:.2f} E {u.pos_ned_m[1]:.2f}")
    finally:
        keys.restore()
        sim._send(mavlink.MAVLink_manual_control_message(0, 0, 0, 500, 0, 0))
    return EXIT_OK


def _apply_key(ch: str, x: int, r: int) -> tuple[int, int]:
    if ch == "w":
        x = min(1000, x + STEP)
    elif ch == "s":
        x = max(-1000, x - STEP)
    elif ch == "a":
        r = max(-1000, r - STEP)
    elif ch == "d":
        r = min(1000, r + STEP)
    elif ch == " ":
        x = r = 0
    return x, r
