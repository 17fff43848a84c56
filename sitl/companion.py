"""The vision companion in lockstep: camera frames -> ArUco -> LANDING_TARGET, after a simulated latency.

A real companion computer grabs a frame, finds the marker and sends LANDING_TARGET to the
flight controller some tens of milliseconds later.  Here the simulator plays both the
camera and that computer, with the companion's own code (:mod:`vision`): at each capture
time (``rate_hz`` of the vehicle file's [camera], simulated time) the state is handed to a worker
(:mod:`sitl.companion_workers`: a process of its own with ``SIM_CAM_PROC`` 1, the default, else a thread), which
renders the frame (:mod:`sitl.camera`; :mod:`sitl.deck_render` with ``SIM_CAM_RENDER`` 1), runs the detector and
builds the message; the message goes out on the simulator link in the first period at or after capture +
``SIM_CAM_LAT_MS``, before that period's HIL_SENSOR.  The worker runs while the simulator steps on, so rendering
costs little wall time, and nothing depends on its timing: the frame is rendered from the state taken at capture,
and the message waits for its release time (the main thread blocks if the worker is late).  Same seed, same
frames, same messages, whichever worker.

LANDING_TARGET is sent in ArduPilot's body form (MAV_FRAME_BODY_FRD: x/y/z the marker's
centre from the vehicle's centre of mass along body FRD axes, m; angle_x/angle_y/distance
filled too; ``time_usec`` = capture time, the lockstep clock) from the vehicle's system
(1) as MAV_COMP_ID_ONBOARD_COMPUTER (191), as a companion computer wired to the flight
controller would.  With no marker in view nothing is sent.

The pad (:mod:`vision.pad`, ``SIM_PAD_LAYOUT``) may have several markers: the detector uses every one it sees
(one pose from all their corners) and the message is the pad's centre whichever they were.  Which markers were
used, how often and from how near and far is counted per marker (:class:`MarkerUse`) and said in the camera line
the companion prints when it closes (the simulator's log).  Each frame is also handed, in capture order and on
the lockstep thread, to ``on_frame`` (a :class:`sitl.truth_log.CameraFrame`: capture time, the gimbal's joint
angles, the markers used), which the simulator's ground-truth log records.
"""

from __future__ import annotations

import math
import sys
import time
from collections import deque
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import mujoco
import numpy as np
from pymavlink.dialects.v20 import common as mavlink

from params.vehicle import CameraSpec
from sitl.camera import RENDER_FAST, DownwardCamera, open_camera
from sitl.camera_media import CameraMedia, CameraPose, camera_pose
from sitl.companion_workers import FrameAnswer, new_worker
from sitl.gimbal import camera_to_body
from sitl.marker_view import MarkerView, deck_centre_enu
from sitl.model import GIMBAL_JOINTS, part_name
from sitl.sim_settings import CameraSettings
from sitl.truth_log import CameraFrame
from vision.camera_model import pinhole
from vision.detector import MarkerDetection, MarkerDetector, expected_normal_cam
from vision.landing_target import CameraMount, landing_target_message, target_offset
from vision.pad import NESTED_PAD, PadLayout

COMPANION_COMPID = mavlink.MAV_COMP_ID_ONBOARD_COMPUTER  # 191
BUSY_KEEPALIVE_S = 0.2  # wall seconds between two "busy" HEARTBEATs while the lockstep waits for a frame


@dataclass
class MarkerUse:
    """One marker's part in the detections: the frames whose pose it was used in, those in which it was the pad's
    only marker seen, and the nearest and farthest distance (camera to the pad's centre, m) it was used from."""

    frames: int = 0
    alone: int = 0
    nearest_m: float = math.inf
    farthest_m: float = 0.0

    def add(self, distance_m: float, alone: bool) -> None:
        self.frames += 1
        self.alone += int(alone)
        self.nearest_m = min(self.nearest_m, distance_m)
        self.farthest_m = max(self.farthest_m, distance_m)


