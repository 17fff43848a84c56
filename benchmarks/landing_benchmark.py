"""Benchmark: randomised precision landings on the UGV, scored from the simulator's truth.

Grid (each a flag): UGV speed {0, 0.5, 1, 2, 3} m/s x path {line, circle, figure8, random} x
wind {calm, windy: 5 m/s from the West, 1 m/s turbulence, 2 m/s gusts} x vehicle {quad_x,
firefly}; ``--runs`` landings per cell, randomised by seed: the UGV's start offset and heading,
the meeting point's offset (up to 0.5 m from the UGV's path) and the simulator's sensor and wind
seeds.  Speed 0 is the static pad (the path does not matter: one cell per wind and vehicle).

Each landing is its own simulator + flight-controller pair on its own instance number
(``--base-instance`` + k, k < ``--jobs``), run ``--jobs`` at a time (default: the number of
cores).  A progress bar (stderr) counts the landings done and the failures, with the time left;
every landing prints its line (its cell, error or reason, real-time factor); the results go to a
CSV (one row per landing, appended as each ends) and a PNG summary, and a table per cell is
printed at the end: success rate, touchdown error mean / p95 / max, time to land, real-time
factor (simulated / wall seconds of the whole flight, camera and detection on).

Targets (issue 13): static pad error <= 5 cm in 10 of 10 runs, calm and windy; 1 m/s line
<= 10 cm in 10 of 10; 1 m/s circle >= 90 % success with error <= 15 cm; 3 m/s line >= 90 %
success with error <= 15 cm; real-time factor >= 5x.

The whole default grid is 68 cells, 680 landings (hours); choose a few cells with the flags.

Usage: ``python benchmarks/landing_benchmark.py [--runs 10] [--speeds 0 1 3] [--paths line circle]
[--winds calm windy] [--vehicles quad_x firefly] [--jobs N] [--out DIR] [--keep-logs] [--fc-param NAME=VALUE]``
"""

from __future__ import annotations

import argparse
import csv
import math
import os
import queue
import re
import sys
import threading
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gcs.client import VehicleClient  # noqa: E402
from gcs.launcher import Stack  # noqa: E402
from gcs.launcher.landing_run import LandingResult, LandingSetup, fly_landing  # noqa: E402
from gcs.sim_client import SimClient  # noqa: E402
from mavsim_core import ports  # noqa: E402
from sitl.ugv_paths import Pose2  # noqa: E402

from _cli import instance_number, parser  # noqa: E402
from _progress import Progress  # noqa: E402

BASE_INSTANCE = 11  # 11-19 (one per job): apart from people's 0-9, 10, the other benchmarks' 20-27 and the tests' 30-99


@dataclass(frozen=True)
class Cell:
    vehicle: str
    speed_m_s: float
    path: str
    wind: str

    def label(self) -> str:
        where = "static pad" if self.speed_m_s == 0 else f"{self.path} {self.speed_m_s:g} m/s"
        return f"{self.vehicle} {where} {self.wind}"


def randomised_setup(cell: Cell, run: int) -> LandingSetup:
    """The cell's landing number ``run``: its own seed, start pose and meeting offset."""
    seed = 1000 * run + 17
    rng = np.random.default_rng(seed)
    heading = float(rng.uniform(-math.pi, math.pi))
    start = Pose2(4.0 + float(rng.uniform(-0.5, 0.5)), float(rng.uniform(-0.5, 0.5)), heading)
    r = float(rng.uniform(0.0, 0.5))
    a = float(rng.uniform(-math.pi, math.pi))
    return LandingSetup(
        vehicle=cell.vehicle,
        path="static" if cell.speed_m_s == 0 else cell.path,
        speed_m_s=cell.speed_m_s,
        windy=cell.wind == "windy",
        seed=seed,
        ugv_start=start,
        meet_offset_m=(r * math.cos(a), r * math.sin(a)),
    )


CAMERA_LINE = re.compile(
    r"camera: (\d+) frames, (\d+) with the marker .*farthest ([\d.]+) m\).*error against the truth "
    r"([\d.]+) cm mean, ([\d.]+) cm max"
)


def camera_figures(sitl_log: str) -> dict[str, float]:
    """The simulator's camera line (sitl/companion.py): detections per second of flight, the farthest
    detection, and the detections' position error against the truth."""
    m = CAMERA_LINE.search(sitl_log)
    if m is None:
        return {"detections_per_s": math.nan, "farthest_m": math.nan, "pose_err_mean_cm": math.nan}
    frames, found = int(m.group(1)), int(m.group(2))
    return {
        "detections_per_s": found / (frames / 20.0) if frames else math.nan,  # 20 Hz camera
        "farthest_m": float(m.group(3)),
        "pose_err_mean_cm": float(m.group(4)),
        "pose_err_max_cm": float(m.group(5)),
    }


