"""What the camera makes of its frames besides detections: the RTP video, photos and recordings.

The vision companion's worker thread (:mod:`sitl.companion`) hands each frame it renders to
:meth:`CameraMedia.frame`, with the camera's pose in the state copy the frame was rendered from and the marker's
detection in it (drawn on the streamed picture with ``SIM_VID_ANNOT`` 1); it asks
:meth:`CameraMedia.wants` first, so a frame that detection would skip (the pad wholly out of view) is
rendered anyway while the video streams, a recording runs or a photo waits.  The camera component
(:mod:`sitl.camera_component`, the lockstep thread) asks for photos and recordings and collects what came of
them with :meth:`CameraMedia.pop_results`; a lock keeps the two threads apart.

Everything is in simulated time: the stream's and the recording's timestamps are the frames' capture times,
a photo is the first frame captured at or after its due time.  Files go to ``media_dir`` (created when the
first file is written): ``IMG_<index>.jpg`` and ``VID_<n>.mp4``.  A write that fails (a full disk, a
directory that cannot be made) is a result with the OS's reason; the flight goes on.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Callable

import cv2
import numpy as np

if TYPE_CHECKING:
    from sitl.video_stream import Mp4Recorder, RtpVideoStream


@dataclass(frozen=True)
class CameraPose:
    """The camera at a frame's capture: position (m, NED from the vehicle's start point on the ground) and
    attitude (w, x, y, z; earth NED to the camera frame of gimbal protocol v2: x along the optical axis, y to the
    image's right, z to its bottom), and the vehicle's start point's geodetic position (deg, deg, m AMSL)."""

    pos_ned_m: np.ndarray
    q_ned_cam: np.ndarray
    home: tuple[float, float, float]


@dataclass(frozen=True)
class PhotoResult:
    """A photo taken (``path`` the JPEG) or not (``error`` why); its capture time (simulated µs) and pose."""

    index: int
    time_us: int
    pose: CameraPose
    path: Path | None
    error: str = ""


@dataclass(frozen=True)
class RecordingResult:
    """A recording ended (or failed: ``error``): its file, frames and simulated duration (s)."""

    path: Path
    frames: int
    duration_s: float
    error: str = ""


@dataclass
class _Photos:
    next_index: int  # the index of the next photo (CAMERA_IMAGE_CAPTURED.image_index)
    due_us: int  # capture the first frame at or after this time
    interval_us: int  # 0: one photo
    left: int  # photos still to take (0: until stopped)


class CameraMedia:
    """The camera's stream, photos and recordings (see the module docstring)."""

    def __init__(
        self,
        width_px: int,
        height_px: int,
        rate_hz: float,
        media_dir: Path,
        stream: RtpVideoStream | None = None,
        stream_fps: float | None = None,
        home: tuple[float, float, float] = (0.0, 0.0, 0.0),
    ) -> None:
        self.width_px, self.height_px, self.rate_hz = width_px, height_px, rate_hz
        self.media_dir = media_dir
        self.home = home  # the vehicle's start point (deg, deg, m AMSL): the photos' geotags are from it
        self.stream = stream
        self.streaming = stream is not None  # (MAV_CMD_VIDEO_STOP_STREAMING pauses it)
        # (rgb, the frame's detection or None) -> the picture streamed: the detection drawn (SIM_VID_ANNOT 1)
        self.annotate: Callable[[np.ndarray, object], np.ndarray] | None = None
        self._stream_period_us = round(1e6 / (stream_fps or rate_hz))
        self._next_stream_us = 0
        self._lock = threading.RLock()
        self._photos: _Photos | None = None
        self._image_count = 0  # photos taken so far (the next index without a sequence number given)
        self._recorder: Mp4Recorder | None = None
        self._recording_path: Path | None = None
        self._results: list[PhotoResult | RecordingResult] = []
        self._videos = 0
        self.recording_started_us: int | None = None
        self.last_time_us = 0
        self.failed = False  # an unexpected error stopped everything here (see frame)

    # -- the lockstep thread (the camera component)
    def take_photos(self, now_us: int, interval_s: float, count: int, index: int | None) -> None:
        """Photos from the next frame on: ``count`` of them (0: until :meth:`stop_photos`), ``interval_s`` apart."""
        with self._lock:
            start = self._image_count if index is None else index
            interval_us = max(int(round(interval_s * 1e6)), 0)
            self._photos = _Photos(start, now_us, interval_us, count)

    def stop_photos(self) -> None:
        with self._lock:
            self._photos = None

    @property
    def photo_interval_s(self) -> float:
        """The interval of the photos being taken (s; 0: none, or one at a time)."""
        p = self._photos
        return 0.0 if p is None or p.interval_us == 0 else p.interval_us * 1e-6

    @property
    def image_count(self) -> int:
        return self._image_count

    @property
    def recording(self) -> bool:
        return self._recording_path is not None

    def start_recording(self, now_us: int) -> Path:
        """A recording from the next frame on, into a new MP4 in the media directory; its path."""
        with self._lock:
            if self._recording_path is not None:
                return self._recording_path
            self._videos += 1
            self._recording_path = self.media_dir / f"VID_{self._videos:04d}.mp4"
            self.recording_started_us = now_us
            return self._recording_path

    def stop_recording(self) -> None:
        """End the recording (its result comes from :meth:`pop_results`).  The file is closed under the lock the
        worker holds while it adds a frame: closing FFmpeg's encoder in the middle of an ``add`` on the other
        thread crashed the simulator (SIGSEGV, a fresh clone's test run, 2026-12-05)."""
        with self._lock:
            path, self._recording_path = self._recording_path, None
            self.recording_started_us = None
            recorder, self._recorder = self._recorder, None
            if path is not None:
                self._report(self._close_recorder(path, recorder))

    def pop_results(self) -> list[PhotoResult | RecordingResult]:
        with self._lock:
            out, self._results = self._results, []
        return out

    # -- the worker thread (the vision companion)
    def wants(self, time_us: int) -> bool:
        """Whether the frame captured at ``time_us`` is wanted here (so it must be rendered)."""
        p = self._photos
        return not self.failed and (
            self.stream is not None
            and self.streaming
            and time_us >= self._next_stream_us
            or self._recording_path is not None
            or p is not None
            and time_us >= p.due_us
        )

    def frame(self, rgb: np.ndarray, time_us: int, pose: CameraPose, detection=None) -> None:
        """One rendered frame (RGB, uint8, height x width x 3) captured at ``time_us`` (simulated µs).  Nothing
        here may stop the flight: an unexpected error is reported once (a :class:`RecordingResult` naming it) and
        the video, photos and recordings stop."""
        if self.failed:
            return
        try:
            self._frame(rgb, time_us, pose, detection)
        except Exception as exc:
            self.failed = True
            self._report(RecordingResult(self.media_dir, 0, 0.0, f"video and photos stopped: {exc!r}"[:200]))

    def _frame(self, rgb: np.ndarray, time_us: int, pose: CameraPose, detection) -> None:
        self.last_time_us = time_us
        if self.stream is not None and self.streaming and time_us >= self._next_stream_us:
            self._next_stream_us = max(self._next_stream_us + self._stream_period_us, time_us + 1)
            self.stream.send(rgb if self.annotate is None else self.annotate(rgb, detection), time_us)
        with self._lock:
            photo = self._due_photo(time_us)
        if photo is not None:
            self._report(self._save_photo(rgb, photo, time_us, pose))
        with self._lock:  # (the recorder is opened, fed and closed under the lock: see stop_recording)
            path = self._recording_path
            if path is not None and self._recorder is None:
                self._recorder = self._open_recorder(path)
            recorder = self._recorder
            if recorder is not None and path is not None:
                from sitl.video_stream import VideoWriteError

                try:
                    recorder.add(rgb, time_us)
                except VideoWriteError as exc:  # (a full disk): reported now, the recording ends
                    self._recorder = self._recording_path = self.recording_started_us = None
                    self._report(RecordingResult(path, 0, 0.0, f"recording failed: {exc}"))

    def _report(self, result: PhotoResult | RecordingResult) -> None:
        with self._lock:
            self._results.append(result)

    def _due_photo(self, time_us: int) -> int | None:
        """The index of a photo due at ``time_us`` (the schedule moved on), or None (under the lock)."""
        p = self._photos
        if p is None or time_us < p.due_us:
            return None
        index = p.next_index
        p.next_index += 1
        self._image_count = max(self._image_count, p.next_index)
        if p.left == 1 or p.interval_us == 0:
            self._photos = None
        else:
            p.left = max(p.left - 1, 0)
            p.due_us += p.interval_us
        return index

    def _save_photo(self, rgb: np.ndarray, index: int, time_us: int, pose: CameraPose) -> PhotoResult:
        path = self.media_dir / f"IMG_{index:04d}.jpg"
        try:
            ok, jpeg = cv2.imencode(".jpg", cv2.cvtColor(rgb, cv2.COLOR_RGB2BGR), (cv2.IMWRITE_JPEG_QUALITY, 90))
            if not ok:
                raise OSError("the JPEG encoder failed")
            self.media_dir.mkdir(parents=True, exist_ok=True)
            path.write_bytes(jpeg.tobytes())
        except OSError as exc:
            return PhotoResult(index, time_us, pose, None, f"photo {index} not saved: {exc.strerror or exc}")
        return PhotoResult(index, time_us, pose, path)

    def _open_recorder(self, path: Path) -> Mp4Recorder | None:
        from sitl.video_stream import Mp4Recorder, VideoWriteError

        try:
            path.parent.mkdir(parents=True, exist_ok=True)
            return Mp4Recorder(path, self.width_px, self.height_px, self.rate_hz)
        except (OSError, VideoWriteError) as exc:
            self._report(RecordingResult(path, 0, 0.0, f"recording not started: {exc}"))
            self._recording_path = self.recording_started_us = None
            return None

    def _close_recorder(self, path: Path, recorder: Mp4Recorder | None) -> RecordingResult:
        if recorder is None:
            return RecordingResult(path, 0, 0.0, "recording ended before a frame came")
        from sitl.video_stream import VideoWriteError

        try:
            frames, duration_s = recorder.close()
        except VideoWriteError as exc:
            return RecordingResult(path, 0, 0.0, f"recording failed: {exc}")
        return RecordingResult(path, frames, duration_s)

    def close(self) -> None:
        self.stop_recording()
        if self.stream is not None:
            self.stream.close()


# The camera frame of gimbal protocol v2 (x along the optical axis, y image right, z image bottom) in MuJoCo's
# camera frame (x right, y up, looking along -z): its columns.
_MJ_CAM_TO_GIMBAL = np.array([[0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [-1.0, 0.0, 0.0]])
_ENU_TO_NED = np.array([[0.0, 1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, -1.0]])


def camera_pose(data, camera_id: int, home: tuple[float, float, float]) -> CameraPose:
    """The pose of MuJoCo camera ``camera_id`` in ``data`` (vehicle 0's world: the origin is its start point on the
    ground, ENU), as :class:`CameraPose`."""
    from mavsim_core import quaternion

    pos_ned = _ENU_TO_NED @ np.asarray(data.cam_xpos[camera_id], dtype=float)
    r_enu_mj = np.asarray(data.cam_xmat[camera_id], dtype=float).reshape(3, 3)
    r_ned_cam = _ENU_TO_NED @ r_enu_mj @ _MJ_CAM_TO_GIMBAL
    return CameraPose(pos_ned, quaternion.from_matrix(r_ned_cam), home)
