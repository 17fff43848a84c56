"""``gcs``: command a PX4-like vehicle from the shell.

Examples::

    gcs watch                  # one refreshing line: mode, armed, position, altitude, battery, GPS, messages
    gcs arm && gcs takeoff 5   # arm, climb to 5 m above home
    gcs goto 47.3979 8.5457 10 # fly to a latitude, longitude at 10 m above home (DO_REPOSITION)
    gcs mode HOLD              # any PX4 mode name: POSCTL, AUTO.LOITER, RTL ...
    gcs land                   # land here and wait for the automatic disarm
    gcs land --precision       # land on the landing target (AUTO.PRECLAND; 'required': no fallback)
    gcs status                 # a status line once a second (Ctrl-C to stop)
    gcs ugv drive              # drive the simulated ground vehicle from the keyboard (MANUAL_CONTROL)
    gcs fly                    # pilot the vehicle from the keyboard (MANUAL_CONTROL; keys: gcs fly -h)
    gcs autotune               # in Hold: identify the rate loop, propose gains, apply them if accepted
    gcs -i 2 rtl               # the vehicle of instance 2 (system id 3, on the shared UDP 14550)
    gcs param get MPC_XY_P
    gcs plot logs/             # PNG figures of the newest flight log there
    gcs replay logs/ --video flight.mp4  # a video of the latest flight there, rendered from its logs
    gcs param save tuned.params  # also: param list, set, load, diff (see gcs/param_cli.py)
    gcs signing setup PASSPHRASE  # MAVLink 2 signing; then: gcs --signing-key PASSPHRASE arm

Each command is sent again until its COMMAND_ACK comes (the MAVLink command protocol: every
0.5 s, ``confirmation`` counting the tries) and then waits for its effect; a lost ACK does not
fail a command the vehicle is seen carrying out (armed, mode).  The parser is
:mod:`gcs.cli_parser`, the flight commands :mod:`gcs.flight_cli`, status and watch
:mod:`gcs.watch_cli`.  Exit codes (those of every console script, :mod:`mavsim_core.cli_args`):
0 done, 1 refused by the vehicle (its result and reason are printed) or failed (the effect did
not come, a file could not be read), 2 usage error (argparse; a --url that cannot open), 3 no
answer from the vehicle (what it was waiting for is printed).
"""

from __future__ import annotations

import argparse
import os
import sys

from mavsim_core import ports

from . import autotune_cli, fly_cli, mission_cli, param_cli, signing_cli, ugv_cli, watch_cli
from .cli_parser import ANSWER_TIMEOUT_S, CONNECT_TIMEOUT_S, DEFAULT_GCS_PORT, build_parser
from .client import VehicleClient
from .errors import EXIT_REFUSED, EXIT_USAGE, GcsError, report_error
from .flight_cli import FlightCommands
from .watch_cli import status_line

__all__ = ["build_parser", "main", "resolve_url", "status_line"]

URL_SCHEMES = ("udpin:", "udpout:", "udpbcast:", "udp:", "tcpin:", "tcp:", "mcast:")  # pymavlink's network URLs


def resolve_url(args: argparse.Namespace) -> str:
    """The connection string: --url, else the ground-station port 14550 that every instance sends to."""
    if args.url:
        return args.url
    return f"udpin:0.0.0.0:{DEFAULT_GCS_PORT}"


def command_label(args: argparse.Namespace) -> str:
    """``param get``, ``mission upload``, ``arm``: the command as the user typed it, for error lines."""
    sub = getattr(args, f"{args.command}_command", None)
    return f"{args.command} {sub}" if sub else args.command


def _handler(client: VehicleClient, args: argparse.Namespace):
    """The function running ``args.command`` over ``client``."""
    flight = FlightCommands(client, args)
    return {
        "status": lambda: watch_cli.run_status(client, args),
        "watch": lambda: watch_cli.run_watch(client, args),
        "arm": flight.arm,
        "disarm": flight.disarm,
        "takeoff": flight.takeoff,
        "goto": flight.goto,
        "land": flight.land,
        "rtl": flight.rtl,
        "mode": flight.mode,
        "param": lambda: param_cli.run_param_command(client, args),
        "mission": lambda: mission_cli.run_mission_command(client, args),
        "fly": lambda: fly_cli.run_fly_command(client, args),
        "signing": lambda: signing_cli.run_signing_command(client, args),
        "autotune": lambda: autotune_cli.run_autotune(client, args),
    }[args.command]


def main(argv: list[str] | None = None) -> int:
    """Run the ``gcs`` CLI; returns the exit code (0 done, 1 refused or failed, 2 usage, 3 no answer)."""
    args = build_parser().parse_args(argv)
    if args.command == "plot":
        from . import plot

        return plot.run(args)
    if args.command == "replay":  # a video from the logs (gcs/launcher/replay.py), no vehicle needed
        from .launcher import replay

        return replay.run(args)
    if args.command == "ugv":  # the simulator's own port, not the vehicle's
        return ugv_cli.run_ugv_command(args)
    if args.command == "mission" and args.mission_command == "upload":
        args.plan = mission_cli.load_file(args.file)  # read before connecting: a broken file sends nothing
        if args.plan is None:
            return EXIT_REFUSED
    if args.command == "param" and (refused := param_cli.check_file(args)) is not None:
        return refused
    url = resolve_url(args)
    if not url.startswith(URL_SCHEMES) and not os.path.exists(url):  # pymavlink would take it for a serial device
        print(f"gcs: --url {url}: neither udpin:/udp:/tcp:HOST:PORT nor an existing serial device", file=sys.stderr)
        return EXIT_USAGE
    client = None
    try:
        client = VehicleClient(
            url,
            timeout_s=args.timeout or CONNECT_TIMEOUT_S,
            target_system=None if args.instance is None else ports.system_id(args.instance),
            signing_key=args.signing_key,
        )
        client.timeout_s = args.timeout or ANSWER_TIMEOUT_S
        return _handler(client, args)()
    except (GcsError, ValueError, OSError, OverflowError) as exc:  # refused, no answer, bad value, bad --url
        return report_error(exc, command_label(args))
    except KeyboardInterrupt:
        print("gcs: interrupted", file=sys.stderr)
        return 130
    finally:
        if client is not None:
            client.close()


if __name__ == "__main__":
    sys.exit(main())
