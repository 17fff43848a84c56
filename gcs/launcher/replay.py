"""``gcs replay LOG --video FILE.mp4``: a video of a flight rendered from its logs, after the fact.

The simulator's logs of the flight (``<stem>.truth.npy``, ``<stem>.frames.npy``, ``<stem>.sim.json``) pose and
build its world; the renderer is the simulator's own (:mod:`sitl.replay_video`: MuJoCo, PyAV), which is why this
lives in the launcher, the one part of ``gcs`` that may import ``sitl``.  The flight controller's log of the same
flight (its ULog ``.ulg``, else the ``.tlog``; paired with the truth log as ``gcs plot`` pairs them,
:mod:`gcs.flight_logs`) gives the status line its flight mode and precision-landing phase.

LOG is a directory (its newest truth log: the latest flight), a file of the flight (any of ``.truth.npy``,
``.ulg``, ``.tlog``, ``.frames.npy``, ``.sim.json``: the truth log of the same stem) or the flight's
path without a suffix (``logs/2026-12-05_19-31-33_i61``).  ``flight-demo --video FILE.mp4`` flies through
:func:`demo_with_video`, which renders the flight once it is over.  Exit codes: 0 written, 1 no truth log or a
log that cannot be rendered (one line on stderr), 2 usage error (neither --video nor --preview).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from pathlib import Path
from typing import Callable

from mavsim_core.cli_args import EXIT_FAILED, EXIT_OK, EXIT_USAGE
from mavsim_core.cli_checks import number_in

from ..flight_logs import FC_SUFFIX, TLOG_SUFFIX, FlightData, FlightLogError, find_truth, load_tlog, load_ulog
from ..plot_landing import PHASES

TRUTH_SUFFIX = ".truth.npy"
FLIGHT_SUFFIXES = (TRUTH_SUFFIX, FC_SUFFIX, TLOG_SUFFIX, ".frames.npy", ".sim.json")
DEFAULT_SIZE, DEFAULT_FPS = (640, 360), 25.0


DESCRIPTION = (
    "Render a flight's video from its logs, after the fact: a chase view that follows the vehicle (and the ground "
    "vehicle's deck), the onboard camera's view in a corner when the flight had the camera, and a line with the "
    "simulated time, flight mode, altitude, landing phase and distance to the deck.  The video plays in real time "
    "(simulated seconds).  LOG: a log directory (its latest flight), any file of the flight, or its path without "
    "the suffix."
)


class NoFlight(Exception):
    """No truth log where the user pointed (the message is the one line to print)."""


def video_size(text: str) -> tuple[int, int]:
    """argparse ``type`` of ``--size``: ``WxH``, each even (H.264 in yuv420p), 32..3840 px."""
    try:
        w, h = (int(x) for x in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be WIDTHxHEIGHT in pixels (e.g. 640x360), not {text!r}") from None
    if not (32 <= w <= 3840 and 32 <= h <= 2160) or w % 2 or h % 2:
        raise argparse.ArgumentTypeError(f"width 32..3840 and height 32..2160, both even, not {text!r}")
    return w, h


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument(
        "log", metavar="LOG",
        help="a log directory (its latest flight), a file of the flight (.truth.npy, .ulg, .tlog ...) "
        "or the flight's path without its suffix",
    )  # fmt: skip
    p.add_argument("--video", metavar="FILE.mp4", help="the MP4 (H.264) to write")
    p.add_argument(
        "--size", type=video_size, default=DEFAULT_SIZE, metavar="WxH",
        help=f"the video's size in pixels (default {DEFAULT_SIZE[0]}x{DEFAULT_SIZE[1]})",
    )  # fmt: skip
    p.add_argument(
        "--fps", type=lambda t: number_in(t, 1.0, 120.0, "--fps"), default=DEFAULT_FPS,
        help=f"frames per simulated second (default {DEFAULT_FPS:g}): the video plays in real time",
    )  # fmt: skip
    p.add_argument("--no-inset", action="store_true", help="leave out the onboard camera's view")
    p.add_argument("--preview", metavar="FILE.webp", help="also an animated WebP of the flight (a README preview)")
    p.add_argument("--preview-width", type=video_size_width, default=480, metavar="PX", help="its width (480)")
    p.add_argument(
        "--preview-fps", type=lambda t: number_in(t, 1.0, 60.0, "--preview-fps"), default=12.5, metavar="FPS",
        help="its frame rate at most (default 12.5: every 2nd frame at 25 fps)",
    )  # fmt: skip
    p.add_argument(
        "--vehicle", metavar="NAME|FILE",
        help="the vehicle file flown, for a flight logged without its .sim.json (default: guessed from its motors)",
    )  # fmt: skip
    p.add_argument("--no-progress", action="store_true", help="no progress bar on stderr")


def video_size_width(text: str) -> int:
    """argparse ``type`` of ``--preview-width``: an even number of pixels 32..3840."""
    return video_size(f"{text}x32")[0]


def run(args: argparse.Namespace) -> int:
    """``gcs replay``: 0 written, 1 no flight there or it failed, 2 no output named (one line on stderr)."""
    if args.video is None and args.preview is None:
        print("gcs replay: nothing to write: give --video FILE.mp4 (and/or --preview FILE.webp)", file=sys.stderr)
        return EXIT_USAGE
    try:
        truth = find_flight(Path(args.log))
    except NoFlight as exc:
        print(f"gcs replay: {exc}", file=sys.stderr)
        return EXIT_FAILED
    return render(truth, args)


def find_flight(path: Path) -> Path:
    """The truth log of the flight ``path`` names (the module docstring); :class:`NoFlight` if there is none."""
    if path.is_dir():
        found = sorted(path.glob("*" + TRUTH_SUFFIX), key=lambda p: (p.stat().st_mtime, p.name))
        if not found:
            raise NoFlight(f"{path}: no *{TRUTH_SUFFIX} (the simulator's ground-truth log: sitl --log-dir) here")
        return found[-1]
    name = path.name
    stem = next((name[: -len(s)] for s in FLIGHT_SUFFIXES if name.endswith(s)), name)
    truth = path.with_name(stem + TRUTH_SUFFIX)
    if truth.exists():
        return truth
    if name.endswith((FC_SUFFIX, TLOG_SUFFIX)) and path.exists():  # a log of another stem: paired as gcs plot does
        try:
            data = load_ulog(path) if name.endswith(FC_SUFFIX) else load_tlog(path)
            series = [s for s in (data.estimate, data.setpoint) if s is not None and s.t_s.size]
            if series and (paired := find_truth(path, _span(series))) is not None:
                return paired
        except (FlightLogError, OSError, ValueError):
            pass
    raise NoFlight(f"{path}: no {truth.name} (the simulator's ground-truth log of this flight)")


def _span(series) -> tuple[float, float]:
    return min(float(s.t_s[0]) for s in series), max(float(s.t_s[-1]) for s in series)


def status_track(truth: Path):
    """The flight controller's mode and landing phase over the flight (:class:`sitl.replay_video.StatusTrack`),
    from its ``.ulg`` of the same flight, else its ``.tlog`` (modes only); empty when neither is found."""
    from sitl.replay_video import StatusTrack

    data = _fc_data(truth)
    if data is None:
        return StatusTrack(), "no flight controller log of this flight: no mode or landing phase shown"
    phases: list[tuple[float, str]] = []
    if data.landing is not None:
        codes = data.landing.cols["precland_phase"].astype(int)
        for t, code in zip(data.landing.t_s, codes):
            name = (PHASES[code] if 0 <= code < len(PHASES) else str(code)) if code else ""
            if not phases or phases[-1][1] != name:
                phases.append((float(t), name))
    return StatusTrack(tuple(data.modes), tuple(phases)), None


def _fc_data(truth: Path) -> FlightData | None:
    """The flight controller's log of the truth log's flight: the same stem's (.ulg, else .tlog), else one
    of the directory's whose truth log this is (paired by name time and span, as ``gcs plot`` pairs them)."""
    stem = truth.name[: -len(TRUTH_SUFFIX)]
    own = [truth.with_name(stem + sfx) for sfx in (FC_SUFFIX, TLOG_SUFFIX)]
    others = [p for sfx in (FC_SUFFIX, TLOG_SUFFIX) for p in sorted(truth.parent.glob("*" + sfx)) if p not in own]
    for path in [p for p in own if p.exists()] + others:
        try:
            data = load_ulog(path) if path.name.endswith(FC_SUFFIX) else load_tlog(path)
        except (FlightLogError, OSError, ValueError, KeyError):
            continue
        series = [s for s in (data.estimate, data.setpoint) if s is not None and s.t_s.size]
        if path in own or (series and find_truth(path, _span(series)) == truth):
            return data
    return None


