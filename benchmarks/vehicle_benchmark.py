"""Benchmark: both vehicles, hover in calm and in wind, 10 m step response, real-time factor.

A thin script over the campaign runner (``campaign``, campaign/; kind ``hover_step``,
campaign/hover_step.py, which has the flight and the measuring; its campaign file:
benchmarks/campaigns/hover_step.toml): the flags below build a campaign of one run per vehicle,
which it runs and prints as a table.

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

Each flight goes through the simulator's holds (the kind's module docstring): the same ``--seed``
gives the same figures to the last digit whatever the machine's load, the real-time factors aside
(wall-clock, the holds' round trips included); ``--sim-param SIM_HOLD_MS=0`` flies with the simulator
running free instead.

The vehicles fly one after another (``--jobs 1``, so the real-time factors are those of one stack
alone on the machine); a progress bar (stderr) counts the flights.

Usage: ``python benchmarks/vehicle_benchmark.py [--vehicles quad_x firefly] [--hover S] [--seed N] [-i N] [--gps rtk]
[--sim-param NAME=VALUE] [--fc-param NAME=VALUE] [--jobs N] [--out CSV] [--keep-logs DIR]``
"""

from __future__ import annotations

import math
import sys
import tempfile
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from campaign import runner, spec  # noqa: E402
from campaign.hover_step import ALT_M, STEP_M, STEP_WINDOW_S, WIND_REF_M_S, windy_parameters  # noqa: E402
from mavsim_core import ports  # noqa: E402
from params.param_file import read_param_file  # noqa: E402
from sitl.scenario import SCENARIO_DIR, load_scenario  # noqa: E402

from _cli import add_instance, parser  # noqa: E402


def params(items: list[str], flag: str, ap) -> dict[str, float]:
    """``NAME=VALUE`` flags as a campaign file's parameter table; a usage error if one is not."""
    out = {}
    for item in items:
        name, _, value = item.partition("=")
        try:
            out[name] = float(value)
        except ValueError:
            ap.error(f"argument {flag}: {item!r} is not NAME=VALUE")
    return out


def gps_params(gps: str) -> tuple[dict[str, float], dict[str, float]]:
    """(SIM_* parameters, flight-controller parameters) of a ``--gps`` choice: none for the default receiver;
    for ``rtk``, params/scenarios/rtk_gps.toml and params/rtk_gps.params."""
    if gps != "rtk":
        return {}, {}
    fc = read_param_file(SCENARIO_DIR.parent / "rtk_gps.params")
    return dict(load_scenario("rtk_gps").parameters), {e.name: float(e.value) for e in fc.entries}


def campaign_dict(args, ap, gps: tuple[dict[str, float], dict[str, float]]) -> dict[str, Any]:
    """The campaign these flags make (benchmarks/campaigns/hover_step.toml's keys): one run per vehicle;
    ``gps``: :func:`gps_params` of ``--gps``."""
    sim, fc = gps
    return {
        "name": "vehicle_benchmark",
        "kind": "hover_step",
        "runs": 1,
        "time_limit_s": 600 + 20 * args.hover,  # a safety net: a flight takes 5-15 s plus 2 hovers at --speed max
        "retries": 1,
        "grid": {"vehicle": args.vehicles, "wind_m_s": [WIND_REF_M_S], "fault": ["none"], "hover_s": [args.hover]},
        "random": {"sim_seed": [args.seed, args.seed]},
        "sim_params": sim | params(args.sim_param, "--sim-param", ap),
        "fc_params": fc | params(args.fc_param, "--fc-param", ap),
    }


def settle_text(settle_s: float) -> str:
    """A settling time for the table: seconds, or "never" (NaN: still outside the band at the end)."""
    return "never" if math.isnan(settle_s) else f"{settle_s:.2f}s"


