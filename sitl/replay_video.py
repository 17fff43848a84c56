"""A flight's video rendered from its logs: the chase view, the onboard camera's inset and a status line.

What it reads (simulated time throughout, the truth log's clock):

- the simulator's truth log ``<stem>.truth.npy`` (:mod:`sitl.truth_log`; 250 Hz, NED m from the start point, roll,
  pitch, yaw rad; with the UGV its deck centre and yaw), which sets the video's span;
- the camera-frame log ``<stem>.frames.npy`` beside it, when the flight had the camera: the gimbal's joint angles
  (deg) at each frame's capture, interpolated to each video frame's time, and the markers the detector used;
- the world it was flown in, ``<stem>.sim.json`` (:mod:`sitl.flight_setup`), or a guess for older flights;
- what the flight controller logged, as a :class:`StatusTrack` the caller reads from its log (mode and precision
  landing phase over time; the simulator cannot know them).

Video frame k shows simulated time t0 + k / fps, t0 the truth log's first sample, the nearest truth sample posing
the world (4 ms apart); there are floor((t_last - t0) fps) + 1 frames, so the video lasts the truth log's span to
within one frame.  The chase view (:class:`sitl.replay_scene.ChaseCamera`) fills the picture; the onboard camera's
view (greyscale, as the detector saw it, without its pixel noise) sits in the bottom-right corner; the top line
says the simulated time, the flight mode, the altitude above the start (m), the landing phase and the horizontal
distance to the deck's centre (m).  Frames go to an MP4 (and, thinned and scaled, to an animated WebP preview).
"""

from __future__ import annotations

import bisect
import math
import sys
import time
from dataclasses import dataclass, field, replace
from fractions import Fraction
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from mavsim_core.npy_log import read_npy_log
from sitl.flight_setup import FlightSetup, guess_setup, read_setup
from sitl.replay_encode import FrameWriter, mp4_writer, webp_writer
from sitl.replay_scene import ChaseCamera, Pose, ReplayScene

TRUTH_SUFFIX, FRAMES_SUFFIX = ".truth.npy", ".frames.npy"
INSET_WIDTH_SHARE = 0.32  # the inset's width, a share of the video's
TEXT_RGB = (255, 255, 255)


class ReplayError(Exception):
    """The flight cannot be rendered (the message says why, naming the file)."""


@dataclass(frozen=True)
class StatusTrack:
    """What the flight controller logged, as steps: each (t_s, text) holds from t_s (simulated s) to the next."""

    modes: tuple[tuple[float, str], ...] = ()
    phases: tuple[tuple[float, str], ...] = ()  # the precision landing's phase ("" where there is none)

    def at(self, t_s: float) -> tuple[str, str]:
        """(mode, landing phase) at ``t_s``; "" for what is not known then."""
        return _step_at(self.modes, t_s), _step_at(self.phases, t_s)


def _step_at(steps: tuple[tuple[float, str], ...], t_s: float) -> str:
    k = bisect.bisect_right([t for t, _ in steps], t_s) - 1
    return steps[k][1] if k >= 0 else ""


@dataclass(frozen=True)
class PreviewOptions:
    """An animated WebP beside the video: ``width`` px wide (the height keeps the aspect), ``fps`` at most."""

    path: Path
    width: int = 480
    fps: float = 12.5


@dataclass(frozen=True)
class VideoOptions:
    """The video's size (px, even), frame rate (frames per simulated second) and parts."""

    width: int = 640
    height: int = 360
    fps: float = 25.0
    inset: bool = True
    progress: bool = True
    preview: PreviewOptions | None = None


@dataclass
class VideoResult:
    """What was written: frames, the simulated span they show (s), the wall time it took (s), notes for the user."""

    path: Path | None
    frames: int
    fps: float
    t0_s: float
    t1_s: float
    wall_s: float
    inset: bool
    preview_frames: int = 0
    notes: list[str] = field(default_factory=list)

    @property
    def duration_s(self) -> float:
        return self.frames / self.fps


@dataclass(frozen=True)
class FlightLogs:
    """The simulator's logs of one flight, read: truth columns, frame log columns (None: no camera), the world."""

    truth_path: Path
    truth: np.ndarray
    frames: np.ndarray | None
    setup: FlightSetup
    notes: tuple[str, ...] = ()


