"""Benchmark: randomised precision landings on the UGV, scored from the simulator's truth.

A thin script over the campaign runner (``campaign``, campaign/; its campaign file:
benchmarks/campaigns/landing.toml): the flags below build the campaign, which it runs and reports.

Grid (each a flag): UGV speed {0, 0.5, 1, 2, 3} m/s x path {line, circle, figure8, random} x
wind {calm, windy: 5 m/s from the West, 1 m/s turbulence, 2 m/s gusts} x vehicle {quad_x,
firefly}; ``--runs`` landings per cell, randomised by seed: the UGV's start offset and heading,
the meeting point's offset (up to 0.5 m from the UGV's path) and the simulator's seed (sensor noise,
wind gusts).  Speed 0 is the static pad (the path does not matter: one cell per wind and vehicle).

Each landing is its own simulator + flight-controller pair on its own instance number (leased from
the shared pool 30-99, or ``--base-instance`` + k, k < ``--jobs``), ``--jobs`` at a time (default:
the number of cores), or on Ray (``--ray auto``).  A progress bar (stderr) counts the landings done
and the failures, with the time left; every landing prints its line (its cell, error or reason,
real-time factor); the results go to a CSV (one row per landing, appended as each ends; ``--resume``
goes on with it) and PNG plots, and a table per cell is printed at the end: success rate with its
95 % interval, touchdown error mean / p95 / max, time to land, real-time factor.

Targets (issue 13): static pad error <= 5 cm in 10 of 10 runs, calm and windy; 1 m/s line
<= 10 cm in 10 of 10; 1 m/s circle >= 90 % success with error <= 15 cm; 3 m/s line >= 90 %
success with error <= 15 cm; real-time factor >= 5x.

The whole default grid is 68 cells, 680 landings (hours); choose a few cells with the flags.

Usage: ``python benchmarks/landing_benchmark.py [--runs 10] [--speeds 0 1 3] [--paths line circle]
[--winds calm windy] [--vehicles quad_x firefly] [--jobs N] [--out DIR] [--keep-logs] [--fc-param NAME=VALUE]``
"""

from __future__ import annotations

import os
import sys
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from campaign import report, runner, spec  # noqa: E402
from campaign.landing import PATHS  # noqa: E402
from mavsim_core import ports  # noqa: E402

from _cli import instance_number, parser  # noqa: E402


def campaign_dict(args) -> dict[str, Any]:
    """The campaign file these flags make (benchmarks/campaigns/landing.toml's keys)."""
    data: dict[str, Any] = {
        "name": "landings",
        "kind": "landing",
        "runs": args.runs,
        "base_seed": args.seed,
        "grid": {"vehicle": args.vehicles, "wind": args.winds, "ugv_speed_m_s": args.speeds, "ugv_path": args.paths},
    }
    if args.fc_param:
        data["fc_params"] = {a.split("=", 1)[0]: float(a.split("=", 1)[1]) for a in args.fc_param}
    return data


def say_row(row: dict[str, Any]) -> None:
    from tqdm import tqdm

    what = (
        f"landed, error {row['touchdown_error_m'] * 100:.1f} cm" if row["status"] == "ok" else f"FAILED {row['reason']}"
    )
    tqdm.write(f"{row['label']} #{row['index']}: {what}, RTF {row['real_time_factor']:.1f}", file=sys.stdout)


def main(argv: list[str] | None = None) -> int:
    ap = parser(__doc__)
    ap.add_argument("--runs", type=int, default=10, help="landings per cell")
    ap.add_argument(
        "--speeds", type=float, nargs="+", default=[0, 0.5, 1, 2, 3], help="UGV speeds, m/s (0: static pad)"
    )
    ap.add_argument("--paths", nargs="+", default=list(PATHS), help="UGV paths (for speeds above 0)")
    ap.add_argument("--winds", nargs="+", default=["calm", "windy"], choices=["calm", "windy"], help="wind cases")
    ap.add_argument("--vehicles", nargs="+", default=["quad_x", "firefly"], help="vehicle file names")
    ap.add_argument("--seed", type=int, default=1, help="the campaign's base seed (every run's draws follow from it)")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="landings at a time (the number of cores)")
    ap.add_argument(
        "--ray", metavar="ADDRESS", help="run on Ray instead: 'auto' (local, joined or started) or an address"
    )
    ap.add_argument(
        "--base-instance", type=instance_number, help="instance of job 0, job k uses base + k (default: leased, 30-99)"
    )
    ap.add_argument("--out", type=Path, default=Path("landing_benchmark"), help="CSV, PNGs and logs go here")
    ap.add_argument("--resume", action="store_true", help="go on with the CSV in --out (same flags)")
    ap.add_argument("--keep-logs", action="store_true", help="keep each landing's flight logs under --out")
    ap.add_argument(
        "--fc-param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a flight-controller parameter for every landing (e.g. PLD_PREDICTOR=1: the polynomial predictor)",
    )
    args = ap.parse_args(argv)
    if args.jobs < 1:
        ap.error("argument --jobs: at least 1")
    if args.base_instance is not None and args.base_instance + args.jobs - 1 > ports.MAX_INSTANCE:
        ap.error(f"argument --base-instance: {args.jobs} jobs need instances up to {ports.MAX_INSTANCE}")
    try:
        campaign = spec.from_dict(campaign_dict(args), "landings")
    except (spec.SpecError, ValueError) as exc:
        ap.error(str(exc))
    csv_path = args.out.resolve() / "landings.csv"
    if not args.resume:
        csv_path.unlink(missing_ok=True)  # one campaign per file
    options = runner.Options(out=csv_path, resume=args.resume, jobs=args.jobs, ray=args.ray, on_row=say_row)
    if args.base_instance is not None:
        options.instances = (args.base_instance, args.base_instance + args.jobs - 1)
    if args.keep_logs:
        options.log_dir = args.out / "logs"
    print(f"{len(campaign.kind_().cells(campaign.grid)) * args.runs} landings; results in {csv_path}", flush=True)
    runner.run(campaign, options)
    table, plots = report.report(csv_path, args.out)
    print("\n" + table)
    print(f"\nCSV: {csv_path}\nPNG: " + " ".join(str(p) for p in plots))
    return 0


if __name__ == "__main__":
    sys.exit(main())
