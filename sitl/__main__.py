"""``sitl``: start the simulator process.  ``sitl --help`` lists the options."""

from __future__ import annotations

import argparse
import math
import signal
import sys
import time
from copy import deepcopy
from pathlib import Path

from mavsim_core import ports
from mavsim_core.cli_args import EXIT_CODES_EPILOG, EXIT_USAGE, add_instance_option, add_version_option, port_number
from mavsim_core.cli_checks import (
    host_address,
    make_dir,
    non_negative_int,
    port_or_zero,
    positive_int,
    positive_number,
    startup_failed,
)
from params.vehicle_arg import vehicle_argument
from sitl.scenario import Scenario, ScenarioError, list_scenarios, load_scenario
from sitl.sim_params import SimParamError, SimParameters, format_table
from sitl.sim_settings import CameraSettings, MotorSettings, SensorSettings, UgvSettings, WindSettings

DEFAULT_HOME = (47.397742, 8.545594, 488.0)  # PX4's default SITL home, Zurich


def parse_speed(text: str) -> float | None:
    """argparse ``type`` of ``--speed``: ``max`` (None: unpaced) or a finite real-time factor > 0."""
    if text.lower() == "max":
        return None
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number or 'max', not {text!r}") from None
    if not (v > 0 and math.isfinite(v)):
        raise argparse.ArgumentTypeError(f"must be a real-time factor > 0 or 'max', not {text!r}")
    return v


def parse_home(text: str) -> tuple[float, float, float]:
    """argparse ``type`` of ``--home``: ``LAT,LON,ALT`` (degrees, degrees, metres AMSL)."""
    try:
        lat, lon, alt = (float(x) for x in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be LAT,LON,ALT (degrees, degrees, metres AMSL), not {text!r}") from None
    if not (-90 < lat < 90 and -180 <= lon <= 180 and math.isfinite(alt)):
        raise argparse.ArgumentTypeError(
            f"latitude must be -90..90, longitude -180..180 and altitude a finite number, not {text!r}"
        )
    return lat, lon, alt


def parse_param_assignment(text: str) -> tuple[str, int | float]:
    """``NAME=VALUE`` of ``--param``: the syntax only; the name and range are checked later."""
    name, sep, value = text.partition("=")
    name, value = name.strip(), value.strip()
    if not sep or not name or not value:
        raise argparse.ArgumentTypeError(f"expected NAME=VALUE (e.g. SIM_WIND_SPD=5), not {text!r}")
    try:
        return name, int(value)
    except ValueError:
        pass
    try:
        return name, float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{name}: value must be a number, not {value!r}") from None


def _add_port_options(p: argparse.ArgumentParser) -> None:
    """``--count`` and the options of the ports: TCP of the lockstep link, UDP of the simulator's component."""
    p.add_argument(
        "--count", type=positive_int, default=1, metavar="K",
        help="simulate K multicopters in one world, 3 m apart along East: vehicle k is instance N+k (system id "
        "1+N+k, TCP 4560+N+k, UDP 14740+N+k), its own flight controller; the world steps when all have answered. "
        "With the UGV (SIM_UGV_EN) each has its own, 10 m apart, its own camera, companion and deck marker ids. "
        "Explicit --port/--truth-port/--truth-local-port/--ugv-radio-port are vehicle 0's, vehicle k's are +k",
    )  # fmt: skip
    p.add_argument("--port", type=port_number, help="TCP port the flight controller connects to (default 4560+N)")
    p.add_argument(
        "--bind", default="127.0.0.1", metavar="ADDR", type=host_address,
        help="local address of the TCP port and of the simulator's MAVLink component (ground truth, SIM_* "
        "parameters); default 127.0.0.1: only this machine reaches them; 0.0.0.0: every interface (anyone on "
        "the network can then drive the simulation and set SIM_* parameters)",
    )  # fmt: skip
    p.add_argument(
        "--truth-port", type=port_or_zero,
        help="UDP port the simulator's MAVLink component (ground truth, SIM_* parameters, the ground vehicle) "
        "sends to (default 14740+N); 0 disables it",
    )  # fmt: skip
    p.add_argument("--truth-host", default="127.0.0.1", type=host_address)
    p.add_argument(
        "--truth-local-port",
        type=port_or_zero,
        default=0,
        help="local UDP port of the simulator's MAVLink component; 0 = chosen by the OS",
    )
    p.add_argument(
        "--ugv-radio-port", type=port_number,
        help="UDP port the ground vehicle's FOLLOW_TARGET goes to (SIM_UGV_FLW=1), on --truth-host: the flight "
        "controller's API-side socket (default 14640+N)",
    )  # fmt: skip


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="sitl",
        description="MuJoCo multirotor simulator (PX4 simulator MAVLink API, lockstep)",
        epilog=EXIT_CODES_EPILOG,
    )
    add_version_option(p)
    p.add_argument(
        "--vehicle", default="quad_x", type=vehicle_argument,
        help="vehicle name in params/vehicles or a .toml path (relative to the working directory)",
    )  # fmt: skip
    p.add_argument("--speed", type=parse_speed, default=1.0, help="1 = real time, N = N x real time, 'max' = unpaced")
    add_instance_option(
        p,
        help=f"vehicle instance 0-{ports.MAX_INSTANCE}, as PX4's -i: system id 1+N, TCP port 4560+N, "
        "ground truth and SIM_* parameters to UDP 14740+N",
    )
    _add_port_options(p)
    p.add_argument("--home", type=parse_home, default=DEFAULT_HOME, help="LAT,LON,ALT of the start point")
    p.add_argument("--seed", type=non_negative_int, default=0, help="random seed of the sensor noise")
    p.add_argument("--duration", type=positive_number, default=None, help="stop after this many simulated seconds")
    p.add_argument(
        "--scenario",
        metavar="NAME|FILE",
        help=f"SIM_* parameters and timed events from a TOML file (relative to the working directory) or a "
        f"shipped scenario ({', '.join(list_scenarios())})",
    )
    p.add_argument(
        "--param",
        metavar="NAME=VALUE",
        type=parse_param_assignment,
        action="append",
        default=[],
        help="set a SIM_* parameter at start-up (repeatable; applied after --scenario)",
    )
    p.add_argument(
        "--list-params",
        action="store_true",
        help="print the SIM_* parameters (with --scenario/--param applied) and exit",
    )
    p.add_argument(
        "--log-dir",
        metavar="DIR",
        default=None,
        help="write a ground-truth log (.truth.npy) per arming here (default: none); created if need be, "
        "a directory that cannot be created stops the start (exit 1)",
    )
    p.add_argument(
        "--save-frames",
        metavar="DIR",
        default=None,
        help="save every 10th camera frame, annotated by the vision companion, as PNG here (default: none)",
    )
    p.add_argument(
        "--media-dir",
        metavar="DIR",
        default=None,
        help="where the camera's photos and recordings go (MAV_CMD_IMAGE_START_CAPTURE, VIDEO_START_CAPTURE); "
        "default: DIR/camera under --log-dir, else a folder in the system's temporary directory",
    )
    p.add_argument("--video-host", default="127.0.0.1", type=host_address, help="where the RTP video goes")
    p.add_argument("--video-port", type=port_number, help="UDP port of the RTP video (default 5600+N)")
    p.add_argument("--camera-port", type=port_number, help="the MAVLink camera's local UDP port (default 14030+N)")
    p.add_argument(
        "--payload-port", type=port_number,
        help="the flight controller's payload link, where the MAVLink camera sends (default 14280+N)",
    )  # fmt: skip
    return p