def render(truth: Path, args: argparse.Namespace) -> int:
    """Render the flight of ``truth`` as ``args`` say; print what was written."""
    from sitl.replay_video import PreviewOptions, ReplayError, VideoOptions, read_flight, render_video

    video = Path(args.video) if args.video else None
    preview = None
    if args.preview:
        preview = PreviewOptions(Path(args.preview), args.preview_width, args.preview_fps)
    (width, height), progress = args.size, not args.no_progress
    options = VideoOptions(width, height, args.fps, not args.no_inset, progress, preview)
    try:
        for out in (video, preview.path if preview else None):
            if out is not None:
                out.parent.mkdir(parents=True, exist_ok=True)
        logs = read_flight(truth, args.vehicle)
        status, missing = status_track(truth)
        result = render_video(logs, video, status, options)
    except ReplayError as exc:
        print(f"gcs replay: {exc}", file=sys.stderr)
        return EXIT_FAILED
    except (OSError, ValueError) as exc:  # a file that cannot be written, an encoder PyAV does not have
        print(f"gcs replay: {truth.name}: {exc}", file=sys.stderr)
        return EXIT_FAILED
    for note in result.notes + ([missing] if missing else []):
        print(f"note: {note}")
    span = f"simulated {result.t0_s:.2f}-{result.t1_s:.2f} s"
    inset = "with the camera inset" if result.inset else "no camera inset"
    if video is not None:
        print(
            f"wrote {video}: {result.frames} frames at {result.fps:g} fps, {result.duration_s:.2f} s ({span}), "
            f"{width}x{height}, {inset}"
        )
    if preview is not None:
        size_kb = preview.path.stat().st_size / 1024
        print(f"wrote {preview.path}: {result.preview_frames} frames, {size_kb:.0f} KiB (animated WebP)")
    sim_s = result.duration_s
    print(f"rendered in {result.wall_s:.1f} s ({result.wall_s / sim_s:.2f} wall s per simulated s) from {truth.name}")
    return EXIT_OK


