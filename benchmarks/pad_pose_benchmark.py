"""Benchmark: how well the companion's detector (vision/detector.py) finds the landing pad's centre, per layout.

Renders the quad_x's downward camera (480 x 360 px, 90 deg; sitl/camera.py, grey noise 2) over the UGV's deck
carrying each pad layout (vision/pad.py), from random poses: the vehicle at a height above the deck drawn in each
height band, tilted up to --max-tilt deg in a random direction, a random yaw, the pad's centre anywhere within
30 % of the height of where the camera's axis meets the deck (the gimbal at its zero: the camera fixed to the body,
looking down).  Every layout sees the same poses and the same noise.  For each frame it compares the pad's centre
the detector reports (along the body FRD axes, vision/landing_target.py, as the companion sends it) with the truth
the frame was rendered from, and prints per height band: the detection rate, the median and 95th percentile of
the centre's position error (3-D, cm) over the frames with a detection, and the detection's mean CPU time (ms; OpenCV
held to one thread, so that it is the work done, whatever else the machine runs; the poses found are the same).

Layouts: single (the seed's marker 76, 0.333 m, at the centre), side (76 at 0.30 m behind the centre beside 42,
0.125 m, at the centre: the first nested pad), board (vision.pad.NESTED_PAD, the default).  "+g" after a name
gives the detector the expected pad normal from the vehicle's attitude and one threshold window (``rendered``: the
simulated companion's way; without it, python -m vision's).  --jpeg Q passes every frame through JPEG at quality
Q first, as a recorded video would.

Usage: ``python benchmarks/pad_pose_benchmark.py [--frames 40] [--layouts single side board board+g]``
"""

from __future__ import annotations

import math
import os
import sys
import time
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")  # headless rendering, before MuJoCo is imported (as sitl does)

import cv2  # noqa: E402
import mujoco  # noqa: E402
import numpy as np  # noqa: E402
from scipy.spatial.transform import Rotation  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from mavsim_core.frames import quat_enu_flu_to_ned_frd  # noqa: E402
from params.vehicle import load_vehicle  # noqa: E402
from sitl.camera import DownwardCamera  # noqa: E402
from sitl.marker_view import deck_centre_enu  # noqa: E402
from sitl.sim_settings import UgvSettings  # noqa: E402
from sitl.simulation import Simulation  # noqa: E402
from vision.camera_model import pinhole  # noqa: E402
from vision.detector import MarkerDetector, expected_normal_cam  # noqa: E402
from vision.landing_target import CameraMount, target_offset  # noqa: E402
from vision.pad import NESTED_PAD, SINGLE_PAD, PadLayout, PadMarker  # noqa: E402

from _cli import parser  # noqa: E402
from _progress import Progress  # noqa: E402

SIDE_BY_SIDE = PadLayout((PadMarker(76, 0.333, -0.30, 0.0), PadMarker(42, 0.125)))
LAYOUTS = {"single": SINGLE_PAD, "side": SIDE_BY_SIDE, "board": NESTED_PAD}
BANDS = ((0.3, 0.6), (0.6, 1.0), (1.0, 1.5), (1.5, 2.0), (2.0, 2.5), (2.5, 3.0), (3.0, 3.5), (3.5, 4.0))
SPEC = load_vehicle("quad_x")


def poses(frames: int, max_tilt_deg: float, bands, seed: int) -> list[tuple[int, float, Rotation, np.ndarray]]:
    """(band index, height above the deck m, body FLU -> ENU rotation, the pad's centre from the point below the
    vehicle, ENU m) for ``frames`` poses a band."""
    rng = np.random.default_rng(seed)
    out = []
    for b, (lo, hi) in enumerate(bands):
        for _ in range(frames):
            h = rng.uniform(lo, hi)
            tilt, towards, yaw = (
                math.radians(max_tilt_deg) * math.sqrt(rng.uniform()),
                rng.uniform(0, 2 * math.pi),
                rng.uniform(0, 2 * math.pi),
            )
            axis = np.array((math.cos(towards), math.sin(towards), 0.0))
            rot = Rotation.from_rotvec(tilt * axis) * Rotation.from_euler("z", yaw)
            look = rot.apply((0.0, 0.0, -1.0))  # the camera's axis (body down), ENU
            r, a = 0.3 * h * math.sqrt(rng.uniform()), rng.uniform(0, 2 * math.pi)
            offset = look[:2] * h / -look[2] + r * np.array((math.cos(a), math.sin(a)))
            out.append((b, h, rot, offset))
    return out