def configure(
    args: argparse.Namespace,
) -> tuple[tuple[WindSettings, SensorSettings, MotorSettings, UgvSettings, CameraSettings], Scenario | None]:
    """The settings objects with the scenario's parameters, then ``--param``, applied.

    Raises ScenarioError or SimParamError (nothing is half-applied: each step checks all its values first).
    """
    settings = (WindSettings(), SensorSettings(), MotorSettings(), UgvSettings(), CameraSettings())
    params = SimParameters(*settings)
    scenario = load_scenario(args.scenario, params) if args.scenario else None
    if scenario is not None:
        params.set_many(scenario.parameters)
        if scenario.pad is not None:
            settings[3].nested_pad = scenario.pad
    params.set_many(dict(args.param))  # later --param of the same name wins
    return settings, scenario


def _companion(sim, camera: CameraSettings, args: argparse.Namespace, k: int = 0):
    """Vehicle ``k``'s camera and vision companion, when the world has the UGV (a marker to see) and the
    vehicle a camera; None otherwise (rendering would cost ~40 % of the speed for nothing).  In a world where each
    vehicle has its own ground vehicle, vehicle k's camera looks for its own deck's markers (``sim.pad``)."""
    if sim.ugv is None or sim.spec.camera.rate_hz <= 0:
        return None
    from sitl.companion import LockstepCompanion
    from sitl.multicopter import vehicle_seed

    save = Path(args.save_frames) if args.save_frames else None
    if save is not None and k > 0:
        save = save / f"vehicle-{k}"
    own = getattr(sim, "world", None) is not None and sim.world.own_ugvs
    return LockstepCompanion(
        sim.model,
        sim.spec.camera,
        camera,
        seed=vehicle_seed(args.seed, k),
        save_dir=save,
        sysid=ports.system_id(args.instance + k),
        pad=sim.pad,
        vehicle=k,
        ugv=k if own else 0,
        fork_worker=True,  # (nothing rendered here yet: its frames' process forked, not started afresh)
    )


