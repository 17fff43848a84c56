"""``flight-demo``: start the simulator and flight controller, fly a square, land, report.

The scripted flight: wait until ready to arm, arm, take off to 5 m, hold 10 s,
fly a 10 m square with four DO_REPOSITION legs (N 10, then E 10, then back to
N 0, then E 0, relative to the hold point, waiting at each corner until within
0.5 m and slower than 0.5 m/s), land and wait for the automatic disarm.
Durations the vehicle must hold are simulated seconds (the vehicle's clock),
so the flight is the same at any ``--speed``; timeouts are wall seconds.

``--wait`` instead starts both processes (in real time by default) and prints
how to connect QGroundControl, MAVProxy, MAVSDK or ``gcs``, until Ctrl-C.

Paths (``--log-dir``, ``--vehicle FILE.toml``, paths in ``--sitl-arg``/``--autopilot-arg``) are
relative to the working directory the demo is started in.

Exit codes: 0 success, 1 a step failed (refused, child died, check failed, a directory that
cannot be created), 2 usage error, 3 a step timed out (no answer from the vehicle), 130 interrupted.
"""

from __future__ import annotations

import argparse
import math
import shutil
import signal
import sys
import threading
import time
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import TYPE_CHECKING

from mavsim_core import ports
from mavsim_core.cli_args import EXIT_NO_ANSWER, EXIT_USAGE
from mavsim_core.cli_checks import make_dir, startup_failed

from ..client import VehicleClient
from ..errors import CommandRefused, GcsError, GcsTimeout, StatusText
from ..frame_log import FRAMES_SUFFIX
from ..sim_client import SimClient
from .demo_args import build_parser
from .multi_demo import MultiDemo
from .multi_stack import MultiStack
from .stack import Stack, StackError

if TYPE_CHECKING:
    from .landing_run import LandingSetup

ARRIVAL_RADIUS_M = 0.5
ARRIVAL_SPEED_M_S = 0.5


@dataclass
class FlightLog:
    """What the demo measures while flying (fed every message by a client listener)."""

    client: VehicleClient
    max_alt_m: float = -math.inf
    armed_at_s: float | None = None
    disarmed_at_s: float | None = None
    liftoff_at_s: float | None = None
    touchdown_at_s: float | None = None
    corners: list[tuple[str, float, float, float]] = field(default_factory=list)  # name, horiz err, alt err, t
    hold_drift_m: float = 0.0
    landing_error_m: float | None = None

    def __call__(self, msg) -> None:
        mtype = msg.get_type()
        now = self.client.sim_time_s()
        if mtype == "GLOBAL_POSITION_INT":
            self.max_alt_m = max(self.max_alt_m, msg.relative_alt / 1000.0)
        elif mtype == "EXTENDED_SYS_STATE":
            if msg.landed_state in (2, 3) and self.liftoff_at_s is None:  # IN_AIR, TAKEOFF
                self.liftoff_at_s = now
            elif msg.landed_state == 1 and self.liftoff_at_s is not None and self.touchdown_at_s is None:
                self.touchdown_at_s = now
        elif mtype == "HEARTBEAT":
            armed = bool(msg.base_mode & 128)
            if armed and self.armed_at_s is None:
                self.armed_at_s = now
            elif not armed and self.armed_at_s is not None and self.disarmed_at_s is None:
                self.disarmed_at_s = now

    def flight_time_s(self) -> float | None:
        """Liftoff to touchdown (landed state), else arm to disarm, simulated seconds."""
        if self.liftoff_at_s is not None and self.touchdown_at_s is not None:
            return self.touchdown_at_s - self.liftoff_at_s
        if self.armed_at_s is not None and self.disarmed_at_s is not None:
            return self.disarmed_at_s - self.armed_at_s
        return None


