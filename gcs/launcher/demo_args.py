"""``flight-demo``'s command line: every value checked by argparse (one ``error:`` line, exit 2).

The values the simulator also takes (``--speed``, ``--home``, ``--vehicle``) are checked with the
simulator's own argparse types, so ``flight-demo`` refuses exactly what ``sitl`` would refuse,
before anything starts.
"""

from __future__ import annotations

import argparse

from mavsim_core.cli_args import EXIT_CODES_EPILOG, add_instance_option, add_version_option
from mavsim_core.cli_checks import non_negative_int, positive_int, positive_number
from params.vehicle_arg import vehicle_argument
from sitl.__main__ import parse_home, parse_speed


def checked(check):
    """An argparse ``type`` that checks a value with ``check`` (a ``sitl`` option's type) and keeps its text."""

    def text(value: str) -> str:
        check(value)
        return value

    return text


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="flight-demo",
        description="Start the simulator and the flight controller, fly a square, land, report.",
        epilog=EXIT_CODES_EPILOG,
    )
    add_version_option(parser)
    add_instance_option(parser, help="instance N 0-99 (PX4's -i): system id 1+N, simulator TCP 4560+N (default 0)")
    parser.add_argument(
        "--count", type=positive_int, default=1, metavar="K",
        help="K vehicles in one simulated world (sitl --count K; instances N..N+K-1, 3 m apart along East): "
        "each takes off to its own height (--alt - 1 m, then 1 m higher each), holds --hold s, lands on its spot "
        "(default 1: the square); with --scenario ugv-landing each lands on its own moving UGV (10 m apart)",
    )  # fmt: skip
    parser.add_argument(
        "--speed", default=None, type=checked(parse_speed),
        help="simulation speed: 'max' or a real-time factor (default max; 1 with --wait)",
    )  # fmt: skip
    parser.add_argument(
        "--vehicle", default="quad_x", type=vehicle_argument, help="vehicle name or .toml file (default quad_x)"
    )
    parser.add_argument(
        "--home", default=None, type=checked(parse_home), metavar="LAT,LON,ALT", help="home position for the simulator"
    )
    parser.add_argument("--seed", type=non_negative_int, default=None, help="simulator random seed")
    parser.add_argument("--alt", type=positive_number, default=5.0, help="flight altitude above home, m (default 5)")
    parser.add_argument("--side", type=positive_number, default=10.0, help="square side, m (default 10)")
    parser.add_argument(
        "--hold", type=positive_number, default=10.0, help="hover time after takeoff, simulated s (default 10)"
    )
    parser.add_argument(
        "--ready-timeout",
        type=positive_number,
        default=120.0,
        help="wall seconds to wait for the vehicle to be ready to arm (default 120)",
    )
    parser.add_argument(
        "--step-timeout",
        type=positive_number,
        default=120.0,
        help="wall seconds allowed for each flight step (default 120)",
    )
    parser.add_argument(
        "--log-dir",
        default=None,
        metavar="DIR",
        help="where to write the child logs and the flight logs, created if need be (default: a temp dir)",
    )
    parser.add_argument("--sitl-module", default="sitl", help="module run as the simulator (testing; default sitl)")
    parser.add_argument(
        "--autopilot-module",
        default="autopilot",
        help="module run as the flight controller (testing; default autopilot)",
    )
    parser.add_argument(
        "--sitl-arg", action="append", default=[], metavar="ARG", help="extra argument for the simulator (repeatable)"
    )
    parser.add_argument(
        "--autopilot-arg",
        action="append",
        default=[],
        metavar="ARG",
        help="extra argument for the flight controller (repeatable)",
    )
    parser.add_argument(
        "--wait", action="store_true", help="only start the stack and print how to connect; run until Ctrl-C"
    )
    parser.add_argument(
        "--video", metavar="FILE.mp4", default=None,
        help="after the flight, render its video from the logs (gcs replay: 640x360, 25 fps, the camera's view "
        "inset); the logs are kept (in --log-dir, else a temp dir)",
    )  # fmt: skip
    parser.add_argument(
        "--scenario",
        choices=("square", "ugv-landing"),
        default="square",
        help="square: the 10 m square (default); ugv-landing: find the UGV driving a circle with the camera "
        "and land on its deck (prints the touchdown error from the truth)",
    )
    return parser