def read_flight(truth_path: Path, vehicle: str | None = None) -> FlightLogs:
    """The truth log, the frame log and the setup beside it; ``vehicle`` (a name or .toml) overrides the setup's."""
    try:
        truth = read_npy_log(truth_path)
    except (OSError, ValueError) as exc:
        raise ReplayError(f"{truth_path}: cannot read the truth log: {exc}") from None
    if truth.size < 2:
        raise ReplayError(f"{truth_path}: the truth log holds {truth.size} sample(s), no flight to show")
    frames_path = truth_path.with_name(truth_path.name[: -len(TRUTH_SUFFIX)] + FRAMES_SUFFIX)
    frames = read_npy_log(frames_path) if frames_path.exists() else None
    frames = frames if frames is not None and frames.size else None
    notes = []
    try:
        setup = read_setup(truth_path)
    except ValueError as exc:
        raise ReplayError(str(exc)) from None
    if setup is None:
        gimbal = frames is not None and bool(np.isfinite(frames["gimbal_pitch_deg"]).any())
        names = truth.dtype.names or ()
        columns = [] if frames is None else [frames[k] for k in frames.dtype.names or () if k.startswith("marker_")]
        ids = {int(i) for c in columns for i in c}
        n_motors = len([k for k in names if k.startswith("motor_")])
        try:
            setup, note = guess_setup(n_motors, "ugv_n_m" in names, gimbal, ids - {-1})
        except ValueError as exc:
            raise ReplayError(f"{truth_path}: {exc}") from None
        notes.append(note)
    if vehicle is not None:
        setup = replace(setup, vehicle_name=vehicle, vehicle_file=vehicle, vehicle_toml="")
        notes.append(f"vehicle from --vehicle: {vehicle}")
    return FlightLogs(truth_path, truth, frames, setup, tuple(notes))


def frame_count(t0_s: float, t1_s: float, fps: float) -> int:
    """Video frames for a log from ``t0_s`` to ``t1_s``: floor(span x fps) + 1 (the module docstring)."""
    return int(math.floor((t1_s - t0_s) * fps + 1e-9)) + 1


def render_video(logs: FlightLogs, video: Path | None, status: StatusTrack, options: VideoOptions) -> VideoResult:
    """Render the flight into ``video`` (MP4; None: only the preview) and ``options.preview``; the result."""
    tr, fr = logs.truth, logs.frames
    t_s = tr["time_us"] / 1e6
    fps = Fraction(options.fps).limit_denominator(1000)
    n = frame_count(float(t_s[0]), float(t_s[-1]), float(fps))
    try:
        spec = logs.setup.vehicle_spec()
    except ValueError as exc:
        raise ReplayError(f"{logs.truth_path}: the vehicle {logs.setup.vehicle_name!r}: {exc}") from None
    ugv = "ugv_n_m" in (tr.dtype.names or ())
    size = (options.width, options.height)
    inset = None
    if options.inset and fr is not None and spec.camera.rate_hz > 0:  # the camera's aspect, a share of the width
        w = 2 * round(options.width * INSET_WIDTH_SHARE / 2)
        inset = (w, 2 * round(w * spec.camera.height_px / spec.camera.width_px / 2))
    t1 = float(t_s[0] + (n - 1) / fps)
    result = VideoResult(video, n, float(fps), float(t_s[0]), t1, 0.0, inset is not None, notes=list(logs.notes))
    wall0 = time.perf_counter()
    scene = ReplayScene(spec, logs.setup.pad_layout() if ugv else None, size, inset)
    writers: list[tuple[FrameWriter, int, tuple[int, int] | None]] = []  # each: every k-th frame, resized to
    try:
        writers += _writers(video, options, fps)
        chase, gimbal = ChaseCamera(), _gimbal_track(fr)
        alt0_m = -float(tr["pos_d_m"][0])
        redraw_s = 0.5 if sys.stderr.isatty() else 10.0  # each redraw into a file is another line
        bar = tqdm(
            total=n, unit="frame", desc=logs.truth_path.name, file=sys.stderr, disable=not options.progress,
            mininterval=redraw_s,
        )  # fmt: skip
        with bar:
            for k in range(n):
                t = float(t_s[0] + k / fps)
                i = _nearest(t_s, t)
                pose = _pose(tr[i], ugv, gimbal(t) if gimbal else None)
                scene.place(pose)
                img = scene.render_chase(chase.view(t, pose))
                if (onboard := scene.render_onboard()) is not None:
                    _draw_inset(img, onboard, _markers_at(fr, t))
                mode, phase = status.at(t)
                mode = mode if tr["armed"][i] else "DISARMED"
                _draw_status(img, t, mode, -float(tr["pos_d_m"][i]) - alt0_m, phase, _deck_distance(pose))
                for writer, every, resize in writers:
                    if k % every == 0:
                        writer.write(img if resize is None else cv2.resize(img, resize, interpolation=cv2.INTER_AREA))
                bar.update()
        result.preview_frames = sum(w.frames for w, _, resize in writers if resize is not None)
    finally:
        for writer, _, _ in writers:
            writer.close()
        scene.close()
    result.wall_s = time.perf_counter() - wall0
    return result


def _writers(video: Path | None, options: VideoOptions, fps: Fraction) -> list:
    """The MP4 (every frame) and the preview (every k-th frame, scaled) as (writer, k, size or None)."""
    out: list = []
    try:
        if video is not None:
            out.append((mp4_writer(video, (options.width, options.height), fps), 1, None))
        if (p := options.preview) is not None:
            step = max(1, round(float(fps) / p.fps))
            width = 2 * round(p.width / 2)
            size = (width, 2 * round(width * options.height / options.width / 2))
            out.append((webp_writer(p.path, size, fps / step), step, size))
    except BaseException:
        for writer, _, _ in out:
            writer.close()
        raise
    return out