@dataclass
class CompanionStats:
    frames: int = 0
    not_rendered: int = 0  # frames skipped: the marker wholly out of view (sitl.marker_view)
    detections: int = 0
    render_s: float = 0.0
    detect_s: float = 0.0
    max_range_m: float = 0.0
    waited_s: float = 0.0  # the lockstep loop waiting for the worker (wall seconds)
    pose_err_sum_m: float = 0.0  # the detections' marker position against the truth the frame was rendered from
    pose_err_max_m: float = 0.0
    markers: dict[int, MarkerUse] = field(default_factory=dict)  # marker id -> its use, in the order first used

    def count_markers(self, detection: MarkerDetection) -> None:
        """Which of the pad's markers ``detection`` was computed from."""
        for marker_id in detection.marker_ids:
            use = self.markers.setdefault(marker_id, MarkerUse())
            use.add(detection.distance_m, alone=len(detection.marker_ids) == 1)

    def markers_line(self) -> str:
        """ "markers used: id 76 in 120 frames (0.95-3.41 m, alone in 40), ..." (distances to the pad's centre)."""
        uses = (
            f"id {i} in {u.frames} frames ({u.nearest_m:.2f}-{u.farthest_m:.2f} m, alone in {u.alone})"
            for i, u in sorted(self.markers.items())
        )
        return "markers used: " + (", ".join(uses) or "none")

    def line(self) -> str:
        n = max(self.frames, 1)
        return (
            f"camera: {self.frames} frames, {self.detections} with the marker "
            f"({100.0 * self.detections / n:.0f} %, farthest {self.max_range_m:.2f} m); "
            f"{self.not_rendered} not rendered (the marker out of view); per frame rendered "
            f"{1e3 * self.render_s / max(n - self.not_rendered, 1):.1f} ms render + "
            f"{1e3 * self.detect_s / max(n - self.not_rendered, 1):.1f} ms detect; "
            f"the simulator waited {self.waited_s:.2f} s for it; marker position error against the truth "
            f"{100 * self.pose_err_sum_m / max(self.detections, 1):.1f} cm mean, "
            f"{100 * self.pose_err_max_m:.1f} cm max; {self.markers_line()}"
        )


@dataclass
class FramePipeline:
    """What makes the frames, opened on the worker: renderer, detector, the camera's fixed mount, the view test."""

    camera: DownwardCamera
    detector: MarkerDetector
    mount: CameraMount
    view: MarkerView