def measure(
    layout: PadLayout, gravity: bool, samples, jpeg: int, progress: Progress
) -> list[tuple[int, bool, float, float]]:
    """(band, detected, centre error m, detection s) per pose."""
    ugv = UgvSettings(enabled=1, north_m=3.0, east_m=1.0, yaw_deg=30.0, path=0, nested_pad=layout)
    sim = Simulation(SPEC, (47.4, 8.5, 400.0), seed=1, ugv=ugv)
    cam = DownwardCamera(sim.model, SPEC.camera, seed=1)
    lens = pinhole(SPEC.camera.width_px, SPEC.camera.height_px, math.radians(SPEC.camera.hfov_deg))
    det = MarkerDetector(lens, layout=layout, rendered=gravity)  # +g: the simulated companion's detector
    mount = CameraMount(position_frd_m=SPEC.camera.position_frd_m)
    deck = deck_centre_enu(sim.model, sim.data).copy()
    veh = sim.model.body("vehicle").id
    out = []
    for band, h, rot, offset in samples:
        x, y, z, w = rot.as_quat()
        sim.data.qpos[0:3] = [deck[0] - offset[0], deck[1] - offset[1], deck[2] + h]
        sim.data.qpos[3:7] = [w, x, y, z]
        mujoco.mj_forward(sim.model, sim.data)
        frame = cam.capture(sim.data, noise_grey=2.0)
        if jpeg:
            frame = cv2.imdecode(cv2.imencode(".jpg", frame, (cv2.IMWRITE_JPEG_QUALITY, jpeg))[1], cv2.IMREAD_GRAYSCALE)
        q = quat_enu_flu_to_ned_frd(np.array(sim.data.qpos[3:7]))
        up = expected_normal_cam(mount.rotation_frd_cam, q) if gravity else None
        t0 = time.process_time()
        found = det.detect(frame, up)
        dt = time.process_time() - t0
        err = math.nan
        if found is not None:
            flu = sim.data.xmat[veh].reshape(3, 3).T @ (deck_centre_enu(sim.model, sim.data) - sim.data.xpos[veh])
            truth = np.array((flu[0], -flu[1], -flu[2]))
            err = float(np.linalg.norm(target_offset(found, mount, q).frd_m - truth))
        out.append((band, found is not None, err, dt))
        progress.done()
    cam.close()
    return out


def table(name: str, rows, bands) -> list[str]:
    lines = [
        f"{name}:",
        "| height above deck (m) | detected | error median (cm) | error p95 (cm) | detect CPU (ms) |",
        "|---|---|---|---|---|",
    ]
    for b, (lo, hi) in enumerate(bands):
        mine = [r for r in rows if r[0] == b]
        errs = np.array([r[2] for r in mine if r[1]])
        med, p95 = (f"{100 * np.median(errs):.1f}", f"{100 * np.percentile(errs, 95):.1f}") if len(errs) else ("-", "-")
        ms = 1e3 * np.mean([r[3] for r in mine])
        lines.append(f"| {lo:.1f}-{hi:.1f} | {len(errs)}/{len(mine)} | {med} | {p95} | {ms:.2f} |")
    errs = np.array([r[2] for r in rows if r[1]])
    lines.append(
        f"| all | {len(errs)}/{len(rows)} | {100 * np.median(errs):.1f} | {100 * np.percentile(errs, 95):.1f} | "
        f"{1e3 * np.mean([r[3] for r in rows]):.2f} |"
    )
    return lines


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--frames", type=int, default=40, help="poses a height band")
    ap.add_argument("--max-tilt", type=float, default=30.0, help="the vehicle's largest tilt (deg)")
    ap.add_argument("--max-height", type=float, default=4.0, help="the top of the last band (m above the deck)")
    ap.add_argument("--layouts", nargs="+", default=["single", "side", "board", "board+g"], help="layouts, +g: gravity")
    ap.add_argument("--jpeg", type=int, default=0, help="JPEG quality each frame passes through (0: none)")
    ap.add_argument("--seed", type=int, default=1, help="seed of the random poses (the same poses for every layout)")
    args = ap.parse_args()
    cv2.setNumThreads(1)
    bands = [b for b in BANDS if b[1] <= args.max_height + 1e-9]
    while bands[-1][1] < args.max_height - 1e-9:
        bands.append((bands[-1][1], min(bands[-1][1] + 0.5, args.max_height)))
    samples = poses(args.frames, args.max_tilt, bands, args.seed)
    progress = Progress(len(samples) * len(args.layouts), "frames")
    results = {}
    for name in args.layouts:
        base = name.removesuffix("+g")
        if base not in LAYOUTS:
            ap.error(f"--layouts: {name!r}: not one of {', '.join(LAYOUTS)} (with or without +g)")
        results[name] = measure(LAYOUTS[base], name.endswith("+g"), samples, args.jpeg, progress)
    progress.close()
    print(f"{args.frames} poses a band, tilt up to {args.max_tilt:g} deg, JPEG {args.jpeg or 'off'}")
    for name, rows in results.items():
        print("\n".join(table(name, rows, bands)) + "\n")


if __name__ == "__main__":
    main()