def run_one(
    setup: LandingSetup, instance: int, log_dir: Path | None, fc_params: Path | None
) -> tuple[LandingResult, dict]:
    """One landing on its own stack; an infrastructure failure is a failed landing with its reason."""
    stack = Stack(
        instance=instance,
        speed="max",
        vehicle=setup.vehicle,
        seed=setup.seed,
        extra_sitl_args=setup.sim_args(),
        extra_autopilot_args=["--params", str(fc_params)] if fc_params else [],
        log_dir=log_dir,
        flight_logs=log_dir is not None,
    )
    try:
        with stack, SimClient(ports.sim_component_port(instance)) as truth:
            with VehicleClient(stack.api_url, timeout_s=120, idle=stack.check_alive) as client:
                result = fly_landing(client, truth, setup, timeout_s=240)
    except Exception as exc:  # noqa: BLE001 - recorded as the run's failure, the campaign goes on
        result = LandingResult(reason=f"{type(exc).__name__}: {exc}"[:200])
    try:
        camera = camera_figures(stack.log_path("sitl").read_text())
    except Exception:  # noqa: BLE001 - no log (the stack did not start)
        camera = camera_figures("")
    return result, camera


def cells_from(args: argparse.Namespace) -> list[Cell]:
    out: list[Cell] = []
    for vehicle in args.vehicles:
        for wind in args.winds:
            for speed in args.speeds:
                for path in ["static"] if speed == 0 else args.paths:
                    out.append(Cell(vehicle, speed, path, wind))
    return out


def summarise(rows: list[dict]) -> str:
    lines = [
        f"{'cell':<34} {'runs':>4} {'success':>8} {'err mean':>9} {'err p95':>8} {'err max':>8} "
        f"{'t land':>7} {'RTF':>5} {'det/s':>6} {'range':>6} {'pose err':>8}"
    ]
    for label in dict.fromkeys(r["cell"] for r in rows):
        rs = [r for r in rows if r["cell"] == label]
        ok = [r for r in rs if r["success"]]
        err = np.array([r["touchdown_error_m"] for r in rs if math.isfinite(r["touchdown_error_m"])])
        t_land = float(np.mean([r["time_to_land_s"] for r in ok])) if ok else math.nan
        rtf = np.array([r["real_time_factor"] for r in rs if math.isfinite(r["real_time_factor"])])
        e = (err.mean(), np.percentile(err, 95), err.max()) if len(err) else (math.nan,) * 3
        lines.append(
            f"{label:<34} {len(rs):>4} {len(ok):>3}/{len(rs):<4} {e[0]:>8.3f}m {e[1]:>7.3f}m {e[2]:>7.3f}m "
            f"{t_land:>6.1f}s {np.mean(rtf) if len(rtf) else math.nan:>5.1f} "
            f"{_mean(rs, 'detections_per_s'):>6.1f} {_max(rs, 'farthest_m'):>5.2f}m "
            f"{_mean(rs, 'pose_err_mean_cm'):>6.1f}cm"
        )
    return "\n".join(lines)


def _mean(rows: list[dict], key: str) -> float:
    v = [r[key] for r in rows if math.isfinite(r[key])]
    return float(np.mean(v)) if v else math.nan


def _max(rows: list[dict], key: str) -> float:
    v = [r[key] for r in rows if math.isfinite(r[key])]
    return float(np.max(v)) if v else math.nan