def _print_started(spec, args: argparse.Namespace, scenario: Scenario | None, servers) -> None:
    """What was started, on stderr: vehicle, speed, home, scenario, each vehicle's MAVLink component."""
    speed = "max" if args.speed is None else f"{args.speed:g}x"
    count = f"{args.count} x " if args.count > 1 else ""
    print(
        f"[sitl] vehicle {count}{spec.name} ({len(spec.rotors)} rotors, {spec.mass_kg:.3g} kg), speed {speed}, "
        f"home {args.home[0]:.6f},{args.home[1]:.6f},{args.home[2]:.1f}",
        file=sys.stderr,
        flush=True,
    )
    if scenario is not None:
        about = f": {scenario.description}" if scenario.description else ""
        print(
            f"[sitl] scenario {scenario.name}{about} ({len(scenario.parameters)} parameters, "
            f"{len(scenario.events)} events)",
            file=sys.stderr,
            flush=True,
        )
    for server in servers:
        tcp = f"TCP {server.port}; " if len(servers) > 1 else ""
        if server.param_server is not None:
            host, port = server.param_server.local_address[:2]
            dest = server.truth_addr
            print(
                f"[sitl] {tcp}SIM_* parameters and ground truth: MAVLink sysid {server.sysid} compid 51 on UDP "
                f"{host}:{port}, sending to {dest[0]}:{dest[1]}",
                file=sys.stderr,
                flush=True,
            )


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        server = _start(args)
    except (OSError, ValueError, KeyboardInterrupt) as exc:  # the start only: the loop's bugs keep their traceback
        return startup_failed("sitl", exc, args.instance)
    if isinstance(server, int):
        return server
    wall0, cpu0 = time.monotonic(), time.process_time()
    try:
        server.run(args.duration)
    except KeyboardInterrupt:
        pass
    finally:
        server.close()
        for vehicle in getattr(server, "servers", [server]):  # a WorldLockstep: each vehicle's server
            if vehicle.truth_log is not None:
                vehicle.truth_log.close()
        _print_totals(getattr(server, "servers", [server])[0].sim.time_us / 1e6, wall0, cpu0)
    return 0


def _print_totals(sim_s: float, wall0: float, cpu0: float) -> None:
    """The run's last log line: simulated seconds, wall seconds and this process's CPU seconds (what a suite
    or a campaign spends where: docs/testing.md, "Time")."""
    wall_s, cpu_s = time.monotonic() - wall0, time.process_time() - cpu0
    rtf = f"{sim_s / wall_s:.1f}x" if wall_s > 0 else "-"
    print(f"[sitl] simulated {sim_s:.1f} s in {wall_s:.1f} wall s ({rtf}), {cpu_s:.1f} CPU s", flush=True)


