"""The ``gcs`` command line: its argparse parser, a flight from arm to land in ``gcs --help``.

The flight commands (arm, disarm, takeoff, goto, land, rtl, mode) and the watch commands (status,
watch) are declared here; param, mission, signing, ugv, fly and plot add their own sub-parsers
(``gcs/param_cli.py`` ...).  Every value is checked by its argparse type (:mod:`gcs.cli_types`), so a
bad one is a usage error (exit 2) before anything is sent.  Every sub-command's ``--help`` ends with
the exit codes.
"""

from __future__ import annotations

import argparse
import math

from mavsim_core import cli_args
from mavsim_core import px4_modes as modes

from . import autotune_cli, cli_types, fly_cli, mission_cli, param_cli, signing_cli, ugv_cli

DEFAULT_GCS_PORT = 14550
CONNECT_TIMEOUT_S = 10.0
ANSWER_TIMEOUT_S = 10.0  # wall seconds a request is retried for (COMMAND_ACK, PARAM_VALUE) unless --timeout

# The flight `gcs --help` shows; tests/test_e2e_gcs_daily.py flies these lines as printed.
FLIGHT = (
    ("gcs arm", "arm the motors"),
    ("gcs takeoff 10", "climb to 10 m above home; returns once there"),
    ("gcs goto 47.3979 8.5457 10", "fly to latitude, longitude, 10 m above home; returns once there"),
    ("gcs mode HOLD", "hold here (any PX4 mode: POSCTL, AUTO.LOITER, RTL ...)"),
    ("gcs land", "land here; returns once landed and disarmed"),
    ("gcs disarm", "disarm (if it is still armed)"),
)
EPILOG = "\n".join(
    [
        "A flight from arm to land (each command waits until done; && stops at the first failure):",
        *(f"  {line:<30} # {what}" for line, what in FLIGHT),
        "Meanwhile, in another terminal: gcs watch (one line, refreshed; Ctrl-C to stop).",
        "",
        cli_args.EXIT_CODES_EPILOG,
    ]
)


def add_connection_options(parser: argparse.ArgumentParser) -> None:
    """The options every command shares: where the vehicle is and how long to wait for it."""
    parser.add_argument(
        "--url",
        default=None,
        help=f"pymavlink connection string (default udpin:0.0.0.0:{DEFAULT_GCS_PORT}, where every instance sends)",
    )
    cli_args.add_instance_option(
        parser,
        default=None,
        help="vehicle instance N (0-99): the vehicle with MAVLink system id 1+N (PX4's multi-vehicle scheme); "
        "default: the first vehicle heard (instance 0 for 'ugv')",
    )
    parser.add_argument(
        "--timeout",
        type=cli_types.positive,
        default=None,
        metavar="S",
        help="wall seconds to wait at each step (heartbeat, answer to a request sent again every 0.5 s, effect); "
        f"default: per step ({CONNECT_TIMEOUT_S:g} s for the heartbeat, {ANSWER_TIMEOUT_S:g} s for an answer)",
    )
    signing_cli.add_signing_key_option(parser)  # --signing-key (MAVLink 2 signing, gcs/signing_cli.py)


