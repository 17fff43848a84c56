"""``autopilot``: start the flight-controller process.  ``autopilot --help`` lists the options.

``main`` parses the options and wires the parts (parameters, flight controller,
ground-station link, flight logs, simulator link); the loop itself, lockstep with
the simulator, is :func:`autopilot.lockstep_loop.run_lockstep`.
"""

from __future__ import annotations

import argparse
import signal
import sys
import threading

from mavsim_core import ports
from mavsim_core.cli_args import EXIT_CODES_EPILOG, add_instance_option, add_version_option, port_number
from mavsim_core.cli_checks import check_readable, host_address, make_dir, startup_failed, system_id
from params.vehicle_arg import vehicle_argument


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="autopilot", description="Multirotor flight controller (PX4-compatible MAVLink)", epilog=EXIT_CODES_EPILOG
    )
    add_version_option(p)
    p.add_argument(
        "--vehicle", default="quad_x", type=vehicle_argument,
        help="vehicle name in params/vehicles or a .toml path (relative to the working directory)",
    )  # fmt: skip
    add_instance_option(
        p,
        help=f"vehicle instance 0-{ports.MAX_INSTANCE}, as PX4's -i: system id 1+N, simulator TCP 4560+N, "
        "API link to UDP 14540+N, ground-station link to the shared UDP 14550 from local port 18570+N",
    )
    p.add_argument("--sim-host", default="127.0.0.1", type=host_address, help="the simulator's host")
    p.add_argument("--sim-port", type=port_number, help="simulator TCP port (default 4560+N)")
    p.add_argument(
        "--gcs-port", type=port_number, help="UDP port ground stations listen on (default 14550, every instance)"
    )
    p.add_argument("--api-port", type=port_number, help="UDP port APIs such as MAVSDK listen on (default 14540+N)")
    p.add_argument(
        "--gcs-local-port", type=port_number, help="local UDP port of the ground-station link (default 18570+N)"
    )
    p.add_argument(
        "--api-local-port",
        type=port_number,
        help="local UDP port of the API link, where companions send (default 14640+N)",
    )
    p.add_argument(
        "--payload-local-port", type=port_number,
        help="local UDP port of the onboard payload link, where a MAVLink camera talks (default 14280+N)",
    )  # fmt: skip
    p.add_argument("--camera-port", type=port_number, help="UDP port of the MAVLink camera (default 14030+N)")
    p.add_argument(
        "--sysid", type=system_id,
        help="MAVLink system id 1-255 (default: the MAV_SYS_ID parameter, 1+N unless --state-dir kept another); "
        "given, it also sets MAV_SYS_ID",
    )  # fmt: skip
    # -- parameters (autopilot/param_storage.py)
    p.add_argument(
        "--params",
        metavar="FILE",
        help="apply a parameter file at start-up (QGroundControl's tab-separated format or MAVProxy's "
        "NAME VALUE); bad lines are reported and skipped, an unreadable file stops the start (exit 1)",
    )
    p.add_argument(
        "--state-dir",
        metavar="DIR",
        help="save changed parameters in DIR/<vehicle>-<instance>.params, the uploaded mission, fence and "
        "rally plans in DIR/<vehicle>-<instance>.plan.json and the MAVLink signing key (SETUP_SIGNING) in "
        "DIR/<vehicle>-<instance>.signing, and load them at start-up "
        "(default: nothing saved, every run starts from the defaults)",
    )
    # -- flight logs (autopilot/flight_recorder.py)
    p.add_argument(
        "--log-dir",
        default="logs",
        metavar="DIR",
        help="write a .tlog and a ULog (.ulg) per arming here (default ./logs); a directory "
        "that cannot be created stops the start (exit 1)",
    )
    p.add_argument("--no-log", action="store_true", help="write no flight logs")
    p.add_argument(
        "--input-clock",
        choices=("sim+wall", "sim"),
        default="sim+wall",
        help="when an input from outside (sticks, offboard setpoints, a follow target, the ground station's "
        "HEARTBEAT) counts as lost: 'sim+wall' (default) once silent in simulated and in wall time, for clients "
        "that send on the wall clock while the simulation runs faster; 'sim' on simulated time alone, as PX4 in "
        "lockstep, for a client that acts in simulated time (a script stepping a held simulator)",
    )
    return p


