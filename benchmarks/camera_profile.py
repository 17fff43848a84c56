"""Benchmark: where the time of a camera-on landing's frames goes, stage by stage, for each renderer.

Flies one ``flight-demo --scenario ugv-landing`` (sitl/companion.py's camera and vision companion on, at full
speed; its real-time factor and the simulator's camera line are printed), or reads a flight already flown
(``--truth FILE.truth.npy``, with its .frames.npy and .sim.json beside it), then replays that landing's camera
frames: each frame's state (the multicopter, the UGV, the gimbal's joints at its capture) is put back into a
MuJoCo model of the world it was flown in, and the companion's work on it is done again, one stage at a time:

- view test: whether a marker can be in the frame at all (sitl/marker_view.py); a frame without is not rendered;
- scene update: ``mujoco.Renderer.update_scene`` (the geoms and lights for the frame);
- render: MuJoCo's OpenGL render (``mjr_render``, then ``glFinish`` so the rasterising is counted here), or the
  fast path's whole frame (sitl/deck_render.py, ``SIM_CAM_RENDER`` 1);
- read-back: ``mjr_readPixels`` and the vertical flip;
- grey + noise: the RGB frame to grey, plus the seeded pixel noise (sitl/camera.py);
- detection: the ArUco detector and the pad's pose (vision/detector.py);
- message: the target in the body frame and LANDING_TARGET packed (vision/landing_target.py);
- with ``--video`` (the RTP stream on, ``SIM_VID_EN`` 1: the simulator's default), every frame is rendered, those
  without a marker in view too, and "video" is its colour frame encoded as H.264 and sent (sitl/video_stream.py,
  to a local UDP port nobody reads).

Each stage's time is its sum over the flight per frame rendered for detection (the view test and the video run on
other frames too), as wall time and as the process's CPU time (``time.process_time``: every thread, Mesa's
rasteriser threads included; OpenCV held to one thread).  The share of a frame's total, and what the camera costs
per simulated second (20 frames, the view test on all, the rest on those rendered), follow.  The machine's load is
printed beside them: the wall times grow with it.

Usage: ``python benchmarks/camera_profile.py [--truth FILE.truth.npy] [--renderers mujoco fast] [--repeat 2]``
"""

from __future__ import annotations

import math
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")  # headless rendering, before MuJoCo is imported (as sitl does)

import cv2  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from _landing_frames import LandingFrames, fly_landing, load_line  # noqa: E402
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from sitl.camera import FrameNoise  # noqa: E402
from sitl.marker_view import MarkerView  # noqa: E402
from sitl.sim_settings import CameraSettings  # noqa: E402
from vision.camera_model import pinhole  # noqa: E402
from vision.detector import MarkerDetector, expected_normal_cam  # noqa: E402
from vision.landing_target import landing_target_message, target_offset  # noqa: E402

from _cli import add_instance, parser  # noqa: E402

STAGES = ("view test", "scene update", "render", "read-back", "grey + noise", "detection", "message", "video")
NOISE_GREY = CameraSettings().noise_grey


class Clock:
    """Wall and process-CPU seconds per stage, summed, and how many times each was timed."""

    def __init__(self) -> None:
        self.wall = dict.fromkeys(STAGES, 0.0)
        self.cpu = dict.fromkeys(STAGES, 0.0)
        self.count = dict.fromkeys(STAGES, 0)
        self._t = (0.0, 0.0)

    def start(self) -> None:
        self._t = (time.perf_counter(), time.process_time())

    def lap(self, stage: str) -> None:
        w, c = time.perf_counter(), time.process_time()
        self.wall[stage] += w - self._t[0]
        self.cpu[stage] += c - self._t[1]
        self.count[stage] += 1
        self._t = (w, c)