def print_table(args, rows: list[dict[str, Any]], gps: tuple[dict[str, float], dict[str, float]]) -> None:
    wind = windy_parameters()
    if args.gps == "rtk":
        print("GPS: RTK fixed (" + " ".join(f"{k}={v:g}" for k, v in (gps[0] | gps[1]).items()) + ")")
    if args.sim_param or args.fc_param:
        print("settings: " + " ".join(args.sim_param + args.fc_param))
    print(
        f"hover {args.hover:.0f} s at {ALT_M:.0f} m; wind {wind['SIM_WIND_SPD']:.0f} m/s from 270 deg, "
        f"turbulence {wind['SIM_WIND_TURB']:.0f} m/s RMS, gusts {wind['SIM_GUST_SPD']:.0f} m/s every "
        f"~{wind['SIM_GUST_INT']:.0f} s; errors = truth - setpoint, RMS"
    )
    print(
        f"{'vehicle':9} {'calm h':>7} {'calm v':>7} {'wind h':>7} {'wind v':>7} {'wind max':>8} "
        f"{'rise':>6} {'overshoot':>9} {'settle':>7} {'final':>6} {'RTF wind':>8} {'RTF all':>7}"
    )
    for r in rows:
        if r["status"] != "ok":
            print(f"{r['vehicle']:9} FAILED ({r['status']}): {r['reason']}")
            continue
        print(
            f"{r['vehicle']:9} {r['calm_h_rms_m']:6.3f}m {r['calm_v_rms_m']:6.3f}m {r['wind_h_rms_m']:6.3f}m "
            f"{r['wind_v_rms_m']:6.3f}m {r['wind_h_max_m']:7.3f}m {r['step_rise_s']:5.2f}s "
            f"{r['step_overshoot_pct']:8.1f}% {settle_text(r['step_settle_s']):>7} {r['step_final_err_m']:5.2f}m "
            f"{r['rtf_wind']:7.1f}x {r['real_time_factor']:6.1f}x"
        )
        print(
            f"{'':9} flight controller's own tracking (estimate - setpoint), horizontal RMS: "
            f"calm {r['calm_ctrl_h_rms_m']:.3f} m, wind {r['wind_ctrl_h_rms_m']:.3f} m; "
            f"step settle {settle_text(r['step_ctrl_settle_s'])}, overshoot {r['step_ctrl_overshoot_pct']:.1f} %"
        )
    print(
        f"step: {STEP_M:g} m North via DO_REPOSITION; rise 10-90 %, settle = from the command until the 1 s moving "
        f"average stays within 0.1 m of the target (never: not within the {STEP_WINDOW_S:g} s); "
        f"final = error at {STEP_WINDOW_S:g} s; own step: the same of the estimate against the point sent"
    )


def main(argv: list[str] | None = None) -> int:
    ap = parser(__doc__)
    ap.add_argument(
        "--vehicles", nargs="+", default=["quad_x", "firefly"], help="vehicle file names (params/vehicles/) or paths"
    )
    add_instance(ap, 21)  # the runs lease N .. N + jobs - 1
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
        help="a flight-controller parameter from the start (e.g. MPC_XY_P=1.2), repeatable",
    )
    ap.add_argument(
        "--gps",
        choices=("single", "rtk"),
        default="single",
        help="the simulated receiver: single (default: a single-point fix, 0.1 m noise, 0.05 m wander) or rtk "
        "(sitl --scenario rtk_gps with params/rtk_gps.params: 2 cm noise, 1 cm wander)",
    )
    ap.add_argument("--jobs", type=int, default=1, help="vehicles flown at a time (more: lower real-time factors)")
    ap.add_argument("--out", type=Path, help="keep the results CSV here (default: a temporary file)")
    ap.add_argument("--keep-logs", type=Path, metavar="DIR", help="keep each flight's logs (.ulg, .tlog ...) here")
    args = ap.parse_args(argv)
    if args.jobs < 1 or args.instance + args.jobs - 1 > ports.MAX_INSTANCE:
        ap.error(f"argument --jobs: 1 to {ports.MAX_INSTANCE - args.instance + 1} with -i {args.instance}")
    gps = gps_params(args.gps)
    try:
        campaign = spec.from_dict(campaign_dict(args, ap, gps), "vehicle_benchmark")
    except spec.SpecError as exc:
        ap.error(str(exc))
    rows: dict[int, dict[str, Any]] = {}
    with tempfile.TemporaryDirectory(prefix="vehicle_benchmark-") as tmp:
        out = (args.out or Path(tmp) / "results.csv").resolve()
        out.unlink(missing_ok=True)  # one campaign per file
        options = runner.Options(out=out, jobs=args.jobs, on_row=lambda r: rows.__setitem__(r["cell"], r))
        options.instances = (args.instance, args.instance + args.jobs - 1)
        if args.keep_logs:
            options.log_dir = args.keep_logs.resolve()
        runner.run(campaign, options)
    print_table(args, [rows[c] for c in sorted(rows)], gps)
    return 0 if all(r["status"] == "ok" for r in rows.values()) else 1


if __name__ == "__main__":
    sys.exit(main())