def plot(rows: list[dict], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    labels = list(dict.fromkeys(r["cell"] for r in rows))
    fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(13, 0.45 * len(labels) + 2))
    for i, label in enumerate(labels):
        rs = [r for r in rows if r["cell"] == label]
        err = [r["touchdown_error_m"] * 100 for r in rs if math.isfinite(r["touchdown_error_m"])]
        ax1.scatter(err, [i] * len(err), s=14, color=["C2" if r["success"] else "C3" for r in rs][: len(err)])
        ax2.barh(i, 100 * sum(r["success"] for r in rs) / len(rs), color="C0")
    for ax in (ax1, ax2):
        ax.set_yticks(range(len(labels)), labels, fontsize=8)
        ax.invert_yaxis()
        ax.grid(alpha=0.3)
    ax1.set_xlabel("touchdown error (cm; green: landed and stayed on the deck)")
    ax2.set_xlabel("success (%)")
    ax2.set_xlim(0, 100)
    fig.suptitle("Precision landing on the UGV (benchmarks/landing_benchmark.py)")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    ap = parser(__doc__)
    ap.add_argument("--runs", type=int, default=10, help="landings per cell")
    ap.add_argument(
        "--speeds", type=float, nargs="+", default=[0, 0.5, 1, 2, 3], help="UGV speeds, m/s (0: static pad)"
    )
    ap.add_argument(
        "--paths", nargs="+", default=["line", "circle", "figure8", "random"], help="UGV paths (for speeds above 0)"
    )
    ap.add_argument("--winds", nargs="+", default=["calm", "windy"], choices=["calm", "windy"], help="wind cases")
    ap.add_argument("--vehicles", nargs="+", default=["quad_x", "firefly"], help="vehicle file names")
    ap.add_argument("--jobs", type=int, default=os.cpu_count() or 1, help="landings at a time (the number of cores)")
    ap.add_argument(
        "--base-instance", type=instance_number, default=BASE_INSTANCE, help="instance of job 0; job k uses base + k"
    )
    ap.add_argument("--out", type=Path, default=Path("landing_benchmark"), help="CSV, PNG and logs go here")
    ap.add_argument("--keep-logs", action="store_true", help="keep each landing's flight logs under --out")
    ap.add_argument(
        "--fc-param",
        action="append",
        default=[],
        metavar="NAME=VALUE",
        help="a flight-controller parameter for every landing (e.g. PLD_PREDICTOR=1: the polynomial predictor)",
    )
    args = ap.parse_args(argv)
    if not 1 <= args.jobs <= 9:
        ap.error("argument --jobs: 1 to 9 (instances base..base+8, clear of the other benchmarks)")
    if args.base_instance + args.jobs - 1 > ports.MAX_INSTANCE:
        ap.error(f"argument --base-instance: {args.jobs} jobs need instances up to {ports.MAX_INSTANCE}")
    args.out.mkdir(parents=True, exist_ok=True)
    work = [(cell, k) for cell in cells_from(args) for k in range(args.runs)]
    csv_path = args.out / "landings.csv"
    csv_path.unlink(missing_ok=True)  # one campaign per file
    fc_params = None
    if args.fc_param:  # MAVProxy's "NAME VALUE" format, read by autopilot --params
        fc_params = args.out / "fc.params"
        fc_params.write_text("".join(f"{a.split('=', 1)[0]} {a.split('=', 1)[1]}\n" for a in args.fc_param))
    print(f"{len(work)} landings, {args.jobs} at a time; results in {csv_path}", flush=True)
    with Progress(len(work), "landing", "landings") as progress:
        progress.note("failures 0")
        rows = run_campaign(work, args, csv_path, fc_params, progress)
    print("\n" + summarise(rows))
    plot(rows, args.out / "landings.png")
    print(f"\nCSV: {csv_path}\nPNG: {args.out / 'landings.png'}")
    return 0


def run_campaign(work: list, args: argparse.Namespace, csv_path: Path, fc_params: Path | None, progress: Progress):
    """Fly every (cell, run) of ``work``, ``args.jobs`` at a time; the CSV rows, in the order they ended."""
    todo: queue.Queue = queue.Queue()
    for item in work:
        todo.put(item)
    rows: list[dict] = []
    lock = threading.Lock()

    def worker(slot: int) -> None:
        while True:
            try:
                cell, k = todo.get_nowait()
            except queue.Empty:
                return
            setup = randomised_setup(cell, k)
            logs = args.out / "logs" / f"{cell.label().replace(' ', '_')}_{k}" if args.keep_logs else None
            res, camera = run_one(setup, args.base_instance + slot, logs, fc_params)
            row = {"cell": cell.label(), "run": k, **asdict(res), "real_time_factor": res.real_time_factor, **camera}
            row["phases"] = " | ".join(res.phases)
            with lock:
                rows.append(row)
                _append_csv(csv_path, row)
                fails = sum(not r["success"] for r in rows)
                progress.say(
                    f"[{len(rows)}/{len(work)}] {cell.label()} #{k}: "
                    + (f"landed, error {res.touchdown_error_m * 100:.1f} cm" if res.success else f"FAILED {res.reason}")
                    + f", RTF {res.real_time_factor:.1f}"
                )
                progress.note(f"failures {fails}")
                progress.done()

    threads = [threading.Thread(target=worker, args=(j,)) for j in range(args.jobs)]
    for th in threads:
        th.start()
    for th in threads:
        th.join()
    return rows


def _append_csv(path: Path, row: dict) -> None:
    new = not path.exists()
    with path.open("a", newline="") as f:
        w = csv.DictWriter(f, fieldnames=list(row))
        if new:
            w.writeheader()
        w.writerow(row)


if __name__ == "__main__":
    sys.exit(main())