class Demo:
    """The scripted flight against a connected client; each step prints a progress line."""

    def __init__(self, client: VehicleClient, args: argparse.Namespace) -> None:
        self.c = client
        self.args = args
        self.log = FlightLog(client)
        client.add_listener(self.log)
        self.step = "connect"

    def say(self, text: str) -> None:
        t = self.c.sim_time_s()
        stamp = f"{t:8.2f}" if t is not None else "       ?"
        print(f"[sim {stamp} s] {text}", flush=True)

    def run(self) -> None:
        c, a = self.c, self.args
        timeout = a.step_timeout

        self.step = "wait until ready to arm"
        self.say("waiting for the pre-arm checks to pass")
        c.wait_until(c.prearm_ok, a.ready_timeout, "the vehicle to be ready to arm (SYS_STATUS pre-arm check)")
        c.wait_home(timeout)
        self.say("ready to arm")

        self.step = "arm"
        c.arm(timeout_s=10).check()
        c.wait_armed(True, timeout)
        home = c.wait_home(timeout)
        self.say(f"armed; home {home.lat_deg:.7f}, {home.lon_deg:.7f}, {home.alt_amsl_m:.2f} m AMSL")

        self.step = "takeoff"
        c.takeoff(home.alt_amsl_m + a.alt, timeout_s=10).check()
        self.say(f"taking off to {a.alt:g} m")
        c.wait_until(lambda: c.takeoff_done(a.alt), timeout, f"takeoff to {a.alt:g} m")
        self.say(f"reached {c.relative_alt_m():.2f} m (mode {c.mode_name()})")

        self.step = "hold"
        hold_n, hold_e, _ = c.position_ned()

        def drift(msg) -> None:
            if msg.get_type() == "GLOBAL_POSITION_INT" and (p := c.position_ned()) is not None:
                self.log.hold_drift_m = max(self.log.hold_drift_m, math.hypot(p[0] - hold_n, p[1] - hold_e))

        c.add_listener(drift)
        c.wait_sim_time(a.hold, timeout, f"{a.hold:g} s of hover")
        c.remove_listener(drift)
        self.say(f"held {a.hold:g} s at N {hold_n:.2f} E {hold_e:.2f}; max drift {self.log.hold_drift_m:.2f} m")

        legs = (
            ("corner 1 (N)", a.side, 0.0),
            ("corner 2 (NE)", a.side, a.side),
            ("corner 3 (E)", 0.0, a.side),
            ("corner 4 (start)", 0.0, 0.0),
        )
        for name, dn, de in legs:
            self.step = f"fly to {name}"
            tn, te = hold_n + dn, hold_e + de
            c.goto_ned(tn, te, -a.alt, timeout_s=10).check()
            self.say(f"flying to {name}: N {tn:.2f} E {te:.2f} alt {a.alt:g}")
            c.wait_until(
                lambda: c.arrived(tn, te, ARRIVAL_RADIUS_M, ARRIVAL_SPEED_M_S),
                timeout,
                f"arrival at {name} (N {tn:.2f} E {te:.2f})",
            )
            n, e, d = c.position_ned()
            herr, verr = math.hypot(n - tn, e - te), -d - a.alt
            self.log.corners.append((name, herr, verr, c.sim_time_s()))
            self.say(f"at {name}: horizontal error {herr:.2f} m, altitude error {verr:+.2f} m")

        self.step = "land"
        c.land(timeout_s=10).check()
        self.say("landing")
        c.wait_until(lambda: not c.armed() or c.on_ground() is True, timeout, "touchdown")
        n, e, _ = c.position_ned()
        self.log.landing_error_m = math.hypot(n, e)
        self.say(f"touched down at N {n:.2f} E {e:.2f} ({self.log.landing_error_m:.2f} m from home)")
        self.step = "automatic disarm"
        c.wait_until(c.landed_and_disarmed, timeout, "the automatic disarm after landing")
        self.say("disarmed")

    def summary(self, wall_total_s: float, wall_flight_s: float, sim_flight_s: float) -> str:
        log = self.log
        lines = ["", "=== flight summary ==="]
        ft = log.flight_time_s()
        lines.append(f"flight time        {ft:.2f} s (simulated)" if ft is not None else "flight time        ?")
        lines.append(f"max altitude       {log.max_alt_m:.2f} m above home")
        lines.append(f"hold drift (max)   {log.hold_drift_m:.2f} m")
        for name, herr, verr, _t in log.corners:
            lines.append(f"{name:<18} arrival error {herr:.2f} m horizontal, {verr:+.2f} m vertical")
        if log.landing_error_m is not None:
            lines.append(f"landing error      {log.landing_error_m:.2f} m from home")
        rtf = sim_flight_s / wall_flight_s if wall_flight_s > 0 else math.nan
        lines.append(
            f"wall time          {wall_total_s:.1f} s total, {wall_flight_s:.1f} s from first telemetry to the end"
        )
        lines.append(f"real-time factor   {rtf:.2f} ({sim_flight_s:.1f} simulated s / {wall_flight_s:.1f} wall s)")
        return "\n".join(lines)


