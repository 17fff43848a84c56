"""Benchmark: mission transfer speed and the cross-track error of a mission flown at cruise speed.

A thin script over the campaign runner (``campaign``, campaign/; kind ``mission``,
campaign/mission_kind.py, which has the flight and the measuring; its campaign file:
benchmarks/campaigns/mission.toml): the flags below build a campaign of one run, which it runs and
prints.  That run starts the simulator and the flight controller (``--speed max``, lockstep), then:

1. uploads and downloads missions of 100 and 500 waypoints over loopback UDP with the ground
   station's own protocol client (``gcs/mission_transfer.py``), wall time of each (goal: under
   0.5 s for 500 items);
2. uploads a 4-leg mission (take-off, a square of SIDE_M metres at MPC_XY_CRUISE, land), flies it
   and compares the ground truth (the simulator's own UDP port) with the legs: the horizontal
   distance from the true position to the nearest leg, RMS and maximum over the legs' straight
   parts and corners, and each corner's closest approach.

The flight controller answers a request within one 4 ms lockstep step, so at ``--speed 1`` an item
takes 4 ms.  A progress bar (stderr) counts the run.

Usage: ``python benchmarks/mission_benchmark.py [-i N] [--side M] [--vehicle NAME] [--speed S]
[--no-flight] [--seed N] [--out CSV]``
"""

from __future__ import annotations

import sys
import tempfile
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from campaign import runner, spec  # noqa: E402
from campaign.mission_kind import KIND, TRANSFER_FIGURES, TRANSFER_ITEMS  # noqa: E402

from _cli import add_instance, parser  # noqa: E402


def speed_value(text: str) -> str | float:
    """``--speed``: ``max`` or a real-time factor."""
    return text if text == "max" else float(text)


def campaign_dict(args) -> dict[str, Any]:
    """The campaign these flags make (benchmarks/campaigns/mission.toml's keys): one run."""
    record = ["success", *TRANSFER_FIGURES] if args.no_flight else list(KIND.figures)
    return {
        "name": "mission_benchmark",
        "kind": "mission",
        "runs": 1,
        "time_limit_s": 900,  # a safety net: the run takes ~10 s at --speed max, ~2 min at 1x
        "retries": 1,
        "record": record,
        "grid": {"vehicle": [args.vehicle], "side_m": [args.side], "wind": ["calm"], "speed": [args.speed]},
        "random": {"sim_seed": [args.seed, args.seed]},
    }


def print_figures(args, r: dict[str, Any]) -> None:
    if r["status"] != "ok":
        print(f"FAILED ({r['status']}): {r['reason']}")
        return
    for n in TRANSFER_ITEMS:
        up, down = r[f"upload_{n}_s"], r[f"download_{n}_s"]
        print(f"{n:4d} items: upload {up:.3f} s, download {down:.3f} s (speed {args.speed})")
    if args.no_flight:
        return
    print(
        f"4-leg mission, {args.side:g} m square at cruise speed ({args.vehicle}): "
        f"cross-track RMS {r['xtrack_rms_m']:.3f} m, max {r['xtrack_max_m']:.3f} m; "
        f"mean ground speed {r['mean_speed_m_s']:.2f} m/s over {r['legs_s']:.1f} s"
    )
    print("closest approach to each corner: " + ", ".join(f"{r[f'corner{k}_m']:.2f} m" for k in range(1, 5)))


def main(argv: list[str] | None = None) -> int:
    ap = parser(__doc__)
    add_instance(ap, 26)
    ap.add_argument("--side", type=float, default=30.0, help="side of the square mission, m")
    ap.add_argument("--vehicle", default="quad_x", help="vehicle file name (params/vehicles/) or path")
    ap.add_argument("--speed", type=speed_value, default="max", help="simulator speed: max or N x real time")
    ap.add_argument("--no-flight", action="store_true", help="only the transfer times")
    ap.add_argument("--seed", type=int, default=0, help="simulator seed (sensor noise)")
    ap.add_argument("--out", type=Path, help="keep the results CSV here (default: a temporary file)")
    args = ap.parse_args(argv)
    try:
        campaign = spec.from_dict(campaign_dict(args), "mission_benchmark")
    except spec.SpecError as exc:
        ap.error(str(exc))
    rows: list[dict[str, Any]] = []
    with tempfile.TemporaryDirectory(prefix="mission_benchmark-") as tmp:
        out = (args.out or Path(tmp) / "results.csv").resolve()
        out.unlink(missing_ok=True)  # one campaign per file
        options = runner.Options(out=out, jobs=1, on_row=rows.append)
        options.instances = (args.instance, args.instance)
        runner.run(campaign, options)
    print_figures(args, rows[0])
    return 0 if rows[0]["status"] == "ok" else 1


if __name__ == "__main__":
    sys.exit(main())