def _mujoco_frame(renderer: mujoco.Renderer, data: mujoco.MjData, camera: int, clock: Clock) -> np.ndarray:
    """sitl/camera.py's DownwardCamera.capture's render, one stage at a time (the renderer's own calls): RGB."""
    from OpenGL import GL  # (PyOpenGL on the EGL platform MuJoCo chose)

    option = mujoco.MjvOption()
    renderer.update_scene(data, camera=camera, scene_option=option)
    for flag in ("mjRND_SHADOW", "mjRND_REFLECTION", "mjRND_SKYBOX"):
        renderer.scene.flags[getattr(mujoco.mjtRndFlag, flag)] = 0
    clock.lap("scene update")
    renderer._gl_context.make_current()
    mujoco.mjr_render(renderer._rect, renderer._scene, renderer._mjr_context)
    GL.glFinish()
    clock.lap("render")
    rgb = np.empty((renderer.height, renderer.width, 3), np.uint8)
    mujoco.mjr_readPixels(rgb, None, renderer._rect, renderer._mjr_context)
    rgb = np.flipud(rgb).copy()
    clock.lap("read-back")
    return rgb


def profile(frames: LandingFrames, renderer_name: str, repeat: int, video: bool) -> tuple[Clock, int, int]:
    """The stages' times over every frame of the flight, ``repeat`` times; (clock, frames rendered for detection,
    detections) a pass."""
    from sitl.deck_render import DeckCamera
    from sitl.video_stream import RtpVideoStream

    spec, model = frames.spec.camera, frames.model
    lens = pinhole(spec.width_px, spec.height_px, math.radians(spec.hfov_deg))
    detector = MarkerDetector(lens, layout=frames.pad, rendered=True)
    view = MarkerView(model, "downward", lens, frames.pad)
    mav = mavlink.MAVLink(None, 1, mavlink.MAV_COMP_ID_ONBOARD_COMPUTER)
    gl = mujoco.Renderer(model, spec.height_px, spec.width_px) if renderer_name == "mujoco" else None
    fast = DeckCamera(model, spec) if renderer_name == "fast" else None
    clock, rendered, found = Clock(), 0, 0
    for _ in range(repeat):
        noise = FrameNoise(spec, seed=0)
        stream = RtpVideoStream("127.0.0.1", 9, spec.width_px, spec.height_px, spec.rate_hz) if video else None
        for k in range(len(frames)):
            data = frames.place(k)
            clock.start()
            hidden = view.out_of_view(data)
            clock.lap("view test")
            if hidden and stream is None:
                noise.skip(NOISE_GREY)
                continue
            if gl is not None:
                rgb = _mujoco_frame(gl, data, frames.camera_id, clock)
                grey = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)
            else:
                grey = fast.renderer.render(data)  # type: ignore[union-attr]
                clock.lap("render")
            frame = noise.add(grey, NOISE_GREY)
            clock.lap("grey + noise")
            if stream is not None:
                if gl is None:
                    fast._clean, fast._rgb = grey, None  # type: ignore[union-attr]
                    rgb = fast.last_rgb  # type: ignore[union-attr]
                stream.send(rgb, int(frames.frames["time_us"][k]))
                clock.lap("video")
            if hidden:
                continue
            mount, q = frames.mount(), frames.attitude()
            det = detector.detect(frame, expected_normal_cam(mount.rotation_frd_cam, q))
            clock.lap("detection")
            rendered += 1
            if det is not None:
                found += 1
                target_offset(det, mount, q)
                landing_target_message(det, mount, q, 0, frame=mavlink.MAV_FRAME_BODY_FRD).pack(mav)
                clock.lap("message")
        if stream is not None:
            stream.close()
    if gl is not None:
        gl.close()
    return clock, rendered // repeat, found // repeat