def _nearest(t_s: np.ndarray, t: float) -> int:
    """The index of the sample of ``t_s`` (sorted) nearest ``t``."""
    i = min(int(np.searchsorted(t_s, t)), len(t_s) - 1)
    return i - 1 if i > 0 and t - t_s[i - 1] < t_s[i] - t else i


def _pose(row, ugv: bool, gimbal_rpy_rad: tuple[float, float, float] | None) -> Pose:
    deck = (float(row["ugv_n_m"]), float(row["ugv_e_m"]), float(row["ugv_d_m"])) if ugv else None
    return Pose(
        (float(row["pos_n_m"]), float(row["pos_e_m"]), float(row["pos_d_m"])),
        (float(row["roll_rad"]), float(row["pitch_rad"]), float(row["yaw_rad"])),
        deck,
        float(row["ugv_yaw_rad"]) if ugv else 0.0,
        gimbal_rpy_rad,
    )


def _gimbal_track(frames: np.ndarray | None):
    """t_s -> the gimbal's (roll, pitch, yaw) rad, interpolated between the frames' captures; None: no gimbal."""
    if frames is None:
        return None
    t = frames["time_us"] / 1e6
    cols = [np.radians(frames[f"gimbal_{k}_deg"].astype(float)) for k in ("roll", "pitch", "yaw")]
    ok = np.isfinite(cols[0]) & np.isfinite(cols[1]) & np.isfinite(cols[2])
    if not ok.any():
        return None
    t, cols = t[ok], [c[ok] for c in cols]
    return lambda ts: tuple(float(np.interp(ts, t, c)) for c in cols)


def _markers_at(frames: np.ndarray | None, t_s: float) -> int | None:
    """How many markers the detector used in the last frame captured at or before ``t_s`` (None: none yet)."""
    if frames is None:
        return None
    k = int(np.searchsorted(frames["time_us"], round(t_s * 1e6), side="right")) - 1
    return int(frames["n_markers"][k]) if k >= 0 else None


def _deck_distance(pose: Pose) -> float | None:
    if pose.deck_ned_m is None or not np.all(np.isfinite(pose.deck_ned_m)):
        return None
    return math.hypot(pose.deck_ned_m[0] - pose.pos_ned_m[0], pose.deck_ned_m[1] - pose.pos_ned_m[1])


def _font_scale(img: np.ndarray) -> float:
    return max(0.3, img.shape[0] / 720.0)


def _draw_status(img: np.ndarray, t_s: float, mode: str, alt_m: float, phase: str, deck_m: float | None) -> None:
    """The status line across the top, white on a darkened band."""
    scale = _font_scale(img)
    band = int(round(30 * scale * 1.4))
    img[:band] = (img[:band] * 0.4).astype(np.uint8)
    alt_m = alt_m if abs(alt_m) >= 0.005 else 0.0  # no "-0.00"
    parts = [f"t {t_s:6.2f} s", mode or "?", f"alt {alt_m:5.2f} m"]
    if phase:
        parts.append(f"landing: {phase}")
    if deck_m is not None:
        parts.append(f"deck {deck_m:5.2f} m")
    at = (int(8 * scale * 1.4), int(round(band * 0.68)))
    cv2.putText(img, "   ".join(parts), at, cv2.FONT_HERSHEY_SIMPLEX, scale, TEXT_RGB, 1, cv2.LINE_AA)


def _draw_inset(img: np.ndarray, onboard_rgb: np.ndarray, n_markers: int | None) -> None:
    """The onboard view in greyscale in the bottom-right corner, framed, labelled with the markers in use."""
    h, w = onboard_rgb.shape[:2]
    margin = max(4, img.shape[0] // 60)
    y0, x0 = img.shape[0] - margin - h, img.shape[1] - margin - w
    grey = cv2.cvtColor(onboard_rgb, cv2.COLOR_RGB2GRAY)
    img[y0 : y0 + h, x0 : x0 + w] = grey[:, :, None]
    cv2.rectangle(img, (x0 - 1, y0 - 1), (x0 + w, y0 + h), TEXT_RGB, 1)
    label = "camera" if n_markers is None else f"camera: {n_markers} marker{'s' if n_markers != 1 else ''}"
    scale = _font_scale(img) * 0.8
    band = int(round(22 * scale * 1.4))
    top = max(0, y0 - band)
    img[top : y0 - 1, x0 - 1 : x0 + w + 1] = (img[top : y0 - 1, x0 - 1 : x0 + w + 1] * 0.4).astype(np.uint8)
    cv2.putText(img, label, (x0 + 4, y0 - band // 4 - 1), cv2.FONT_HERSHEY_SIMPLEX, scale, TEXT_RGB, 1, cv2.LINE_AA)