def build_parser() -> argparse.ArgumentParser:
    """The argparse parser of the ``gcs`` command."""
    parser = argparse.ArgumentParser(
        prog="gcs",
        description="Command a PX4-like vehicle over MAVLink.",
        epilog=EPILOG,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    add_connection_options(parser)
    cli_args.add_version_option(parser)
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    _add_watch_parsers(sub)
    _add_flight_parsers(sub)
    param_cli.add_param_parser(sub)
    signing_cli.add_signing_parser(sub)
    ugv_cli.add_ugv_parser(sub)
    fly_cli.add_fly_parser(sub)
    mission_cli.add_mission_parser(sub)
    autotune_cli.add_autotune_parser(sub)
    from . import plot  # gcs plot (gcs/plot.py): figures from a flight log, no vehicle needed

    plot.add_arguments(
        sub.add_parser(
            "plot", help="write PNG figures (setpoint vs estimate vs truth, motors) of a flight log (.ulg or .tlog)"
        )
    )
    from .launcher import replay  # gcs replay (gcs/launcher/replay.py): a flight's video from its logs

    replay.add_arguments(
        sub.add_parser(
            "replay",
            help="render a flight's video from its logs (MP4: a chase view, the onboard camera, mode and phase)",
            description=replay.DESCRIPTION,
        )
    )
    _add_exit_codes(parser)
    return parser


def _add_watch_parsers(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("status", help="print mode, arming, position, speed, battery and GPS once a second")
    p.add_argument("--once", action="store_true", help="print one line and exit")
    p = sub.add_parser(
        "watch",
        help="one refreshing line: mode, armed, position, altitude, battery, GPS, last message (Ctrl-C to stop)",
        description="One line, refreshed in place: mode, armed, latitude/longitude, altitude above home, battery, "
        "GPS fix and satellites, the vehicle's last STATUSTEXT.  Until Ctrl-C (exit 0), or --count refreshes.  "
        "When the output is not a terminal, one line per refresh.",
    )
    p.add_argument("--count", type=cli_types.positive_int, default=None, metavar="N", help="stop after N refreshes")
    p.add_argument(
        "--period", type=cli_types.positive, default=1.0, metavar="S", help="wall seconds between refreshes (1)"
    )


def _add_flight_parsers(sub: argparse._SubParsersAction) -> None:
    sub.add_parser("arm", help="arm the motors")
    p = sub.add_parser("disarm", help="disarm the motors")
    p.add_argument("--force", action="store_true", help="force (param2 = 21196): disarms even in flight")

    p = sub.add_parser("takeoff", help="take off to ALT metres above home and wait until there")
    p.add_argument(
        "alt",
        nargs="?",
        type=cli_types.altitude,
        default=math.nan,
        metavar="ALT",
        help="metres above home (default / nan: the vehicle's MIS_TAKEOFF_ALT)",
    )
    p.add_argument("--arm", action="store_true", help="arm first if disarmed")
    _add_goto_parser(sub)

    p = sub.add_parser("land", help="land where the vehicle is and wait until landed and disarmed")
    p.add_argument(
        "--precision",
        nargs="?",
        const="opportunistic",
        choices=("opportunistic", "required"),
        default=None,
        help="precision landing on the landing target (AUTO.PRECLAND, NAV_LAND param 2): 'opportunistic' "
        "(the default) lands normally if no target is found, 'required' holds and reports",
    )
    sub.add_parser("rtl", help="return to launch and wait until landed and disarmed")

    p = sub.add_parser("mode", help="switch flight mode and wait until the heartbeat shows it")
    p.add_argument(
        "name",
        type=cli_types.mode_name,
        metavar="NAME",
        help="one of "
        + ", ".join(modes.mode_names())
        + " (PX4 spellings such as AUTO.LOITER and HOLD accepted; case-insensitive)",
    )


def _add_goto_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "goto",
        help="fly to LAT LON at ALT m above home (DO_REPOSITION) and wait until there",
        description="Fly in a straight line to a point and hold there (MAV_CMD_DO_REPOSITION, as PX4: the vehicle "
        "switches to AUTO.LOITER).  Returns once the vehicle is within a metre of the point and slow; prints the "
        "distance left meanwhile.  The vehicle must be flying (gcs takeoff first).",
    )
    p.add_argument("lat", type=cli_types.latitude, metavar="LAT", help="latitude, degrees (-90..90)")
    p.add_argument("lon", type=cli_types.longitude, metavar="LON", help="longitude, degrees (-180..180)")
    p.add_argument("alt", type=cli_types.finite, metavar="ALT", help="altitude, metres above home (--amsl: AMSL)")
    p.add_argument("--amsl", action="store_true", help="ALT is metres above mean sea level, not above home")
    p.add_argument(
        "--speed",
        type=cli_types.positive,
        default=None,
        metavar="M_S",
        help="ground speed, m/s (default: the vehicle's MPC_XY_CRUISE; at most MPC_XY_VEL_MAX)",
    )
    p.add_argument(
        "--yaw",
        type=cli_types.heading_deg,
        default=None,
        metavar="DEG",
        help="heading on arrival, degrees from north (default: keep the heading)",
    )


def _add_exit_codes(parser: argparse.ArgumentParser) -> None:
    """Every sub-command's ``--help`` ends with the exit codes (those with an epilog of their own keep it
    and get the codes after it)."""
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for child in action.choices.values():
                if child.epilog is None:
                    child.epilog = cli_args.EXIT_CODES_EPILOG
                elif cli_args.EXIT_CODES_EPILOG not in child.epilog:
                    child.epilog += "\n\n" + cli_args.EXIT_CODES_EPILOG
                _add_exit_codes(child)