def demo_with_video(args: argparse.Namespace, fly: Callable[[argparse.Namespace], int]) -> int:
    """``flight-demo --video FILE.mp4``: ``fly(args)`` (the demo), then the video of its flight at the default size
    and rate.  The logs are kept where ``--log-dir`` says, else in a new temp dir.  The demo's exit code, or the
    video's when the demo succeeded; an interrupted demo (130) gets no video, but a ``--wait`` ended by Ctrl-C does
    (of the last flight flown meanwhile)."""
    if args.count > 1:
        print("flight-demo: --video renders one vehicle's flight: not with --count", file=sys.stderr)
        return EXIT_USAGE
    args.log_dir = args.log_dir or tempfile.mkdtemp(prefix=f"flight-demo-{args.instance}-")
    code = fly(args)
    if code == 130 and not args.wait:
        return code
    options = argparse.Namespace(
        video=args.video, size=DEFAULT_SIZE, fps=DEFAULT_FPS, no_inset=False, preview=None, preview_width=480,
        preview_fps=12.5, vehicle=None, no_progress=not sys.stderr.isatty(),
    )  # fmt: skip
    try:
        truth = find_flight(Path(args.log_dir))
    except NoFlight as exc:
        print(f"flight-demo --video: {exc}", file=sys.stderr)
        return code or EXIT_FAILED
    video = render(truth, options)
    return code or video
