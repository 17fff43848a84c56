"""Benchmark: the fast camera (``SIM_CAM_RENDER`` 1, sitl/deck_render.py) against MuJoCo's render: the same
detections, the same pose errors, at what cost, and the landing's real-time factor with each.

1. Frames: the same states rendered both ways (sitl/camera.py's DownwardCamera and sitl/deck_render.py's
   DeckCamera, the same seed: the same pixel noise, ``SIM_CAM_NOISE``'s 2 grey levels), each read by the
   companion's detector (vision/detector.py, with the pad's expected normal, as sitl/companion.py does).  States:
   ``--random N`` random ones over the deck (the multicopter 0.3-4 m above it, tilted up to 25 deg, any heading;
   the gimbal pointed ``--look-off`` deg or less off straight down with a roll of up to 20 deg and a yaw of up to
   30 deg, within its joints' ranges; the pad's centre anywhere within 70 % of the height of where the camera's
   axis meets the deck; the UGV at any heading), and every frame of the landings flown in 2. (or of ``--truth``
   logs).  For each renderer: the detection rate with its 95 % interval (Wilson), the pad centre's position error
   against the truth (3-D, as the companion's ``pose_err``: mean / p95 / max, cm), per height band too; paired:
   the frames only one of them found the pad in, and the mean difference of their errors (95 % interval); the
   pixels' difference (grey levels, noise and all); the time per frame (wall and process CPU, OpenCV held to one
   thread).  What the fast path leaves out (the multicopter's legs and propellers, the UGV's chassis, wheels and
   deck sides): from MuJoCo's segmentation, the frames in which any of it is in the picture, and those in which
   it covers part of a marker (the only way it could change a detection).
2. Landings: ``--landings K`` flights of ``flight-demo --scenario ugv-landing`` with each renderer, alternately
   (the video stream on, the demo's default, unless ``--no-video``): success, touchdown error, real-time factor.

Usage: ``python benchmarks/camera_fast_path.py [--random 400] [--landings 2] [--truth FILE.truth.npy ...]``
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
from _landing_frames import CameraWorld, LandingFrames, fly_landing, load_line  # noqa: E402

from campaign.report import wilson  # noqa: E402
from params.vehicle import load_vehicle  # noqa: E402
from sitl.camera import DownwardCamera  # noqa: E402
from sitl.deck_render import DeckCamera  # noqa: E402
from sitl.gimbal import GimbalSetpoint, earth_rotation, wanted_joint_angles  # noqa: E402
from sitl.marker_view import deck_centre_enu  # noqa: E402
from sitl.sim_settings import CameraSettings  # noqa: E402
from sitl.ugv import UgvGeometry  # noqa: E402
from vision.camera_model import pinhole  # noqa: E402
from vision.detector import MarkerDetector, expected_normal_cam  # noqa: E402
from vision.landing_target import target_offset  # noqa: E402
from vision.pad import NESTED_PAD  # noqa: E402

from _cli import add_instance, parser  # noqa: E402
from _progress import Progress  # noqa: E402

BANDS = ((0.3, 1.0), (1.0, 2.0), (2.0, 3.0), (3.0, 4.0))
RENDERERS = ("mujoco", "fast")


def random_states(world: CameraWorld, n: int, look_off_deg: float, seed: int):
    """Pose ``world`` in ``n`` random states (the module docstring), yielding each one's height above the deck."""
    rng = np.random.default_rng(seed)
    g, top = world.spec.camera.gimbal, UgvGeometry().deck_top_m
    limits = {"gimbal_yaw": g.yaw_range_deg, "gimbal_roll": g.roll_range_deg, "gimbal_pitch": g.pitch_range_deg}
    done = 0
    while done < n:
        h = rng.uniform(0.3, 4.0)
        tilt, towards = math.radians(25.0) * math.sqrt(rng.uniform()), rng.uniform(0, 2 * math.pi)
        rpy = (tilt * math.cos(towards), tilt * math.sin(towards), rng.uniform(-math.pi, math.pi))
        joints = None
        if world.spec.camera.gimballed:
            off, az = math.radians(look_off_deg) * math.sqrt(rng.uniform()), rng.uniform(0, 2 * math.pi)
            sp = GimbalSetpoint.from_angles(
                math.radians(rng.uniform(-20, 20)) + off * math.sin(az), -math.pi / 2 + off * math.cos(az),
                math.radians(rng.uniform(-30, 30)),
            )  # fmt: skip
            angles = wanted_joint_angles(earth_rotation(*rpy), sp)  # (yaw, roll, pitch)
            joints = {
                name: min(max(a, math.radians(limits[name][0])), math.radians(limits[name][1]))
                for name, a in zip(("gimbal_yaw", "gimbal_roll", "gimbal_pitch"), angles)
            }
        data = world.pose((0.0, 0.0, -top - h), rpy, (50.0, 50.0, -top), 0.0, joints)
        eye, axis = data.cam_xpos[world.camera_id], -data.cam_xmat[world.camera_id].reshape(3, 3)[:, 2]
        if axis[2] > -0.3:  # looking nearly at the horizon: another draw
            continue
        hit = eye + axis * (eye[2] - top) / -axis[2]  # where the camera's axis meets the deck's plane (ENU)
        r, a = 0.7 * h * math.sqrt(rng.uniform()), rng.uniform(0, 2 * math.pi)
        deck_ned = (hit[1] + r * math.sin(a), hit[0] + r * math.cos(a), -top)
        world.pose((0.0, 0.0, -top - h), rpy, deck_ned, rng.uniform(-math.pi, math.pi), joints)
        done += 1
        yield h