def _resolve_ports(args: argparse.Namespace) -> None:
    """Fill in the ports and system id of ``args.instance`` not given (argparse checked the ranges)."""
    n = args.instance
    defaults = {
        "sim_port": ports.sim_tcp_port(n),
        "gcs_port": ports.GCS_PORT,
        "api_port": ports.api_port(n),
        "gcs_local_port": ports.gcs_local_port(n),
        "api_local_port": ports.api_local_port(n),
    }  # (the system id comes from MAV_SYS_ID once the parameters are loaded: autopilot.system_id)
    for name, default in defaults.items():
        if getattr(args, name) is None:
            setattr(args, name, default)


def _prepare_parameters(params, args: argparse.Namespace, vehicle_name: str, warnings: list[str]):
    """Vehicle defaults, saved state and --params into the store; the ParamSaver (None: not saving).

    ``warnings`` gets what the ground stations should be told (a corrupt state file kept aside).
    OSError naming the option if --state-dir cannot be created."""
    from autopilot.param_storage import ParamSaver, prepare_parameters, state_file
    from params.vehicle import vehicle_path

    state_path = None
    if args.state_dir:
        make_dir("--state-dir", args.state_dir)
        state_path = state_file(args.state_dir, vehicle_name, args.instance)
    warnings += prepare_parameters(
        params,
        vehicle_toml=vehicle_path(args.vehicle),
        state_path=state_path,
        params_path=args.params,
        log=lambda text: print(text, flush=True),
    )
    if state_path is None:
        return None
    print(f"[autopilot] parameter changes are saved to {state_path}", flush=True)
    return ParamSaver(params, state_path, vehicle_name=vehicle_name, initial_save=True)


def _keep_plans(fc, args: argparse.Namespace, vehicle_name: str) -> None:
    """Load the plans an earlier run saved in --state-dir and save every accepted change there."""
    from autopilot.plan_storage import load_plans, plan_file, save_plans

    path = plan_file(args.state_dir, vehicle_name, args.instance)
    try:
        plans = load_plans(path)
    except ValueError as exc:
        print(f"autopilot: ignoring the saved plans: {exc}", file=sys.stderr)
        plans = {}
    if plans:
        fc.commander.plans.load(plans)
        counts = ", ".join(f"{len(v)} {k}" for k, v in zip(("mission", "fence", "rally"), plans.values()))
        print(f"[autopilot] plans loaded from {path}: {counts} items", flush=True)

    def save(items) -> None:
        try:
            save_plans(path, items)
        except OSError as exc:
            print(f"autopilot: cannot save the plans to {path}: {exc}", file=sys.stderr)

    fc.commander.plans.save = save


def _import_landing_filters() -> None:
    """filterpy (and with it scipy.stats, 0.6 CPU s), imported on a thread of its own while the flight controller
    builds itself, and waited for before it connects to the simulator (which takes about as long to start), instead
    of on the lockstep's thread when the first landing target arrives: a precision landing started from a plain
    ``python -m autopilot`` stopped half a second there (issue 38); imported on a thread during the flight, it slowed
    every step it shared the interpreter with.  A process forked from a server that has imported it
    (gcs/launcher/fork_server.py) finds it imported.  Nothing computed depends on when it is imported."""
    try:
        import filterpy.kalman  # noqa: F401

        import autopilot.navigation.fast_ukf  # noqa: F401
    except Exception:  # noqa: BLE001 - imported again, where it is needed, with its error there
        pass


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    _resolve_ports(args)
    importing = None
    if "filterpy" not in sys.modules:
        importing = threading.Thread(target=_import_landing_filters, name="import-landing-filters", daemon=True)
        importing.start()
    parts: list = []  # what _start opened, closed on the way out whatever happens
    try:
        started = _start(args, parts)
    except (OSError, ValueError, KeyboardInterrupt) as exc:  # the start only: the loop's bugs keep their traceback
        _close(parts)
        return startup_failed("autopilot", exc, args.instance)
    from autopilot.lockstep_loop import run_lockstep

    if importing is not None:  # done before the lockstep starts: its thread would hold the lock the loop waits for
        importing.join()
    try:
        run_lockstep(*started)
    except KeyboardInterrupt:
        pass
    finally:
        _close(parts)
    return 0


