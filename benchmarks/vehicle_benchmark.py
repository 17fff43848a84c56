"""Benchmark: both vehicles, hover in calm and in wind, 10 m step response, real-time factor.

For each vehicle (``quad_x``, ``firefly``) one stack runs (``--speed max``, lockstep,
telemetry on, the simulator's default sensor errors: IMU noise and bias walk, GPS at
5 Hz with 120 ms latency and a wandering error):

1. take off to 5 m, settle, hover 30 simulated seconds in calm air;
2. a 10 m position step North (DO_REPOSITION: the navigator's trajectory toward the
   new point, as a ground station's "go to" flies it): rise time 10-90 %, overshoot,
   settling time to within 0.1 m of the target;
3. turn on 5 m/s wind from the West with 1 m/s Dryden turbulence and 2 m/s gusts
   every ~10 s (``SIM_*`` parameters set over the simulator's MAVLink port), settle,
   hover 30 simulated seconds;
4. land.

Errors are ground truth (the simulator's LOCAL_POSITION_NED, float metres) against
the commanded point.  Real-time factor = simulated seconds / wall seconds over the
windy hover (all effects on) and over the whole flight.

A progress bar (stderr) counts the phases of each vehicle's flight (the numbered steps above, the
settling between them) and shows its simulated seconds.

Usage: ``python benchmarks/vehicle_benchmark.py [--vehicles quad_x firefly] [--hover S] [--seed N] [-i N]
[--sim-param NAME=VALUE] [--fc-param NAME=VALUE]``
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gcs.client import VehicleClient  # noqa: E402
from gcs.launcher import Stack  # noqa: E402
from gcs.sim_client import SimClient  # noqa: E402
from mavsim_core import ports  # noqa: E402
from sitl.scenario import load_scenario  # noqa: E402

from _cli import add_instance, parser  # noqa: E402
from _progress import Progress  # noqa: E402

ALT_M = 5.0
STEP_M = 10.0
PHASES = 9  # of each flight: ready, take-off, settle, calm hover, step, back, wind settle, wind hover, landed
WIND = load_scenario("windy").parameters  # params/scenarios/windy.toml: the same wind as `sitl --scenario windy`


def rms(a) -> float:
    a = np.asarray(a, dtype=float)
    return float(np.sqrt(np.mean(a * a))) if len(a) else float("nan")


def hover_errors(
    truth: SimClient, client: VehicleClient, target: np.ndarray, seconds: float, target_est: np.ndarray | None = None
):
    """Truth minus target over ``seconds`` of simulated time, the real-time factor, and the
    flight controller's own tracking error (its estimate minus ``target_est``, its frame)."""
    client.pump(0.05)
    t0 = truth.latest().time_ms
    est: list[tuple[float, float, float]] = []

    def listener(m) -> None:
        if m.get_type() == "LOCAL_POSITION_NED":
            est.append((m.x, m.y, m.z))

    client.add_listener(listener)
    wall0 = time.monotonic()
    while truth.latest().time_ms - t0 < seconds * 1000:
        client.pump(0.05)
    wall = time.monotonic() - wall0
    client.remove_listener(listener)
    samples = [s for s in truth.since(t0) if s.time_ms <= t0 + seconds * 1000]
    err = np.array([np.array(s.pos_ned_m) - target for s in samples])
    ctrl = np.array(est) - (target_est if target_est is not None else target) if est else np.zeros((0, 3))
    return err, seconds / wall, ctrl