class Comparison:
    """Both renderers' frames of each state: detections, errors, pixel differences, times, what is left out."""

    def __init__(self, world: CameraWorld, noise_grey: float) -> None:
        spec, model = world.spec.camera, world.model
        self.world, self.noise = world, noise_grey
        self.cams = {"mujoco": DownwardCamera(model, spec, seed=1), "fast": DeckCamera(model, spec, seed=1)}
        lens = pinhole(spec.width_px, spec.height_px, math.radians(spec.hfov_deg))
        self.lens = lens
        self.detector = MarkerDetector(lens, layout=world.pad, rendered=True)
        self.seg = mujoco.Renderer(model, spec.height_px, spec.width_px)
        self.seg.enable_segmentation_rendering()
        own = {model.geom("ground").id, model.geom("ugv_deck").id}
        self.other_geoms = np.array([i not in own for i in range(model.ngeom)] + [False])
        self.rows: list[dict] = []

    def frame(self, source: str, height_m: float) -> None:
        w, data = self.world, self.world.data
        mount, q = w.mount(), w.attitude()
        up, truth = expected_normal_cam(mount.rotation_frd_cam, q), w.truth_frd()
        row = {"source": source, "height_m": height_m}
        frames = {}
        for name, cam in self.cams.items():
            t0, c0 = time.perf_counter(), time.process_time()
            frames[name] = cam.capture(data, self.noise)
            row[f"{name}_wall_s"], row[f"{name}_cpu_s"] = time.perf_counter() - t0, time.process_time() - c0
            det = self.detector.detect(frames[name], up)
            err = math.nan if det is None else float(np.linalg.norm(target_offset(det, mount, q).frd_m - truth))
            row[f"{name}_found"], row[f"{name}_err_m"] = det is not None, err
            row[f"{name}_ids"] = set(det.marker_ids) if det is not None else set()
        diff = np.abs(frames["mujoco"].astype(np.int16) - frames["fast"])
        row["pixel_mean"], row["pixel_p99"] = float(diff.mean()), float(np.percentile(diff, 99))
        self.seg.update_scene(data, camera=w.camera_id)
        ids = self.seg.render()[:, :, 0]
        foreign = self.other_geoms[np.where(ids < 0, len(self.other_geoms) - 1, ids)]
        row["foreign_px"] = int(foreign.sum())
        row["foreign_on_marker"] = bool(foreign.any() and (foreign & self._marker_mask()).any())
        self.rows.append(row)

    def _marker_mask(self) -> np.ndarray:
        """The pixels of the pad's markers in the current state (their projected outlines, filled)."""
        w, data, lens = self.world, self.world.data, self.lens
        mask = np.zeros((lens.height_px, lens.width_px), np.uint8)
        ugv = w.model.body("ugv").id
        centre, rot = deck_centre_enu(w.model, data), data.xmat[ugv].reshape(3, 3)
        cam_rot, eye = data.cam_xmat[w.camera_id].reshape(3, 3), data.cam_xpos[w.camera_id]
        for m in w.pad.markers:
            s = m.size_m / 2
            pts = []
            for dx, dy in ((-s, -s), (s, -s), (s, s), (-s, s)):
                p = cam_rot.T @ (centre + rot @ (m.x_m + dx, m.y_m + dy, 0.0) - eye)
                if -p[2] <= 1e-3:
                    break
                pts.append((lens.cx + lens.fx * p[0] / -p[2], lens.cy - lens.fy * p[1] / -p[2]))
            else:
                cv2.fillConvexPoly(mask, np.round(np.array(pts) * 16).astype(np.int32), 1, shift=4)
        return mask.astype(bool)

    def close(self) -> None:
        self.seg.close()
        for cam in self.cams.values():
            cam.close()