def _close(parts: list) -> None:
    """Close what the start opened, in this order: the link, the parameter saver, the flight logs."""
    for part in parts:
        part.close()


def _start(args: argparse.Namespace, parts: list) -> tuple:
    """Everything before the loop; the arguments of :func:`run_lockstep`.  ``parts`` gets what needs closing.

    Raises OSError or ValueError when starting fails (a port in use, a file that cannot be read)."""
    from params.vehicle import load_vehicle

    spec = load_vehicle(args.vehicle)  # checked by argparse already
    from autopilot.flight_controller import FlightController
    from autopilot.link_setup import add_link_services
    from autopilot.mavlink.link import GcsLink
    from autopilot.mavlink.sim_link import SimLink
    from autopilot.mavlink.vehicle_interface import FlightControllerVehicle
    from autopilot.param_catalogue import default_store

    if args.params is not None:  # a start-up file that cannot be read stops the start (a typo, not a default)
        check_readable("--params", args.params)
    if not args.no_log:  # before anything is opened: a log directory that cannot be created stops the start
        make_dir("--log-dir", args.log_dir)
    from autopilot.system_id import set_instance_default, system_id_at_start

    params = default_store()
    set_instance_default(params, args.instance)  # MAV_SYS_ID 1+N, before a saved value is read
    warnings: list[str] = []
    saver = _prepare_parameters(params, args, spec.name, warnings)
    if saver is not None:
        parts.append(saver)
    args.sysid, note = system_id_at_start(params, args.sysid)
    if note is not None:
        print(f"autopilot: {note}", file=sys.stderr)
    if saver is not None:
        saver.request_save()  # (MAV_SYS_ID set by --sysid: on the disk now; nothing written when unchanged)
    fc = FlightController(spec, params, sysid=args.sysid)
    fc.commander.inputs.on_wall_clock = args.input_clock == "sim+wall"
    from pymavlink.dialects.v20.common import MAV_SEVERITY_CRITICAL

    for text in warnings:  # to the ground stations (STATUSTEXT) once the link runs
        fc.commander.say(MAV_SEVERITY_CRITICAL, text)
    fc.commander.param_saver = saver  # PREFLIGHT_STORAGE read/write (None without --state-dir)
    if args.state_dir:
        _keep_plans(fc, args, spec.name)
    link = GcsLink(
        FlightControllerVehicle(fc),
        instance=args.instance,
        sysid=args.sysid,
        compid=1,
        gcs_port=args.gcs_port,
        api_port=args.api_port,
        local_gcs_port=args.gcs_local_port,
        local_api_port=args.api_local_port,
    )
    parts.insert(0, link)
    recorder = None  # flight logs: one .tlog + ULog per arming
    if not args.no_log:
        from autopilot.flight_recorder import FlightRecorder

        recorder = FlightRecorder(args.log_dir, fc, instance=args.instance, sysid=args.sysid)
        parts.append(recorder)
        link.set_traffic_tap(recorder.tap)
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))  # a plain kill closes the logs like Ctrl-C
    sim = SimLink(args.sim_host, args.sim_port, args.sysid)
    add_link_services(link, fc, sim, args, recorder)
    print(
        f"[autopilot] vehicle {spec.name}, system id {args.sysid}, {len(params)} parameters, telemetry to "
        f"ground stations on UDP {args.gcs_port} (from {args.gcs_local_port}) and APIs on UDP {args.api_port} "
        f"(from {args.api_local_port})",
        flush=True,
    )
    return sim, fc, link, recorder


if __name__ == "__main__":
    sys.exit(main())