def _start(args: argparse.Namespace):
    """Everything before the loop: the LockstepServer (``--count`` > 1: the WorldLockstep of every vehicle's),
    listening; or the exit code (0 ``--list-params``, 2).

    Raises OSError or ValueError when starting fails (a port in use, a directory that cannot be created).
    """
    if (last := args.instance + args.count - 1) > ports.MAX_INSTANCE:
        print(f"sitl: --count {args.count} from -i {args.instance} needs instance {last} (max 99)", file=sys.stderr)
        return EXIT_USAGE
    if args.port is None:
        args.port = ports.sim_tcp_port(args.instance)
    if args.truth_port is None:
        args.truth_port = ports.sim_component_port(args.instance)
    try:
        (wind, sensors, motors, ugv, camera), scenario = configure(args)
    except ScenarioError as exc:
        print(f"sitl: --scenario {exc}", file=sys.stderr)
        return EXIT_USAGE
    except SimParamError as exc:
        print(f"sitl: --param {exc}", file=sys.stderr)
        return EXIT_USAGE
    if args.list_params:
        print(format_table(SimParameters(wind, sensors, motors, ugv, camera).describe()))
        return 0
    from params.vehicle import load_vehicle

    spec = load_vehicle(args.vehicle)  # checked by argparse already
    # SIM_CAM_MOUNT (read at start).  Left to the vehicle file (0), the gimbal is built only in a world with the UGV,
    # the one world whose camera renders: its joints and controller cost a stack 17-28 % of its CPU per simulated
    # second (2026-12-02), for a camera no one sees.  2 builds it anyway (a ground station's gimbal controls).
    file_mount = spec.camera.mount if ugv.enabled else "fixed"
    spec = spec.with_camera_mount(camera.mount_name(file_mount))
    for option, path in (("--log-dir", args.log_dir), ("--save-frames", args.save_frames)):
        if path:
            make_dir(option, path)
    from sitl.simulation import SPACING_M, UGV_SPACING_M, Simulation, VehicleView, World, spread

    if args.count == 1:
        sim = Simulation(
            spec, args.home, seed=args.seed, wind=wind, sensors=sensors, motors=motors, ugv=ugv, camera=camera
        )
        views = [sim]
    else:  # every vehicle its own copy of the per-vehicle settings and its own UGV; the air is the world's
        own = [(sensors, motors, camera, ugv)] + [
            deepcopy((sensors, motors, camera, ugv)) for _ in range(1, args.count)
        ]
        sensors_k, motors_k, cameras_k, ugvs_k = zip(*own)
        spacing = UGV_SPACING_M if ugv.enabled else SPACING_M
        world = World(
            spread(spec, args.count, spacing), args.home, args.seed, wind, ugv,
            sensors=sensors_k, motors=motors_k, cameras=cameras_k, ugvs=ugvs_k,
        )  # fmt: skip
        views = [VehicleView(world, k) for k in range(args.count)]
    servers = []
    try:
        for k, view in enumerate(views):
            servers.append(_vehicle_server(args, k, view, scenario))
    except BaseException:
        for server in servers:
            server.close()
        raise
    signal.signal(signal.SIGTERM, lambda *_: sys.exit(143))  # a plain kill closes the log like Ctrl-C
    _print_started(spec, args, scenario, servers)
    for server in servers:  # a frame waited for stalls the whole world: every flight controller hears it is alive
        if server.companion is not None:
            server.companion.keepalive = lambda: [s.busy_keepalive() for s in servers]
    if args.count == 1:
        return servers[0]
    from sitl.world_lockstep import WorldLockstep

    return WorldLockstep(world, servers, args.speed)


def _vehicle_server(args: argparse.Namespace, k: int, sim, scenario: Scenario | None):
    """Vehicle ``k``'s LockstepServer (instance ``--instance`` + k) with its optional parts, listening."""
    from sitl.lockstep import LockstepServer

    instance = args.instance + k
    truth = (args.truth_host, args.truth_port + k) if args.truth_port else None
    local_port = args.truth_local_port + k if args.truth_local_port else 0
    server = LockstepServer(
        sim,
        args.port + k,
        truth,
        args.speed,
        truth_bind=(args.bind, local_port),
        bind_host=args.bind,
        events=scenario.events if scenario else (),
        sysid=ports.system_id(instance),
    )
    try:
        _attach(server, sim, k, args)
    except BaseException:
        server.close()
        raise
    return server


def _attach(server, sim, k: int, args: argparse.Namespace) -> None:
    """Vehicle ``k``'s optional parts: the vision companion, the UGV's radio, the ground-truth log."""
    instance = args.instance + k
    server.companion = _companion(sim, sim.camera_settings, args, k)  # each vehicle its own camera and companion
    if server.companion is not None:  # a MAVLink camera (component 100) with its video (sitl/camera_setup.py)
        from sitl.camera_setup import camera_component

        server.camera = camera_component(server.companion, sim, args, k)
    if sim.ugv is not None:  # its telemetry radio: FOLLOW_TARGET while SIM_UGV_FLW = 1 (sitl/ugv_broadcast.py)
        from sitl.ugv_broadcast import UgvRadio

        port = args.ugv_radio_port + k if args.ugv_radio_port else ports.api_local_port(instance)
        dest, sysid = (args.truth_host, port), ports.system_id(instance)
        server.ugv_radio = UgvRadio(sim.ugv_settings, dest, sysid, sim.sensors.home)  # its truth: this vehicle's frame
    if args.log_dir:  # ground-truth log, one per arming (sitl/truth_log.py)
        from sitl.truth_log import TruthRecorder

        server.truth_log = TruthRecorder(args.log_dir, len(sim.spec.rotors), instance, ugv=sim.ugv is not None)
        from sitl.flight_setup import SetupRecorder  # and the world it flew in beside it (.sim.json, gcs replay)

        server.truth_log.on_open = SetupRecorder(args, sim, server.params)
        if server.companion is not None:  # and each camera frame's record beside it (.frames.npy)
            server.companion.on_frame = server.truth_log.record_frame


if __name__ == "__main__":
    sys.exit(main())