def table(results: dict[str, tuple[Clock, int, int]], n_frames: int, rate_hz: float, repeat: int) -> list[str]:
    names = list(results)
    head = " | ".join(f"{n}: wall ms | {n}: CPU ms | {n}: share" for n in names)
    lines = [f"| stage (per rendered frame) | {head} |", "|---" * (1 + 3 * len(names)) + "|"]
    totals = {}
    for n, (clock, rendered, _) in results.items():
        per = {s: 0.0 for s in STAGES}
        for s in STAGES:
            if clock.count[s]:
                # per rendered frame: the view test is on every frame, so spread over those rendered
                per[s] = clock.wall[s] / max(rendered * repeat, 1), clock.cpu[s] / max(rendered * repeat, 1)
            else:
                per[s] = (0.0, 0.0)
        totals[n] = per
    for s in STAGES:
        cells = []
        for n in names:
            w, c = totals[n][s]
            total_w = sum(v[0] for v in totals[n].values())
            cells.append(f"{1e3 * w:.2f} | {1e3 * c:.2f} | {100 * w / total_w:.0f} %" if w > 0 else "- | - | -")
        lines.append(f"| {s} | {' | '.join(cells)} |")
    cells = []
    for n in names:
        w = sum(v[0] for v in totals[n].values())
        c = sum(v[1] for v in totals[n].values())
        cells.append(f"**{1e3 * w:.2f}** | **{1e3 * c:.2f}** | 100 %")
    lines.append(f"| total | {' | '.join(cells)} |")
    sim_s = n_frames / rate_hz
    for n, (clock, rendered, found) in results.items():
        wall = sum(clock.wall.values()) / repeat
        cpu = sum(clock.cpu.values()) / repeat
        lines.append(
            f"\n{n}: {n_frames} frames ({sim_s:.1f} simulated s), {rendered} rendered, {found} with the pad; "
            f"the camera's work costs {wall / sim_s:.3f} wall s and {cpu / sim_s:.3f} CPU s per simulated second "
            f"(a core of its own could keep up with {sim_s / cpu:.0f}x real time at most)"
        )
    return lines


def main() -> int:
    ap = parser(__doc__, progress=False)
    ap.add_argument("--truth", type=Path, help="a flown landing's truth log (default: fly one now)")
    ap.add_argument("--renderers", nargs="+", default=["mujoco", "fast"], choices=["mujoco", "fast"],
                    help="the renderers to profile (SIM_CAM_RENDER 0 and 1)")  # fmt: skip
    ap.add_argument("--repeat", type=int, default=2, help="passes over the flight's frames (their times averaged)")
    ap.add_argument("--video", action="store_true", help="the RTP stream on: every frame rendered and encoded too")
    ap.add_argument("--log-dir", type=Path, help="where the flown landing's logs go (default: a temporary directory)")
    add_instance(ap, 14)
    args = ap.parse_args()
    cv2.setNumThreads(1)
    tmp = None
    if args.truth is None:
        log_dir = args.log_dir
        if log_dir is None:
            tmp = tempfile.TemporaryDirectory(prefix="camera-profile-")
            log_dir = Path(tmp.name)
        print(f"flying flight-demo --scenario ugv-landing (instance {args.instance}) ...", file=sys.stderr)
        flown = fly_landing(args.instance, log_dir, {"SIM_VID_EN": int(args.video)})
        if not flown.ok or flown.truth is None:
            print(flown.output, file=sys.stderr)
            print("the landing failed: nothing to profile", file=sys.stderr)
            return 1
        stream = "on" if args.video else "off"
        rtf = flown.real_time_factor
        print(f"the landing (video stream {stream}): real-time factor {rtf:.2f}, {flown.wall_s:.1f} wall s")
        print(f"the simulator's {flown.camera_line}")
        truth = flown.truth
    else:
        truth = args.truth
    frames = LandingFrames(truth)
    print(f"{truth.name}: {len(frames)} camera frames; {load_line()}")
    results = {name: profile(frames, name, args.repeat, args.video) for name in args.renderers}
    print("\n".join(table(results, len(frames), frames.spec.camera.rate_hz, args.repeat)))
    print(f"after: {load_line()}")
    if tmp is not None:
        tmp.cleanup()
    return 0


if __name__ == "__main__":
    sys.exit(main())