def summary(rows: list[dict], title: str) -> list[str]:
    n = len(rows)
    if n == 0:
        return []
    out = [
        f"### {title}: {n} frames",
        "",
        "| renderer | detected | rate (95 % interval) | error mean / p95 / max (cm) |",
    ]
    out.append("|---|---|---|---|")
    for name in RENDERERS:
        k = sum(r[f"{name}_found"] for r in rows)
        lo, hi = wilson(k, n)
        errs = np.array([r[f"{name}_err_m"] for r in rows if r[f"{name}_found"]])
        e = f"{100 * errs.mean():.2f} / {100 * np.percentile(errs, 95):.2f} / {100 * errs.max():.2f}" if k else "-"
        out.append(f"| {name} | {k}/{n} | {100 * k / n:.1f} % ({100 * lo:.1f}-{100 * hi:.1f} %) | {e} |")
    only_mj = sum(r["mujoco_found"] and not r["fast_found"] for r in rows)
    only_fast = sum(r["fast_found"] and not r["mujoco_found"] for r in rows)
    both = [r for r in rows if r["mujoco_found"] and r["fast_found"]]
    d = np.array([r["fast_err_m"] - r["mujoco_err_m"] for r in both])
    half = 1.96 * d.std(ddof=1) / math.sqrt(len(d)) if len(d) > 1 else math.nan
    out.append("")
    out.append(
        f"paired: both found the pad in {len(both)}, MuJoCo only in {only_mj}, the fast path only in {only_fast}; "
        f"error fast - MuJoCo {100 * d.mean():+.2f} cm (95 % interval {100 * (d.mean() - half):+.2f} to "
        f"{100 * (d.mean() + half):+.2f}), |difference| p95 {100 * np.percentile(np.abs(d), 95):.2f} cm"
        if len(d)
        else f"paired: MuJoCo only {only_mj}, fast only {only_fast}"
    )
    fewer = sum(len(r["fast_ids"]) < len(r["mujoco_ids"]) for r in both)
    more = sum(len(r["fast_ids"]) > len(r["mujoco_ids"]) for r in both)
    other = sum(r["fast_ids"] != r["mujoco_ids"] for r in both) - fewer - more
    out.append(
        f"markers the pose was computed from: the same in {len(both) - fewer - more - other} of those, fewer with the "
        f"fast path in {fewer}, more in {more}, others in {other} (a marker a few pixels wide, decoded or not)"
    )
    bands = []
    for lo_m, hi_m in BANDS:
        b = [r for r in rows if lo_m <= r["height_m"] < hi_m]
        if b:
            cells = []
            for name in RENDERERS:
                errs = [r[f"{name}_err_m"] for r in b if r[f"{name}_found"]]
                med = f"{100 * np.median(errs):.1f}" if errs else "-"
                cells.append(f"{len(errs)}/{len(b)}, {med} cm")
            bands.append(f"{lo_m:.1f}-{hi_m:.1f} m: MuJoCo {cells[0]}, fast {cells[1]}")
    out.append("by height above the deck (detected, median error): " + "; ".join(bands))
    pm = np.array([r["pixel_mean"] for r in rows])
    p99 = np.array([r["pixel_p99"] for r in rows])
    out.append(f"pixels |MuJoCo - fast|: mean {pm.mean():.2f} grey levels, a frame's p99 {np.median(p99):.1f} median")
    anyf = [r for r in rows if r["foreign_px"] > 0]
    onm = [r for r in rows if r["foreign_on_marker"]]
    changed = sum(r["mujoco_found"] != r["fast_found"] for r in onm)
    out.append(
        f"left out of the fast path: in the picture in {len(anyf)} frames ({100 * len(anyf) / n:.1f} %), "
        f"covering part of a marker in {len(onm)} ({100 * len(onm) / n:.1f} %), a different detection in {changed} "
        "of those"
    )
    for name in RENDERERS:
        w = np.array([r[f"{name}_wall_s"] for r in rows])
        c = np.array([r[f"{name}_cpu_s"] for r in rows])
        out.append(f"{name}: {1e3 * w.mean():.2f} ms wall, {1e3 * c.mean():.2f} ms CPU a frame (render + noise)")
    return out + [""]


