"""``gcs``: command a PX4-like vehicle from the shell.

Examples::

    gcs status                 # live status line once a second (Ctrl-C to stop)
    gcs arm && gcs takeoff 5   # arm, climb to 5 m above home
    gcs mode HOLD              # any PX4 mode name: POSCTL, AUTO.LOITER, RTL ...
    gcs land                   # land here and wait for the automatic disarm
    gcs land --precision       # land on the landing target (AUTO.PRECLAND; 'required': no fallback)
    gcs ugv drive              # drive the simulated ground vehicle from the keyboard (MANUAL_CONTROL)
    gcs fly                    # pilot the vehicle from the keyboard (MANUAL_CONTROL; keys: gcs fly -h)
    gcs --instance 2 rtl       # the vehicle of instance 2 (system id 3, on the shared UDP 14550)
    gcs param get MPC_XY_P
    gcs plot logs/             # PNG figures of the newest flight log there
    gcs param save tuned.params  # also: param list, set, load, diff (see gcs/param_cli.py)
    gcs signing setup PASSPHRASE  # MAVLink 2 signing; then: gcs --signing-key PASSPHRASE arm

Each command is sent again until its COMMAND_ACK comes (the MAVLink command protocol: every
0.5 s, ``confirmation`` counting the tries) and then waits for its effect; a lost ACK does not
fail a command the vehicle is seen carrying out (armed, mode).  Exit codes: 0 done, 1 refused
by the vehicle (its result and reason are printed) or failed (the effect did not come), 2 usage
error (argparse), 3 no answer from the vehicle (what it was waiting for is printed).
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time

from pymavlink.dialects.v20 import common as mavlink

from mavsim_core import ports
from mavsim_core import px4_modes as modes

from . import fly_cli, mission_cli, param_cli, signing_cli, ugv_cli
from .client import VehicleClient
from .errors import (
    EXIT_OK,
    EXIT_REFUSED,
    EXIT_USAGE,
    CommandResult,
    GcsError,
    GcsTimeout,
    report_error,
)
from .plugins.telemetry import GPS_FIX_NAMES

DEFAULT_GCS_PORT = 14550
CONNECT_TIMEOUT_S = 10.0
ANSWER_TIMEOUT_S = 10.0  # wall seconds a request is retried for (COMMAND_ACK, PARAM_VALUE) unless --timeout
EXIT_CODES = "Exit codes: 0 done, 1 refused by the vehicle or failed, 2 usage error, 3 no answer from the vehicle."

# Default wall-clock waits for each command's effect, when --timeout is not given.
EFFECT_TIMEOUT_S = {"arm": 10.0, "disarm": 10.0, "mode": 10.0, "takeoff": 90.0, "land": 180.0, "rtl": 600.0}


def _altitude(text: str) -> float:
    value = float(text)  # accepts "nan"
    if math.isinf(value):
        raise argparse.ArgumentTypeError("altitude must be finite (or nan)")
    return value


def _positive(text: str) -> float:
    value = float(text)
    if not value > 0:
        raise argparse.ArgumentTypeError("must be > 0")
    return value


def add_connection_options(parser: argparse.ArgumentParser) -> None:
    """The options every command shares: where the vehicle is and how long to wait for it."""
    parser.add_argument(
        "--url",
        default=None,
        help=f"pymavlink connection string (default udpin:0.0.0.0:{DEFAULT_GCS_PORT}, where every instance sends)",
    )
    parser.add_argument(
        "--instance",
        "-i",
        type=int,
        default=None,
        metavar="N",
        help="vehicle instance N: the vehicle with MAVLink system id 1+N (PX4's multi-vehicle scheme); "
        "default: the first vehicle heard (instance 0 for 'ugv')",
    )
    parser.add_argument(
        "--timeout",
        type=_positive,
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
        epilog=EXIT_CODES,
    )
    add_connection_options(parser)
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")

    p = sub.add_parser("status", help="print mode, arming, position, speed, battery and GPS once a second")
    p.add_argument("--once", action="store_true", help="print one line and exit")

    sub.add_parser("arm", help="arm the motors")
    p = sub.add_parser("disarm", help="disarm the motors")
    p.add_argument("--force", action="store_true", help="force (param2 = 21196): disarms even in flight")

    p = sub.add_parser("takeoff", help="take off to ALT metres above home and wait until there")
    p.add_argument(
        "alt",
        nargs="?",
        type=_altitude,
        default=math.nan,
        metavar="ALT",
        help="metres above home (default / nan: the vehicle's MIS_TAKEOFF_ALT)",
    )
    p.add_argument("--arm", action="store_true", help="arm first if disarmed")

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
        metavar="NAME",
        help="one of "
        + ", ".join(modes.mode_names())
        + " (PX4 spellings such as AUTO.LOITER and HOLD accepted; case-insensitive)",
    )

    param_cli.add_param_parser(sub)
    signing_cli.add_signing_parser(sub)
    ugv_cli.add_ugv_parser(sub)
    fly_cli.add_fly_parser(sub)
    mission_cli.add_mission_parser(sub)
    # -- gcs plot (gcs/plot.py): figures from a flight log, no vehicle needed
    from . import plot

    plot.add_arguments(
        sub.add_parser(
            "plot", help="write PNG figures (setpoint vs estimate vs truth, motors) of a flight log (.fc.npy or .tlog)"
        )
    )
    return parser


URL_SCHEMES = ("udpin:", "udpout:", "udpbcast:", "udp:", "tcpin:", "tcp:", "mcast:")  # pymavlink's network URLs


def resolve_url(args: argparse.Namespace) -> str:
    """The connection string: --url, else the ground-station port 14550 that every instance sends to."""
    if args.url:
        return args.url
    return f"udpin:0.0.0.0:{DEFAULT_GCS_PORT}"


class _Cli:
    """The sub-command implementations (one client, one set of timeouts)."""

    def __init__(self, client: VehicleClient, args: argparse.Namespace) -> None:
        self.client = client
        self.args = args

    def effect_timeout(self, command: str) -> float:
        return self.args.timeout if self.args.timeout is not None else EFFECT_TIMEOUT_S[command]

    # ------------------------------------------------------------- status

    def status(self) -> int:
        c = self.client
        if self.args.once:
            # ask for the slow messages at once, then give the streams a moment so the line is complete
            for mid in (
                mavlink.MAVLINK_MSG_ID_HOME_POSITION,
                mavlink.MAVLINK_MSG_ID_GPS_RAW_INT,
                mavlink.MAVLINK_MSG_ID_BATTERY_STATUS,
            ):
                c.telemetry.request_message(mid)
            wanted = ("GLOBAL_POSITION_INT", "SYS_STATUS", "GPS_RAW_INT", "HOME_POSITION")
            try:
                c.wait_until(lambda: all(c.latest(t) for t in wanted), min(self.args.timeout or 3.0, 3.0), "telemetry")
            except GcsTimeout:
                pass
            print(status_line(c), flush=True)
            return EXIT_OK
        try:
            next_print = time.monotonic()
            while True:
                now = time.monotonic()
                if now >= next_print:
                    print(status_line(c), flush=True)
                    next_print += 1.0
                    if next_print < now:
                        next_print = now + 1.0
                c.pump(min(0.1, max(next_print - time.monotonic(), 0.0)))
        except KeyboardInterrupt:
            return EXIT_OK

    # ------------------------------------------------------------- arming

    def arm(self) -> int:
        c = self.client
        _checked(c.arm())
        c.wait_armed(True, self.effect_timeout("arm"))
        print(f"armed (mode {c.mode_name()})")
        return EXIT_OK

    def disarm(self) -> int:
        c = self.client
        _checked(c.disarm(force=self.args.force))
        c.wait_armed(False, self.effect_timeout("disarm"))
        print("disarmed")
        return EXIT_OK

    # ------------------------------------------------------------- flight

    def takeoff(self) -> int:
        c = self.client
        timeout = self.effect_timeout("takeoff")
        home = c.wait_home(timeout)
        if self.args.arm and not c.armed():
            _checked(c.arm())
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
        _checked(c.takeoff(alt_amsl))
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

    def land(self) -> int:
        c = self.client
        precision = {None: 0, "opportunistic": 1, "required": 2}[self.args.precision]
        _checked(c.land(precision=precision))
        print("precision landing" if precision else "landing", flush=True)
        return self._wait_landed_disarmed(self.effect_timeout("land"))

    def rtl(self) -> int:
        c = self.client
        _checked(c.return_to_launch())
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
        _checked(c.set_mode(target.name))
        c.wait_mode(target.name, self.effect_timeout("mode"))
        print(f"mode {target.name} ({target.px4_name})")
        return EXIT_OK

    def param(self) -> int:
        return param_cli.run_param_command(self.client, self.args)


def _checked(result: CommandResult) -> CommandResult:
    """The result if accepted (CommandRefused otherwise), with a note when no COMMAND_ACK came back."""
    result.check()
    if not result.acknowledged:
        note = f"note: no acknowledgement of {result.command_name} came back; the vehicle was seen doing it"
        print(note, file=sys.stderr)
    return result


def status_line(client: VehicleClient) -> str:
    """One human-readable line of vehicle state (what ``gcs status`` prints)."""
    c = client
    t = c.sim_time_s()
    fields = [
        f"t {t:8.2f} s" if t is not None else "t      ? s",
        f"{c.mode_name() or '?':<10}",
        "ARMED   " if c.armed() else "disarmed",
    ]
    pos = c.position_ned()
    if pos is not None:
        fields.append(f"N {pos[0]:7.2f} E {pos[1]:7.2f} alt {-pos[2]:6.2f} m")
    elif c.relative_alt_m() is not None:
        fields.append(f"N       ? E       ? alt {c.relative_alt_m():6.2f} m")
    else:
        fields.append("position ?")
    gs = c.ground_speed_m_s()
    fields.append(f"gs {gs:4.1f} m/s" if gs is not None else "gs ? m/s")
    volts, pct = c.battery()
    fields.append(
        "batt " + (f"{volts:.1f} V" if volts is not None else "? V") + " " + (f"{pct}%" if pct is not None else "?%")
    )
    gps = c.gps()
    fields.append(f"GPS {GPS_FIX_NAMES.get(gps[0], gps[0])} {gps[1]} sats" if gps is not None else "GPS ?")
    if not c.prearm_ok() and not c.armed() and c.latest("SYS_STATUS") is not None:
        fields.append("not ready")
    silent = c.age_s("HEARTBEAT")
    if silent is not None and silent > 3.0:
        fields.append(f"(no heartbeat for {silent:.0f} s)")
    return "  ".join(fields)


def main(argv: list[str] | None = None) -> int:
    """Run the ``gcs`` CLI; returns the exit code (0 done, 1 refused or failed, 2 usage, 3 no answer)."""
    args = build_parser().parse_args(argv)
    if args.command == "plot":
        from . import plot

        return plot.run(args)
    if args.command == "ugv":  # the simulator's own port, not the vehicle's
        return ugv_cli.run_ugv_command(args)
    if args.command == "mission" and args.mission_command == "upload":
        args.plan = mission_cli.load_file(args.file)  # read before connecting: a broken file sends nothing
        if args.plan is None:
            return EXIT_REFUSED
    if args.command == "mode":
        try:
            modes.lookup_mode(args.name)
        except modes.UnknownModeError as exc:
            print(f"gcs: error: {exc}", file=sys.stderr)
            return EXIT_REFUSED
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
        cli = _Cli(client, args)
        handler = {
            "status": cli.status,
            "arm": cli.arm,
            "disarm": cli.disarm,
            "takeoff": cli.takeoff,
            "land": cli.land,
            "rtl": cli.rtl,
            "mode": cli.mode,
            "param": cli.param,
            "mission": lambda: mission_cli.run_mission_command(client, args),
            "fly": lambda: fly_cli.run_fly_command(client, args),
            "signing": lambda: signing_cli.run_signing_command(client, args),
        }[args.command]
        return handler()
    except (GcsError, ValueError, OSError, OverflowError) as exc:  # refused, no answer, bad value, bad --url
        return report_error(exc, args.command)
    except KeyboardInterrupt:
        print("gcs: interrupted", file=sys.stderr)
        return 130
    finally:
        if client is not None:
            client.close()


if __name__ == "__main__":
    sys.exit(main())
