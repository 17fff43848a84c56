"""The camera protocol's messages, built from what the camera is and what it is doing now (pure functions).

[MAV] common.xml: CAMERA_INFORMATION (#259), CAMERA_SETTINGS (#260), STORAGE_INFORMATION (#261),
CAMERA_CAPTURE_STATUS (#262), VIDEO_STREAM_INFORMATION (#269), VIDEO_STREAM_STATUS (#270),
CAMERA_FOV_STATUS (#271).  Units at this edge are MAVLink's: ms, mm, MiB, degE7, bits/s, degrees.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from pymavlink.dialects.v20 import common as mavlink

from mavsim_core import quaternion
from mavsim_core.geodesy import ned_to_geodetic
from params.vehicle import CameraSpec
from sitl.camera_media import CameraPose

VENDOR = b"mavsim"
SENSOR_WIDTH_MM = 6.17  # a 1/2.3" sensor, the usual small drone camera's; its height follows the aspect ratio
NO_POSITION = 2**31 - 1  # INT32_MAX: CAMERA_FOV_STATUS's "no intersection with the ground"
CAP_FLAGS = (
    mavlink.CAMERA_CAP_FLAGS_CAPTURE_VIDEO
    | mavlink.CAMERA_CAP_FLAGS_CAPTURE_IMAGE
    | mavlink.CAMERA_CAP_FLAGS_HAS_MODES
    | mavlink.CAMERA_CAP_FLAGS_CAN_CAPTURE_IMAGE_IN_VIDEO_MODE
    | mavlink.CAMERA_CAP_FLAGS_CAN_CAPTURE_VIDEO_IN_IMAGE_MODE
    | mavlink.CAMERA_CAP_FLAGS_HAS_VIDEO_STREAM
)


@dataclass(frozen=True)
class CameraDescription:
    """What does not change: the vehicle file's [camera], the stream's address, frame rate (Hz) and bit rate."""

    spec: CameraSpec
    video_uri: str
    stream_fps: float
    stream_kbps: int

    @property
    def vfov_deg(self) -> float:
        s = self.spec
        return math.degrees(2 * math.atan(math.tan(math.radians(s.hfov_deg) / 2) * s.height_px / s.width_px))

    @staticmethod
    def time_boot_ms(time_us: int) -> int:
        return int(time_us // 1000) & 0xFFFFFFFF


@dataclass(frozen=True)
class camera_messages:  # noqa: N801 (a builder named for what it gives)
    """The messages at one moment: simulated time (µs), mode, stream on, recording (since when), photos' interval
    (s), photos taken and the free space (MiB)."""

    desc: CameraDescription
    now_us: int
    mode: int
    streaming: bool
    recording: bool
    recording_since_us: int | None
    photo_interval_s: float
    image_count: int
    free_mib: float

    def by_id(self) -> dict[int, Callable[[], mavlink.MAVLink_message]]:
        """Message id -> its builder, for MAV_CMD_REQUEST_MESSAGE."""
        return {
            mavlink.MAVLINK_MSG_ID_CAMERA_INFORMATION: self.information,
            mavlink.MAVLINK_MSG_ID_CAMERA_SETTINGS: self.settings,
            mavlink.MAVLINK_MSG_ID_STORAGE_INFORMATION: self.storage,
            mavlink.MAVLINK_MSG_ID_CAMERA_CAPTURE_STATUS: self.capture_status,
            mavlink.MAVLINK_MSG_ID_VIDEO_STREAM_INFORMATION: self.stream_information,
            mavlink.MAVLINK_MSG_ID_VIDEO_STREAM_STATUS: self.stream_status,
        }

    @property
    def _ms(self) -> int:
        return self.desc.time_boot_ms(self.now_us)

    def information(self) -> mavlink.MAVLink_camera_information_message:
        s = self.desc.spec
        focal_mm = SENSOR_WIDTH_MM / 2 / math.tan(math.radians(s.hfov_deg) / 2)
        model = f"SITL {'gimballed' if s.gimballed else 'fixed'} {s.width_px}x{s.height_px}".encode()
        return mavlink.MAVLink_camera_information_message(
            self._ms, VENDOR.ljust(32, b"\0"), model[:32].ljust(32, b"\0"), 1, focal_mm, SENSOR_WIDTH_MM,
            SENSOR_WIDTH_MM * s.height_px / s.width_px, s.width_px, s.height_px, 0, CAP_FLAGS, 0, b"", 0, 0,
        )  # fmt: skip

    def settings(self) -> mavlink.MAVLink_camera_settings_message:
        return mavlink.MAVLink_camera_settings_message(self._ms, self.mode, float("nan"), float("nan"), 0)

    def storage(self) -> mavlink.MAVLink_storage_information_message:
        free = float(self.free_mib)
        return mavlink.MAVLink_storage_information_message(
            self._ms, 1, 1, mavlink.STORAGE_STATUS_READY, free, 0.0, free, float("nan"), float("nan"),
            mavlink.STORAGE_TYPE_OTHER, b"media", mavlink.STORAGE_USAGE_FLAG_SET | mavlink.STORAGE_USAGE_FLAG_PHOTO
            | mavlink.STORAGE_USAGE_FLAG_VIDEO,
        )  # fmt: skip

    def capture_status(self) -> mavlink.MAVLink_camera_capture_status_message:
        interval = self.photo_interval_s
        image_status = 3 if interval > 0 else 0  # 3: an interval set and capturing; 0: idle
        since = self.recording_since_us
        rec_ms = int((self.now_us - since) // 1000) if self.recording and since is not None else 0
        return mavlink.MAVLink_camera_capture_status_message(
            self._ms, image_status, int(self.recording), interval, rec_ms, float(self.free_mib), self.image_count, 0
        )

    def stream_information(self) -> mavlink.MAVLink_video_stream_information_message:
        d, s = self.desc, self.desc.spec
        return mavlink.MAVLink_video_stream_information_message(
            1, 1, mavlink.VIDEO_STREAM_TYPE_RTPUDP, self._stream_flags(), d.stream_fps, s.width_px, s.height_px,
            d.stream_kbps * 1000, 0, round(s.hfov_deg), b"camera", d.video_uri.encode(),
            mavlink.VIDEO_STREAM_ENCODING_H264, 0,
        )  # fmt: skip

    def stream_status(self) -> mavlink.MAVLink_video_stream_status_message:
        d, s = self.desc, self.desc.spec
        bits_s, hfov = d.stream_kbps * 1000, round(s.hfov_deg)
        return mavlink.MAVLink_video_stream_status_message(
            1, self._stream_flags(), d.stream_fps, s.width_px, s.height_px, bits_s, 0, hfov, 0
        )

    def _stream_flags(self) -> int:
        return mavlink.VIDEO_STREAM_STATUS_FLAGS_RUNNING if self.streaming else 0

    def fov_status(self, pose: CameraPose) -> mavlink.MAVLink_camera_fov_status_message:
        """Where the camera is and where the centre of its image meets the ground (flat, at the start point's
        height; INT32_MAX when the optical axis points at or above the horizon), its attitude and field of view."""
        lat, lon, alt = ned_to_geodetic(pose.pos_ned_m, *pose.home)
        axis = quaternion.to_matrix(pose.q_ned_cam)[:, 0]  # the optical axis, NED
        lat_i = lon_i = NO_POSITION
        alt_i = float("nan")
        if axis[2] > 1e-3:
            ground = pose.pos_ned_m + axis * (-pose.pos_ned_m[2] / axis[2])
            la, lo, alt_i = ned_to_geodetic(np.array([ground[0], ground[1], 0.0]), *pose.home)
            lat_i, lon_i = round(la * 1e7), round(lo * 1e7)
        return mavlink.MAVLink_camera_fov_status_message(
            self._ms, round(lat * 1e7), round(lon * 1e7), round(alt * 1000), lat_i, lon_i,
            round(alt_i * 1000) if math.isfinite(alt_i) else NO_POSITION, [float(v) for v in pose.q_ned_cam],
            float(self.desc.spec.hfov_deg), self.desc.vfov_deg, 0,
        )  # fmt: skip