def fly(args, log_root: Path) -> tuple[list[str], list[Path]]:
    """``--landings`` landings with each renderer, alternately: a table, and their truth logs."""
    rate = load_vehicle("quad_x").camera.rate_hz
    lines = [
        "| renderer | landing | OK | touchdown error (m) | real-time factor | CPU s per simulated s | wall s |",
        "|---|---|---|---|---|---|---|",
    ]
    truths: list[Path] = []
    rtf: dict[str, list[float]] = {name: [] for name in RENDERERS}
    cpu: dict[str, list[float]] = {name: [] for name in RENDERERS}
    for k in range(args.landings):
        for i, name in enumerate(RENDERERS):
            params = {"SIM_CAM_RENDER": float(i), "SIM_VID_EN": 0.0 if args.no_video else 1.0}
            f = fly_landing(args.instance, log_root / f"{name}_{k}", params)
            err = next((ln.split(":")[1].strip() for ln in f.output.splitlines() if "touchdown error" in ln), "-")
            per_s = f.cpu_s / (f.frames / rate) if f.frames else math.nan
            lines.append(
                f"| {name} | {k + 1} | {'yes' if f.ok else 'no'} | {err} | {f.real_time_factor:.2f} | {per_s:.3f} | "
                f"{f.wall_s:.1f} |"
            )
            ok = "OK" if f.ok else "FAILED"
            say = f"{name} landing {k + 1}: {ok}, error {err}, real-time factor {f.real_time_factor:.2f}"
            print(f"{say}, {per_s:.3f} CPU s per simulated s; {load_line()}", file=sys.stderr)
            rtf[name].append(f.real_time_factor)
            cpu[name].append(per_s)
            if f.truth is not None:
                truths.append(f.truth)
    for name in RENDERERS:
        if rtf[name]:
            lines.append(
                f"\n{name}: real-time factor mean {np.nanmean(rtf[name]):.2f} (min {np.nanmin(rtf[name]):.2f}, max "
                f"{np.nanmax(rtf[name]):.2f}), {np.nanmean(cpu[name]):.3f} CPU s per simulated s (the simulator, the "
                f"flight controller and the demo's client) over {len(rtf[name])} landings"
            )
    return lines, truths


def main() -> int:
    ap = parser(__doc__)
    ap.add_argument("--random", type=int, default=400, help="random states over the deck")
    ap.add_argument("--look-off", type=float, default=25.0, help="the gimbal's largest angle off straight down (deg)")
    ap.add_argument("--mount", choices=["gimbal", "fixed"], default="gimbal", help="the random states' camera mount")
    ap.add_argument("--landings", type=int, default=2, help="landings flown with each renderer (0: none)")
    ap.add_argument("--no-video", action="store_true", help="fly the landings with the video stream off")
    ap.add_argument("--truth", type=Path, nargs="*", default=[], help="flown landings' truth logs: their frames too")
    ap.add_argument("--seed", type=int, default=1, help="seed of the random states")
    ap.add_argument("--log-dir", type=Path, help="keep the landings' logs here (default: a temporary directory)")
    add_instance(ap, 15)
    args = ap.parse_args()
    cv2.setNumThreads(1)
    noise = CameraSettings().noise_grey
    with tempfile.TemporaryDirectory(prefix="camera-fast-path-") as tmp:
        root = args.log_dir if args.log_dir is not None else Path(tmp)
        landing_lines, truths = fly(args, root) if args.landings > 0 else ([], [])
        truths += list(args.truth)
        logs = [LandingFrames(t) for t in truths]
    print(f"{load_line()}\n")
    n_frames = sum(len(f) for f in logs)
    progress = Progress(args.random + n_frames, "frames")
    results = []
    if args.random > 0:
        world = CameraWorld(load_vehicle("quad_x").with_camera_mount(args.mount), NESTED_PAD)
        comp = Comparison(world, noise)
        for h in random_states(world, args.random, args.look_off, args.seed):
            comp.frame("random", h)
            progress.done()
        comp.close()
        results.append((f"random states ({args.mount} camera)", comp.rows))
    rows: list[dict] = []
    for frames in logs:
        comp = Comparison(frames, noise)
        for k in range(len(frames)):
            data = frames.place(k)
            veh = frames.model.body("vehicle").id
            comp.frame("landing", float(data.xpos[veh][2] - deck_centre_enu(frames.model, data)[2]))
            progress.done()
        comp.close()
        rows += comp.rows
    progress.close()
    if rows:
        results.append((f"the frames of {len(logs)} landings", rows))
    for title, r in results:
        print("\n".join(summary(r, title)))
    if landing_lines:
        print("### landings (flight-demo --scenario ugv-landing)\n")
        print("\n".join(landing_lines))
    print(f"\nafter: {load_line()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
