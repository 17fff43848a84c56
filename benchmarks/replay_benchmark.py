"""Benchmark: what ``gcs replay`` costs per second of flight, with and without the onboard camera's inset.

Renders one flight's video from its logs (sitl/replay_video.py, as ``gcs replay LOG --video FILE.mp4`` does: the
world compiled from the flight's setup, each frame posed from the truth log, the chase view, the inset rendered
from the vehicle's camera, the status line, H.264 encoding with PyAV) ``--repeat`` times each way, and prints per
way the median wall seconds and CPU seconds (this process and its encoder threads) per simulated second of flight,
and per frame.  Rendering is MuJoCo offscreen (EGL) with the simulator camera's fast settings; wall time depends on
what else the machine runs, CPU time less so.

The flight: ``LOG`` (a log directory or a file of the flight, as ``gcs replay`` takes it), or else one
``flight-demo --scenario ugv-landing`` flown first on instance ``-i`` into a temp dir (about 12 simulated s, with
the camera's frame log).

Usage: ``python benchmarks/replay_benchmark.py [LOG] [--size 640x360] [--fps 25] [--repeat 3]``
"""

from __future__ import annotations

import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gcs.launcher import replay  # noqa: E402
from mavsim_core.cli_checks import positive_int  # noqa: E402
from sitl.replay_video import VideoOptions, read_flight, render_video  # noqa: E402

from _cli import add_instance, parser  # noqa: E402
from _progress import Progress  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]


def fly_demo(instance: int, log_dir: Path) -> None:
    """One ``flight-demo --scenario ugv-landing`` into ``log_dir`` (its output dropped unless it fails)."""
    cmd = [sys.executable, "-m", "gcs.launcher.demo", "-i", str(instance), "--scenario", "ugv-landing"]
    done = subprocess.run([*cmd, "--log-dir", str(log_dir)], cwd=ROOT, capture_output=True, text=True)
    if done.returncode != 0:
        sys.exit(f"the demo flight failed (exit {done.returncode}):\n{done.stdout[-2000:]}{done.stderr[-2000:]}")


def render_once(truth: Path, out: Path, size: tuple[int, int], fps: float, inset: bool) -> tuple[float, float, int]:
    """One render as ``gcs replay`` does it: (wall s, CPU s, frames)."""
    wall0, cpu0 = time.perf_counter(), time.process_time()
    logs = read_flight(truth)
    status, _ = replay.status_track(truth)
    result = render_video(logs, out, status, VideoOptions(size[0], size[1], fps, inset, progress=False))
    return time.perf_counter() - wall0, time.process_time() - cpu0, result.frames


def main(argv: list[str] | None = None) -> int:
    ap = parser(__doc__)
    add_instance(ap, 12)
    ap.add_argument("log", nargs="?", metavar="LOG", help="the flight to render (default: fly the ugv-landing demo)")
    ap.add_argument("--size", type=replay.video_size, default=replay.DEFAULT_SIZE, metavar="WxH", help="video size")
    ap.add_argument("--fps", type=float, default=replay.DEFAULT_FPS, help="frames per simulated second")
    ap.add_argument("--repeat", type=positive_int, default=3, help="renders of each way (the median is printed)")
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="replay-benchmark-") as tmp:
        ways = (("with the inset", True), ("without the inset", False))
        with Progress(len(ways) * args.repeat + (args.log is None), "step") as progress:
            if args.log is None:
                progress.phase("flying the ugv-landing demo")
                fly_demo(args.instance, Path(tmp) / "logs")
                progress.done()
            truth = replay.find_flight(Path(args.log) if args.log else Path(tmp) / "logs")
            span_s = read_flight(truth).truth["time_us"][[0, -1]] / 1e6
            sim_s = float(span_s[1] - span_s[0])
            figures = {}
            for name, inset in ways:
                runs = []
                for k in range(args.repeat):
                    progress.phase(f"render {name} ({k + 1}/{args.repeat})")
                    runs.append(render_once(truth, Path(tmp) / "video.mp4", args.size, args.fps, inset))
                    progress.done()
                figures[name] = runs
            progress.finish("done")
    w, h = args.size
    print(f"flight {truth.name}: {sim_s:.2f} simulated s; video {w}x{h} at {args.fps:g} fps")
    for name, runs in figures.items():
        wall, cpu, frames = statistics.median(r[0] for r in runs), statistics.median(r[1] for r in runs), runs[0][2]
        print(
            f"{name:<18} {wall / sim_s:.3f} wall s and {cpu / sim_s:.3f} CPU s per simulated s "
            f"({1e3 * wall / frames:.1f} ms wall, {1e3 * cpu / frames:.1f} ms CPU per frame; {frames} frames; "
            f"wall s of the {args.repeat} renders: {', '.join(f'{r[0]:.2f}' for r in runs)})"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