def show_statustext(st: StatusText) -> None:
    """Print a vehicle STATUSTEXT stamped with vehicle time (the demo's on_statustext callback)."""
    stamp = f"{st.sim_time_s:8.2f}" if st.sim_time_s is not None else "       ?"
    print(f"[sim {stamp} s] vehicle {st.severity_name}: {st.text}", flush=True)


def _print_tails(stack: Stack, lines: int = 20) -> None:
    for name in stack.procs:
        print(f"--- last lines of {stack.log_path(name)} ---", file=sys.stderr)
        print(stack.tail(name, lines).rstrip(), file=sys.stderr)
    print(f"(full logs in {stack.log_dir})", file=sys.stderr)


def console_script(name: str) -> str:
    """How to type this environment's console script ``name`` from the caller's directory: the bare name when
    the shell finds this very one (an activated virtual environment), else its path (``.venv/bin/gcs``)."""
    here = Path(sys.executable).parent / name
    if shutil.which(name) == str(here):
        return name
    try:
        return str(here.relative_to(Path.cwd()))
    except ValueError:
        return str(here)


def logs_line(stack: Stack) -> str:
    """Where the flight's logs went and the command that plots them, as the caller can type it (``.frames.npy``,
    the camera's frames, only when the simulator wrote one: a flight with the camera)."""
    plot = f"{console_script('gcs')} plot {stack.log_dir}"
    frames = f", {FRAMES_SUFFIX}" if any(Path(stack.log_dir).glob(f"*{FRAMES_SUFFIX}")) else ""
    return f"flight logs (.ulg, .tlog, .truth.npy{frames}) in {stack.log_dir}; plot them: {plot}"


def connection_help(stack: Stack) -> str:
    """How to connect ground stations to a running stack."""
    i, gcs, api = stack.instance, stack.gcs_port, stack.api_port
    qgc = (
        "QGroundControl: start it; it auto-connects on UDP 14550"
        if gcs == 14550
        else f"QGroundControl: add a UDP comm link listening on port {gcs} (it auto-listens only on 14550)"
    )
    return "\n".join(
        [
            f"stack running (instance {i}, speed {stack.speed}); logs in {stack.log_dir}",
            f"  {qgc}",
            f"  MAVProxy:  mavproxy.py --master udpin:0.0.0.0:{gcs}",
            f'  MAVSDK 4:  await sdk.add_any_connection("udpin://0.0.0.0:{api}")  (examples/mavsdk_fly.py)'
            + _more_vehicles(stack),
            f"  gcs:       {console_script('gcs')} --instance {i} status"
            if i
            else f"  gcs:       {console_script('gcs')} status",
            "Ctrl-C to stop.",
        ]
    )


