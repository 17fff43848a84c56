"""``sitl``: start the simulator process.  ``sitl --help`` lists the options."""

from __future__ import annotations

import argparse
import sys

from params.vehicle import VehicleFileError, load_vehicle

DEFAULT_HOME = (47.397742, 8.545594, 488.0)  # PX4's default SITL home, Zurich


def parse_speed(text: str) -> float | None:
    if text.lower() == "max":
        return None
    try:
        v = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"speed must be a number or 'max', not {text!r}") from None
    if not v > 0:
        raise argparse.ArgumentTypeError("speed must be > 0")
    return v


def parse_home(text: str) -> tuple[float, float, float]:
    try:
        lat, lon, alt = (float(x) for x in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError("home must be LAT,LON,ALT (degrees, degrees, metres AMSL)") from None
    if not (-90 < lat < 90 and -180 <= lon <= 180):
        raise argparse.ArgumentTypeError("home latitude/longitude out of range")
    return lat, lon, alt


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="sitl", description="MuJoCo multirotor simulator (PX4 simulator MAVLink API, lockstep)")
    p.add_argument("--vehicle", default="quad_x", help="vehicle name in params/vehicles or a .toml path")
    p.add_argument("--speed", type=parse_speed, default=1.0, help="1 = real time, N = N x real time, 'max' = unpaced")
    p.add_argument("--instance", "-i", type=int, default=0, help="offsets every port, like PX4's -i")
    p.add_argument("--port", type=int, default=4560, help="TCP port the flight controller connects to (+instance)")
    p.add_argument("--truth-port", type=int, default=14560, help="UDP port for ground truth (+instance); 0 disables")
    p.add_argument("--truth-host", default="127.0.0.1")
    p.add_argument("--home", type=parse_home, default=DEFAULT_HOME, help="LAT,LON,ALT of the start point")
    p.add_argument("--seed", type=int, default=0, help="random seed of the sensor noise")
    p.add_argument("--duration", type=float, default=None, help="stop after this many simulated seconds")
    return p


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        spec = load_vehicle(args.vehicle)
    except VehicleFileError as exc:
        print(f"sitl: {exc}", file=sys.stderr)
        return 2
    from sitl.lockstep import LockstepServer
    from sitl.simulation import Simulation

    sim = Simulation(spec, args.home, seed=args.seed)
    truth = (args.truth_host, args.truth_port + args.instance) if args.truth_port else None
    try:
        server = LockstepServer(sim, args.port + args.instance, truth, args.speed)
    except OSError as exc:
        print(f"sitl: cannot listen on TCP port {args.port + args.instance}: {exc}", file=sys.stderr)
        return 2
    speed = "max" if args.speed is None else f"{args.speed:g}x"
    print(f"[sitl] vehicle {spec.name} ({len(spec.rotors)} rotors, {spec.mass_kg:.3g} kg), speed {speed}, "
          f"home {args.home[0]:.6f},{args.home[1]:.6f},{args.home[2]:.1f}", file=sys.stderr, flush=True)
    try:
        server.run(args.duration)
    except KeyboardInterrupt:
        pass
    return 0


if __name__ == "__main__":
    sys.exit(main())