def step_response(truth: SimClient, client: VehicleClient, start: np.ndarray, seconds: float = 25.0) -> dict:
    """Command a STEP_M North step from ``start`` (the flight controller's local frame) and measure
    the truth's response along North, from where the truth was when the step was commanded."""
    client.pump(0.05)
    t0 = truth.latest().time_ms
    north0 = truth.latest().pos_ned_m[0]
    # The step the vehicle has to fly: from where it is (its own estimate) to the new point.
    step_m = start[0] + STEP_M - client.local_position_ned()[0]
    client.goto_ned(start[0] + STEP_M, start[1], start[2]).check()
    while truth.latest().time_ms - t0 < seconds * 1000:
        client.pump(0.05)
    s = [x for x in truth.since(t0) if x.time_ms <= t0 + seconds * 1000]
    t = np.array([x.time_ms - t0 for x in s]) / 1000.0
    north = np.array([x.pos_ned_m[0] for x in s]) - north0
    frac = north / step_m
    t10 = t[np.argmax(frac >= 0.1)]
    t90 = t[np.argmax(frac >= 0.9)]
    # Settled: the 1 s moving average stays within 0.1 m (hover itself wanders by about that much).
    k = max(1, int(round(1.0 / np.median(np.diff(t))))) if len(t) > 1 else 1
    smooth = np.convolve(north, np.ones(k) / k, mode="same")
    outside = np.abs(smooth - step_m) > 0.1
    outside[-k // 2 :] = outside[-k // 2 - 1]  # the edge of the window has no full average
    settle = (
        t[np.nonzero(outside)[0][-1] + 1]
        if outside.any() and outside.nonzero()[0][-1] + 1 < len(t)
        else (float("nan") if outside[-1] else t[0])
    )
    return {
        "rise_s": t90 - t10,
        "overshoot_pct": max(0.0, (north.max() - step_m) / step_m * 100),
        "settle_s": settle,
        "final_err_m": abs(north[-1] - step_m),
    }


def fly(vehicle: str, instance: int, args, progress: Progress) -> dict:
    """One vehicle's flight (the module docstring's steps); its figures."""
    out: dict = {"vehicle": vehicle}
    extra = [a for p in args.sim_param for a in ("--param", p)]
    hover_s = args.hover
    progress.phase("starting the stack")
    with (
        Stack(instance=instance, speed="max", vehicle=vehicle, seed=args.seed, extra_sitl_args=extra) as stack,
        SimClient(ports.sim_component_port(instance)) as truth,
    ):
        client = VehicleClient(stack.api_url, timeout_s=60, idle=progress.idle(stack.check_alive))
        progress.watch(client)
        client.wait_until(client.prearm_ok, 120, "ready to arm")
        truth.wait_connected()
        progress.done(phase="take-off")
        for item in args.fc_param:
            name, value = item.split("=", 1)
            client.param_set(name, float(value))
        start = np.array(truth.latest().pos_ned_m)
        wall_flight0, sim_flight0 = time.monotonic(), client.sim_time_s()
        client.arm().check()
        client.takeoff(client.home().alt_amsl_m + ALT_M).check()
        client.wait_until(lambda: client.takeoff_done(ALT_M), 120, "take-off to 5 m")
        progress.done(phase="settle")
        client.wait_sim_time(5.0)
        progress.done(phase=f"calm hover {hover_s:g} s")
        target = start + np.array([0.0, 0.0, -ALT_M])
        # The estimator's home is where it armed; commands are relative to it, truth to the start point.
        home = client.latest("HOME_POSITION")
        step_start = np.array([home.x, home.y, home.z]) + np.array([0.0, 0.0, -ALT_M])
        err, _, ctrl = hover_errors(truth, client, target, hover_s, step_start)
        out["calm_h"], out["calm_v"] = rms(np.hypot(err[:, 0], err[:, 1])), rms(err[:, 2])
        out["calm_ctrl_h"] = rms(np.hypot(ctrl[:, 0], ctrl[:, 1]))
        progress.done(phase=f"{STEP_M:g} m step")
        out["step"] = step_response(truth, client, step_start)
        progress.done(phase="back")
        client.goto_ned(*step_start).check()
        client.wait_until(lambda: client.arrived(step_start[0], step_start[1], 0.3, 0.3), 120, "back")
        progress.done(phase="wind on, settle")
        for name, value in WIND.items():
            truth.set(name, value)
        client.wait_sim_time(10.0)
        progress.done(phase=f"windy hover {hover_s:g} s")
        err, rtf, ctrl = hover_errors(truth, client, target, hover_s, step_start)
        out["wind_h"], out["wind_v"] = rms(np.hypot(err[:, 0], err[:, 1])), rms(err[:, 2])
        out["wind_ctrl_h"] = rms(np.hypot(ctrl[:, 0], ctrl[:, 1]))
        out["wind_max_h"] = float(np.hypot(err[:, 0], err[:, 1]).max())
        out["rtf_wind"] = rtf
        progress.done(phase="landing")
        client.land().check()
        client.wait_until(client.landed_and_disarmed, 180, "landed and disarmed")
        progress.done(phase="landed")
        out["rtf_flight"] = (client.sim_time_s() - sim_flight0) / (time.monotonic() - wall_flight0)
        progress.watch(None)
        client.close()
    return out


def settle_text(settle_s: float) -> str:
    """A settling time for the table: seconds, or "never" (NaN: still outside the band at the end)."""
    return "never" if math.isnan(settle_s) else f"{settle_s:.2f}s"


def main(argv: list[str] | None = None) -> int:
    ap = parser(__doc__)
    ap.add_argument(
        "--vehicles", nargs="+", default=["quad_x", "firefly"], help="vehicle file names (params/vehicles/) or paths"
    )
    add_instance(ap, 21)  # the first vehicle's; the next ones 22, 23 ...
    ap.add_argument("--hover", type=float, default=30.0, help="each hover, simulated seconds")
    ap.add_argument("--seed", type=int, default=0, help="simulator seed (sensor noise, wind)")
    ap.add_argument(
        "--sim-param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a SIM_* setting for the whole run (e.g. SIM_GPS_DRIFT=0), repeatable",
    )
    ap.add_argument(
        "--fc-param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a flight-controller parameter set before take-off (e.g. MPC_XY_P=1.2), repeatable",
    )
    args = ap.parse_args(argv)
    if args.instance + len(args.vehicles) - 1 > ports.MAX_INSTANCE:
        ap.error(
            f"argument -i/--instance: {len(args.vehicles)} vehicles need instances N to N+{len(args.vehicles) - 1}"
        )
    with Progress(PHASES * len(args.vehicles), "phase") as progress:
        results = []
        for i, vehicle in enumerate(args.vehicles):
            progress.label(vehicle)
            results.append(fly(vehicle, args.instance + i, args, progress))
    if args.sim_param or args.fc_param:
        print("settings: " + " ".join(args.sim_param + args.fc_param))
    print(
        f"hover {args.hover:.0f} s at {ALT_M:.0f} m; wind {WIND['SIM_WIND_SPD']:.0f} m/s from 270 deg, "
        f"turbulence {WIND['SIM_WIND_TURB']:.0f} m/s RMS, gusts {WIND['SIM_GUST_SPD']:.0f} m/s every "
        f"~{WIND['SIM_GUST_INT']:.0f} s; errors = truth - setpoint, RMS"
    )
    print(
        f"{'vehicle':9} {'calm h':>7} {'calm v':>7} {'wind h':>7} {'wind v':>7} {'wind max':>8} "
        f"{'rise':>6} {'overshoot':>9} {'settle':>7} {'final':>6} {'RTF wind':>8} {'RTF all':>7}"
    )
    for r in results:
        s = r["step"]
        print(
            f"{r['vehicle']:9} {r['calm_h']:6.3f}m {r['calm_v']:6.3f}m {r['wind_h']:6.3f}m {r['wind_v']:6.3f}m "
            f"{r['wind_max_h']:7.3f}m {s['rise_s']:5.2f}s {s['overshoot_pct']:8.1f}% {settle_text(s['settle_s']):>7} "
            f"{s['final_err_m']:5.2f}m "
            f"{r['rtf_wind']:7.1f}x {r['rtf_flight']:6.1f}x"
        )
        print(
            f"{'':9} flight controller's own tracking (estimate - setpoint), horizontal RMS: "
            f"calm {r['calm_ctrl_h']:.3f} m, wind {r['wind_ctrl_h']:.3f} m"
        )
    print(
        "step: 10 m North via DO_REPOSITION; rise 10-90 %, settle = from the command until the 1 s moving "
        "average stays within 0.1 m of the target (never: not within the 25 s); final = error at 25 s"
    )
    return 0


if __name__ == "__main__":
    sys.exit(main())