def _more_vehicles(stack: Stack) -> str:
    """The other vehicles of a MultiStack: their system ids and API ports (all on the one ground-station port)."""
    if not isinstance(stack, MultiStack):
        return ""
    each = ", ".join(f"sysid {stack.sysid_of(k)} on UDP {ports.api_port(i)}" for k, i in enumerate(stack.instances))
    return f"\n  {stack.count} vehicles, one per API port: {each}; all on the ground-station port {stack.gcs_port}"


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    if args.video is not None:  # the flight, then its video from its logs (gcs/launcher/replay.py)
        from .replay import demo_with_video

        return demo_with_video(args, _main)
    return _main(args)


def _main(args: argparse.Namespace) -> int:
    if threading.current_thread() is threading.main_thread():
        # a plain `kill` should clean up like Ctrl-C: SystemExit runs the finally below
        signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))
    speed = args.speed or ("1" if args.wait else "max")
    wall_start = time.monotonic()
    if args.log_dir is not None:
        try:
            make_dir("--log-dir", args.log_dir)
        except OSError as exc:
            return startup_failed("flight-demo", exc)
    if args.count > 1 and args.instance + args.count - 1 > ports.MAX_INSTANCE:
        print(f"flight-demo: --count {args.count}: instances past 99", file=sys.stderr)
        return EXIT_USAGE
    landing = None
    if args.scenario == "ugv-landing":
        from .landing_run import LandingSetup  # MuJoCo's UGV model: imported only for this flight

        # as people fly it (one vehicle); several in one world fly through holds, side by side (multi_landing.py)
        several = args.count > 1
        landing = LandingSetup(vehicle=args.vehicle, seed=args.seed or 1, deterministic=several, video=not several)
    stack = _make_stack(args, speed, landing)
    demo = None
    client = None
    try:
        stack.start()
        if args.wait:
            print(connection_help(stack), flush=True)
            stack.wait()
            return 0
        print(f"started sitl (speed {speed}) and autopilot, {_instances(stack)}; logs in {stack.log_dir}", flush=True)
        if isinstance(stack, MultiStack) and landing is not None:
            demo = MultiDemo(stack, args, show_statustext)
            return multi_landing_demo(demo, landing)
        if isinstance(stack, MultiStack):
            demo = MultiDemo(stack, args, show_statustext)
            demo.fly(wall_start)
            print(logs_line(stack))
            print("flight demo: OK")
            return 0
        client = VehicleClient(
            stack.api_url, timeout_s=args.ready_timeout, idle=stack.check_alive, on_statustext=show_statustext
        )
        demo = Demo(client, args)
        client.wait_until(lambda: client.sim_time_s() is not None, args.step_timeout, "vehicle time")
        wall_flight_start, sim_flight_start = time.monotonic(), client.sim_time_s()
        demo.say(f"connected to {client.url}")
        if landing is not None:
            return landing_demo(client, landing, demo, stack)
        demo.run()
        wall_flight = time.monotonic() - wall_flight_start
        sim_flight = client.sim_time_s() - sim_flight_start
        print(demo.summary(time.monotonic() - wall_start, wall_flight, sim_flight))
        print(logs_line(stack))
        print("flight demo: OK")
        return 0
    except KeyboardInterrupt:
        print("\ninterrupted; stopping the stack", file=sys.stderr)
        return 130
    except StackError as exc:
        print(f"flight demo FAILED ({_step(demo)}): {exc}", file=sys.stderr)
        return 1
    except CommandRefused as exc:
        print(f"flight demo FAILED ({_step(demo)}): refused: {exc}", file=sys.stderr)
        _print_tails(stack)
        return 1
    except GcsTimeout as exc:
        print(f"flight demo FAILED ({_step(demo)}): {exc}", file=sys.stderr)
        _print_tails(stack)
        return EXIT_NO_ANSWER
    except GcsError as exc:
        print(f"flight demo FAILED ({_step(demo)}): {exc}", file=sys.stderr)
        _print_tails(stack)
        return 1
    finally:
        if client is not None:
            client.close()
        if isinstance(demo, MultiDemo):
            demo.close()
        stack.stop()


