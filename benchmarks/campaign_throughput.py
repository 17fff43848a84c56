"""Benchmark: campaign throughput (landings per wall-clock minute) against the number of workers.

Runs the same small landing campaign (``--runs`` static-pad landings of quad_x in calm air, the cheapest
landing there is: take-off to the preparation height, the camera finds the pad, precision landing) once
per worker count (``--workers``, default 1 and 2) on the local process pool of ``campaign run``
(campaign/), each into its own results file under ``--out``, and prints per worker count the wall time,
the landings per wall minute, the speed-up over one worker and the parallel efficiency.  Then the estimate
for a cluster: ``--nodes`` nodes of ``--cores-per-node`` cores, each running as many landings at a time as
it has cores (Ray: one task per core), at the per-worker rate measured here scaled by the efficiency measured
here, plus Ray's own cost per task (``--task-overhead-s``, a figure to replace with a measurement on the
cluster itself).  Every run is scored as in ``campaign report``; a run that is not "ok" is counted and
shown.

Progress shows as the campaign's own bar on stderr.
"""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from campaign import runner, spec  # noqa: E402

from _cli import parser  # noqa: E402

CAMPAIGN = """
name = "throughput"
kind = "landing"
runs = {runs}
base_seed = 11
time_limit_s = 300
[grid]
vehicle = ["quad_x"]
wind = ["calm"]
ugv_speed_m_s = [0]
"""


@dataclass(frozen=True)
class Measured:
    workers: int
    wall_s: float
    landings: int
    ok: int

    @property
    def per_minute(self) -> float:
        return self.landings / self.wall_s * 60.0


def measure(workers: int, runs: int, out: Path) -> Measured:
    """One campaign of ``runs`` landings on ``workers`` local workers; its wall time and statuses."""
    path = out / f"throughput_{workers}.toml"
    path.write_text(CAMPAIGN.format(runs=runs))
    csv = out / f"throughput_{workers}.csv"
    csv.unlink(missing_ok=True)
    start = time.monotonic()
    outcome = runner.run(spec.load(path), runner.Options(out=csv, jobs=workers))
    wall_s = time.monotonic() - start
    return Measured(workers, wall_s, outcome.total, outcome.statuses["ok"])


def cluster_estimate(measured: list[Measured], nodes: int, cores: int, task_overhead_s: float) -> str:
    """Landings per minute of ``nodes`` x ``cores`` from the best per-core rate and efficiency measured here."""
    one = measured[0]
    best = max(measured, key=lambda m: m.per_minute)
    efficiency = best.per_minute / (one.per_minute * best.workers)
    seconds_per_landing = one.wall_s / one.landings + task_overhead_s
    per_minute = nodes * cores * efficiency * 60.0 / seconds_per_landing
    return (
        f"estimate for {nodes} nodes x {cores} cores: {per_minute:,.0f} landings/min "
        f"({seconds_per_landing:.1f} s per landing per core incl. {task_overhead_s:.1f} s Ray overhead, "
        f"efficiency {efficiency:.2f} as measured with {best.workers} workers here); "
        f"1,000 landings in {1000 / per_minute * 60:.0f} s"
    )


def main(argv: list[str] | None = None) -> int:
    ap = parser(__doc__)
    ap.add_argument("--runs", type=int, default=8, help="landings per worker count")
    ap.add_argument("--workers", type=int, nargs="+", default=[1, 2], help="worker counts to measure")
    ap.add_argument("--out", type=Path, default=Path("campaign_throughput"), help="campaign and results files here")
    ap.add_argument("--nodes", type=int, default=100, help="cluster size for the estimate")
    ap.add_argument("--cores-per-node", type=int, default=2, help="cores of each cluster node (this machine: 2)")
    ap.add_argument("--task-overhead-s", type=float, default=0.5, help="Ray's cost per task, s (an assumption)")
    args = ap.parse_args(argv)
    args.out.mkdir(parents=True, exist_ok=True)
    measured = [measure(w, args.runs, args.out) for w in args.workers]
    one = measured[0]
    print(f"{'workers':>7} {'landings':>8} {'ok':>4} {'wall s':>7} {'per min':>8} {'speed-up':>8} {'efficiency':>10}")
    for m in measured:
        speed_up = m.per_minute / one.per_minute
        print(
            f"{m.workers:>7} {m.landings:>8} {m.ok:>4} {m.wall_s:>7.1f} {m.per_minute:>8.2f} "
            f"{speed_up:>8.2f} {speed_up / m.workers * one.workers:>10.2f}"
        )
    print(cluster_estimate(measured, args.nodes, args.cores_per_node, args.task_overhead_s))
    return 0


if __name__ == "__main__":
    sys.exit(main())