class LockstepCompanion:
    """Camera + vision companion for one simulation (see the module docstring)."""

    def __init__(
        self,
        model: mujoco.MjModel,
        camera: CameraSpec,
        settings: CameraSettings,
        seed: int = 0,
        sysid: int = 1,
        save_dir: Path | None = None,
        save_every: int = 10,
        pad: PadLayout = NESTED_PAD,
        vehicle: int = 0,
        ugv: int = 0,
        worker: bool = True,
        fork_worker: bool = False,
    ) -> None:
        """``worker`` False: no worker of its own (the pipeline alone, as the worker process builds it);
        ``fork_worker``: a worker process is forked from this one (only a process that has not rendered or run OpenCV
        yet: the simulator building its world), else started afresh."""
        self._args = (model, camera, settings, seed, sysid, save_dir, save_every, pad, vehicle, ugv)
        self.model, self.spec, self.settings, self.pad = model, camera, settings, pad
        # Which multicopter of the world carries this camera (its parts: sitl.model.part_name) and which ground
        # vehicle's deck it looks for (sitl.ugv.ugv_part): vehicle k of a world where each has its own lands on k's
        self.vehicle, self.ugv = vehicle, ugv
        self._camera_name = part_name(vehicle, "downward")
        self._body = model.body(part_name(vehicle, "vehicle")).id
        self._qadr = int(model.jnt_qposadr[model.joint(part_name(vehicle, "root")).id])
        self.period_us = round(1e6 / camera.rate_hz)
        self.next_capture_us = 0
        self.mav = mavlink.MAVLink(None, sysid, COMPANION_COMPID)
        self.stats = CompanionStats()
        self.save_dir, self.save_every = save_dir, save_every
        self._pending: deque[tuple[int, int, CameraPose | None]] = deque()  # (release, capture time, media's pose)
        self._seed = seed
        # A gimballed camera: its encoders' qpos addresses (the mount's rotation is read from them at each capture)
        self._gimbal_qadr = (
            [int(model.jnt_qposadr[model.joint(part_name(vehicle, name)).id]) for name, _ in GIMBAL_JOINTS]
            if camera.gimballed
            else None
        )
        self._camera_id = model.camera(self._camera_name).id
        self.on_frame: Callable[[CameraFrame], None] | None = None  # each frame's record, at its release
        self.media: CameraMedia | None = None  # the video, photos and recordings (sitl/camera_media.py), if any
        self.keepalive: Callable[[], None] | None = None  # while a frame is waited for (sitl/lockstep.py)
        # the frames' worker (sitl/companion_workers.py): a process of its own (SIM_CAM_PROC 1) or a thread
        self._worker = new_worker(self, bool(int(settings.process)), fork_worker) if worker else None

    def constructor_args(self) -> tuple:
        """The arguments this companion was built from (the worker process builds its own from them)."""
        return self._args

    # -- main thread ---------------------------------------------------------------------------
    def step(self, data: mujoco.MjData, time_us: int) -> bytes:
        """Called once per period before HIL_SENSOR: capture if due; return the messages now due."""
        if time_us >= self.next_capture_us:
            self.next_capture_us += self.period_us * max(1, (time_us - self.next_capture_us) // self.period_us + 1)
            if not self.settings.fail:
                self._capture(data, time_us)
        out = b""
        while self._pending and self._pending[0][0] <= time_us:
            _, captured_us, pose = self._pending.popleft()
            t0 = time.perf_counter()
            answer = self._worker.answer(self.keepalive, BUSY_KEEPALIVE_S)
            self.stats.waited_s += time.perf_counter() - t0
            if answer.media is not None and self.media is not None and pose is not None:
                self.media.frame(answer.media[0], captured_us, pose, answer.media[1])
            out += answer.packed
            if self.on_frame is not None:
                self.on_frame(answer.frame)
        return out

    def _capture(self, data: mujoco.MjData, time_us: int) -> None:
        """Hand the frame captured now to the worker (dropped when it has IN_FLIGHT waiting: a busy companion); the
        media's wish for it is taken now, with the camera's pose for a photo's geotag."""
        want_media = self.media is not None and self.media.wants(time_us)
        if self._worker.submit(data, time_us, float(self.settings.noise_grey), want_media):
            release = time_us + 1000 * int(self.settings.latency_ms)
            self._pending.append((release, time_us, self.pose_of(data) if want_media else None))

    def close(self) -> None:
        frames = self._worker.close()
        if frames is not None:  # (kept by a process of its own: all but the wait, which is this side's)
            frames.waited_s, self.stats = self.stats.waited_s, frames
        who = f"vehicle {self.vehicle} " if self.vehicle else ""  # (a world of several: each vehicle's camera)
        print(f"[sitl] {who}{self.stats.line()}", file=sys.stderr, flush=True)

    # -- the frame pipeline (on the worker: sitl/companion_workers.py) -----------------------------
    def open_pipeline(self) -> FramePipeline:
        """The renderer, the detector, the fixed mount and the view test, opened where the frames are made (a
        renderer's GL context belongs to the thread that opened it)."""
        spec = self.spec
        camera = open_camera(self.model, spec, self._seed, int(self.settings.render), self._camera_name)
        detector = MarkerDetector(
            pinhole(spec.width_px, spec.height_px, math.radians(spec.hfov_deg)), layout=self.pad, rendered=True
        )
        view = MarkerView(self.model, self._camera_name, detector.camera, self.pad, self.ugv)
        return FramePipeline(camera, detector, CameraMount(position_frd_m=spec.position_frd_m), view)

    def process_frame(
        self, pipeline: FramePipeline, data: mujoco.MjData, time_us: int, noise: float, want_media: bool
    ) -> FrameAnswer:
        """One frame: rendered (unless the marker is wholly out of view and ``want_media`` is false: the video or a
        photo wants it), the marker found, the message packed; with the frame's record (:class:`CameraFrame`) and,
        when wanted, the RGB frame and the detection for the media."""
        camera, detector, mount, view = pipeline.camera, pipeline.detector, pipeline.mount, pipeline.view
        st = self.stats
        joints = self._joints(data)
        rpy = None if joints is None else (joints[1], joints[2], joints[0])  # (yaw, roll, pitch) -> roll, pitch, yaw
        saved = self.save_dir is not None and (camera.frames + 1) % self.save_every == 1
        if not saved and not self._could_show(view, data):  # it could not show the marker
            shown = None
            if want_media:  # (rendered for the video alone: the same noise draws as a skip, so the same frames after)
                camera.capture(data, noise)
                shown = (camera.last_rgb, None)
            else:
                camera.skip(noise)
            st.frames, st.not_rendered = camera.frames, st.not_rendered + 1
            return FrameAnswer(b"", CameraFrame(time_us, rpy, rendered=False), shown)  # type: ignore[arg-type]
        frame = camera.capture(data, noise)
        mount = self._mount_at_capture(mount, joints)
        q_ned_frd = _attitude(data, self._qadr)
        t0 = time.perf_counter()
        det = detector.detect(frame, expected_normal_cam(mount.rotation_frd_cam, q_ned_frd))
        st.detect_s += time.perf_counter() - t0
        shown = (camera.last_rgb, det) if want_media else None  # (the video drawn with it when SIM_VID_ANNOT is 1)
        st.frames, st.render_s = camera.frames, camera.render_s
        if self.save_dir is not None and st.frames % self.save_every == 1:
            self._save(frame, det, detector, time_us)
        if det is None:
            return FrameAnswer(b"", CameraFrame(time_us, rpy, rendered=True), shown)  # type: ignore[arg-type]
        st.detections += 1
        st.max_range_m = max(st.max_range_m, det.distance_m)
        st.count_markers(det)
        err = float(np.linalg.norm(target_offset(det, mount, q_ned_frd).frd_m - self._truth_frd(data)))
        st.pose_err_sum_m += err
        st.pose_err_max_m = max(st.pose_err_max_m, err)
        msg = landing_target_message(det, mount, q_ned_frd, time_us, frame=mavlink.MAV_FRAME_BODY_FRD)
        packed = msg.pack(self.mav)
        self.mav.seq = (self.mav.seq + 1) % 256
        ids = tuple(int(i) for i in det.marker_ids)
        return FrameAnswer(packed, CameraFrame(time_us, rpy, rendered=True, marker_ids=ids), shown)  # type: ignore[arg-type]

    def _could_show(self, view: MarkerView, data: mujoco.MjData) -> bool:
        """Whether the frame rendered from ``data`` could show a marker the detector finds: some marker in view;
        with the fast camera (``SIM_CAM_RENDER`` 1) also one whole and large enough to decode (issue 38: the frames
        it skips more are a quarter of a landing's renders, none with a marker found; ``SIM_CAM_RENDER`` 0 renders
        them all, as before)."""
        if int(self.settings.render) == RENDER_FAST:
            return view.detectable(data)  # (a marker it can find is in view: the one test is enough)
        return not view.out_of_view(data)

    def pose_of(self, data: mujoco.MjData) -> CameraPose:
        """The camera's pose in the state a frame is rendered from (a photo's geotag and attitude)."""
        return camera_pose(data, self._camera_id, self.media.home if self.media is not None else (0.0, 0.0, 0.0))

    def _mount_at_capture(self, fixed: CameraMount, joints: tuple[float, float, float] | None) -> CameraMount:
        """The camera's mount at the frame's capture: the fixed one, or on a gimbal the rotation its encoders
        read in the state copy the frame was rendered from (``joints``: :meth:`_joints`)."""
        if joints is None:
            return fixed
        return CameraMount(fixed.position_frd_m, np.array(camera_to_body(joints)))  # type: ignore[arg-type]

    def _joints(self, data: mujoco.MjData) -> tuple[float, float, float] | None:
        """The gimbal's joint angles (yaw, roll, pitch; rad) in the state copy the frame is rendered from (a gimbal
        reports its angles at a high rate, and the companion stamps them as it stamps the frame); None for a fixed
        camera."""
        if self._gimbal_qadr is None:
            return None
        return tuple(float(data.qpos[a]) for a in self._gimbal_qadr)  # type: ignore[return-value]

    def _truth_frd(self, data: mujoco.MjData) -> np.ndarray:
        """The marker's centre from the vehicle's centre of mass along body FRD axes, from the state copy."""
        veh = self._body
        deck_enu = deck_centre_enu(self.model, data, self.ugv)
        flu = data.xmat[veh].reshape(3, 3).T @ (deck_enu - data.xpos[veh])
        return np.array([flu[0], -flu[1], -flu[2]])

    def _save(self, frame: np.ndarray, det, detector: MarkerDetector, time_us: int) -> None:
        import cv2

        from vision.annotate import annotate

        self.save_dir.mkdir(parents=True, exist_ok=True)
        cv2.imwrite(str(self.save_dir / f"frame_{time_us // 1000:08d}ms.png"), annotate(frame, det, detector.camera))


def _attitude(data: mujoco.MjData, qadr: int = 0) -> np.ndarray:
    """The vehicle's attitude (w, x, y, z), FRD -> NED, at capture (its free joint's quaternion; ``qadr`` the joint's
    first qpos address)."""
    from mavsim_core.frames import quat_enu_flu_to_ned_frd

    return quat_enu_flu_to_ned_frd(np.array(data.qpos[qadr + 3 : qadr + 7]))