def _make_stack(args: argparse.Namespace, speed: str, landing: LandingSetup | None) -> Stack:
    """The stack of the demo: one vehicle (:class:`Stack`) or ``--count`` of them in one world (:class:`MultiStack`)."""
    return (Stack if args.count == 1 else partial(MultiStack, count=args.count))(
        args.instance,
        speed,
        args.vehicle,
        (landing.sim_args() if landing else []) + args.sitl_arg,
        args.autopilot_arg,
        home=args.home,
        seed=args.seed,
        log_dir=args.log_dir,
        sitl_module=args.sitl_module,
        autopilot_module=args.autopilot_module,
        gcs_port=ports.GCS_PORT,  # where QGroundControl listens, as PX4 SITL
    )


def _instances(stack: Stack) -> str:
    """ "instance N", or "instances N..M" of a MultiStack."""
    if isinstance(stack, MultiStack):
        return f"{stack.count} vehicles in one world, instances {stack.instance}..{stack.instances[-1]}"
    return f"instance {stack.instance}"


def landing_demo(client: VehicleClient, setup: LandingSetup, demo: Demo, stack: Stack) -> int:
    """``--scenario ugv-landing``: one precision landing on the UGV; exit 0 only if it stayed on the deck."""
    from .deck_stance import LEVEL_TOLERANCE_M
    from .landing_run import STAY_ON_DECK_S, fly_landing

    demo.step = "precision landing on the UGV"
    with SimClient(ports.sim_component_port(stack.instance)) as truth:
        result = fly_landing(client, truth, setup, say=demo.say, timeout_s=demo.args.step_timeout)
    print(f"touchdown error: {result.touchdown_error_m:.3f} m")
    print(f"time to land: {result.time_to_land_s:.1f} s (simulated, from NAV_LAND to the motors cut)")
    print(f"UGV speed at touchdown: {result.ugv_speed_at_touchdown_m_s:.2f} m/s")
    print(
        f"on the deck {STAY_ON_DECK_S:g} s later: {result.feet_on_deck} feet on it, "
        f"{result.deck_level_err_cm:+.1f} cm from a level stance (within {100 * LEVEL_TOLERANCE_M:g} cm: level), "
        f"{result.square_off_deg:.0f} deg off square to its edges"
    )
    print(f"real-time factor: {result.real_time_factor:.2f}")
    print(logs_line(stack))
    if not result.success:
        print(f"flight demo FAILED (step: {demo.step}): {result.reason}", file=sys.stderr)
        return 1
    print("flight demo: OK (landed on the UGV's deck)")
    return 0


def multi_landing_demo(demo: MultiDemo, setup: LandingSetup) -> int:
    """``--count N --scenario ugv-landing``: each vehicle lands on its own moving UGV; exit 0 only if all are on
    their decks (gcs/launcher/multi_landing.py)."""
    from .multi_landing import fly_multi_landing, summary

    demo.step = f"{demo.stack.count} precision landings, each on its own UGV"
    demo.open()
    runs = demo.runs
    results = fly_multi_landing([r.client for r in runs], [r.truth for r in runs], setup, say=demo.say,
                                timeout_s=demo.args.step_timeout)  # fmt: skip
    print(summary(results, [r.sysid for r in runs]))
    print(logs_line(demo.stack))
    failed = [k for k, r in enumerate(results) if not r.success]
    if failed:
        print(f"flight demo FAILED (step: {demo.step}): vehicles {failed} not on their decks", file=sys.stderr)
        return 1
    print("flight demo: OK (every vehicle landed on its own UGV's deck)")
    return 0


def _step(demo: Demo | MultiDemo | None) -> str:
    return f"step: {demo.step}" if demo is not None else "step: start-up"


if __name__ == "__main__":
    sys.exit(main())
