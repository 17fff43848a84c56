"""The simulated camera as a MAVLink camera (component 100), on the flight controller's onboard payload link.

As PX4's simulated cameras present themselves: a component of the vehicle's system (1+N) with id 100
(MAV_COMP_ID_CAMERA) and its own HEARTBEAT (MAV_TYPE_CAMERA), talking UDP from 14030+N to the flight
controller's payload link 14280+N, which forwards it to the ground stations (:mod:`autopilot.mavlink.payload_link`).
It answers the camera protocol v2 ([MAV] common.xml) as PX4's camera manager does:

* MAV_CMD_REQUEST_MESSAGE (and the older REQUEST_CAMERA_* / REQUEST_VIDEO_STREAM_* / REQUEST_STORAGE_*
  commands) for CAMERA_INFORMATION, CAMERA_SETTINGS, STORAGE_INFORMATION, CAMERA_CAPTURE_STATUS,
  VIDEO_STREAM_INFORMATION (``udp://127.0.0.1:5600+N``, RTP H.264), VIDEO_STREAM_STATUS, CAMERA_FOV_STATUS
  and a CAMERA_IMAGE_CAPTURED again (param2 its index): MAV_RESULT_ACCEPTED, then the message;
* MAV_CMD_IMAGE_START_CAPTURE (param2 interval s, param3 count, 0 until stopped; param4 the sequence number
  of a single capture: a resent command does not take a second photo) and IMAGE_STOP_CAPTURE: each photo a
  JPEG, then CAMERA_IMAGE_CAPTURED with its geotag (the camera's true position at the frame's capture) and
  the camera's attitude (earth frame, the gimbal's when it has one);
* MAV_CMD_VIDEO_START_CAPTURE (param2: CAMERA_CAPTURE_STATUS per second while recording) / STOP: an MP4;
* MAV_CMD_VIDEO_START_STREAMING / STOP_STREAMING, MAV_CMD_SET_CAMERA_MODE (image 0, video 1).

Anything else addressed to it gets MAV_RESULT_UNSUPPORTED (a broadcast it does not know it leaves to
the others); parameters out of range MAV_RESULT_DENIED and a STATUSTEXT saying
which.  A photo or recording that cannot be written (a full disk) gets a STATUSTEXT and, for a photo,
CAMERA_IMAGE_CAPTURED with capture_result 0; the flight goes on.  Time is simulated (the lockstep's).
"""

from __future__ import annotations

import math
import shutil
from typing import Callable

from pymavlink.dialects.v20 import common as mavlink

from mavsim_core.geodesy import ned_to_geodetic
from mavsim_core.mavlink_udp import UdpEndpoint
from params.vehicle import CameraSpec
from sitl.camera_media import CameraMedia, CameraPose, PhotoResult, RecordingResult
from sitl.camera_messages import CameraDescription, camera_messages

CAMERA_COMPID = mavlink.MAV_COMP_ID_CAMERA  # 100
HEARTBEAT_PERIOD_US = 1_000_000
POLL_PERIOD_US = 20_000  # the socket is read at 50 Hz of simulated time
_REQUEST_COMMANDS = {  # the older one-message requests -> the message they ask for
    mavlink.MAV_CMD_REQUEST_CAMERA_INFORMATION: mavlink.MAVLINK_MSG_ID_CAMERA_INFORMATION,
    mavlink.MAV_CMD_REQUEST_CAMERA_SETTINGS: mavlink.MAVLINK_MSG_ID_CAMERA_SETTINGS,
    mavlink.MAV_CMD_REQUEST_STORAGE_INFORMATION: mavlink.MAVLINK_MSG_ID_STORAGE_INFORMATION,
    mavlink.MAV_CMD_REQUEST_CAMERA_CAPTURE_STATUS: mavlink.MAVLINK_MSG_ID_CAMERA_CAPTURE_STATUS,
    mavlink.MAV_CMD_REQUEST_VIDEO_STREAM_INFORMATION: mavlink.MAVLINK_MSG_ID_VIDEO_STREAM_INFORMATION,
    mavlink.MAV_CMD_REQUEST_VIDEO_STREAM_STATUS: mavlink.MAVLINK_MSG_ID_VIDEO_STREAM_STATUS,
}


class CameraComponent:
    """The camera's MAVLink side (see the module docstring); :meth:`step` every lockstep period."""

    def __init__(
        self,
        media: CameraMedia,
        spec: CameraSpec,
        sysid: int,
        bind: tuple[str, int],
        dest: tuple[str, int],
        video_uri: str,
        stream_fps: float,
        stream_kbps: int,
        pose_now: Callable[[], CameraPose],
    ) -> None:
        self.media, self.sysid = media, sysid
        self.ep = UdpEndpoint("camera", bind, dest, sysid, CAMERA_COMPID)
        self.mav = mavlink.MAVLink(self, sysid, CAMERA_COMPID)
        self.desc = CameraDescription(spec, video_uri, stream_fps, stream_kbps)
        self.streaming = media.stream is not None
        self.mode = mavlink.CAMERA_MODE_IMAGE
        self._pose_now = pose_now
        self._now_us = 0
        self._next_poll_us = self._next_heartbeat_us = 0
        self._status_period_us = 0  # CAMERA_CAPTURE_STATUS while recording (VIDEO_START_CAPTURE param2)
        self._next_status_us = 0
        self._last_sequence: tuple = ()  # (sender, IMAGE_START_CAPTURE param4) of the last single capture
        self._resent, self._sender = False, (0, 0)  # the command being handled: resent? from whom?
        self._captured: dict[int, mavlink.MAVLink_camera_image_captured_message] = {}  # index -> its message
        self._handlers: dict[int, Callable[[tuple], int]] = {
            mavlink.MAV_CMD_REQUEST_MESSAGE: self._request_message,
            mavlink.MAV_CMD_IMAGE_START_CAPTURE: self._start_capture,
            mavlink.MAV_CMD_IMAGE_STOP_CAPTURE: self._stop_capture,
            mavlink.MAV_CMD_VIDEO_START_CAPTURE: self._start_video,
            mavlink.MAV_CMD_VIDEO_STOP_CAPTURE: self._stop_video,
            mavlink.MAV_CMD_VIDEO_START_STREAMING: lambda p: self._streaming(p, True),
            mavlink.MAV_CMD_VIDEO_STOP_STREAMING: lambda p: self._streaming(p, False),
            mavlink.MAV_CMD_SET_CAMERA_MODE: self._set_mode,
        }
        self._handlers.update({cmd: self._old_request(mid) for cmd, mid in _REQUEST_COMMANDS.items()})

    def write(self, data: bytes) -> None:
        """The encoder's sink: one datagram per message to the flight controller's payload link."""
        self.ep.send_datagram(data)

    # -- the lockstep thread
    def step(self, time_us: int) -> None:
        """At simulated ``time_us``: heartbeat, what came from the payload link, the media's results."""
        self._now_us = time_us
        if time_us >= self._next_heartbeat_us:
            self._next_heartbeat_us = time_us + HEARTBEAT_PERIOD_US
            active = mavlink.MAV_STATE_ACTIVE
            self.mav.heartbeat_send(mavlink.MAV_TYPE_CAMERA, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, active)
        if time_us < self._next_poll_us:
            return
        self._next_poll_us = time_us + POLL_PERIOD_US
        while (got := self.ep.recv()) is not None:
            msgs, _ = self.ep.incoming(*got)
            for msg in msgs:
                self._handle(msg)
        for result in self.media.pop_results():
            self._report(result)
        if self.media.recording and self._status_period_us > 0 and time_us >= self._next_status_us:
            self._next_status_us = time_us + self._status_period_us
            self.mav.send(self._messages().capture_status())

    def _handle(self, msg: mavlink.MAVLink_message) -> None:
        if msg.get_type() not in ("COMMAND_LONG", "COMMAND_INT"):
            return
        if msg.target_system not in (0, self.sysid) or msg.target_component not in (0, CAMERA_COMPID):
            return
        if msg.get_type() == "COMMAND_LONG":
            params = (msg.param1, msg.param2, msg.param3, msg.param4, msg.param5, msg.param6, msg.param7)
        else:
            params = (msg.param1, msg.param2, msg.param3, msg.param4, msg.x, msg.y, msg.z)
        self._resent = getattr(msg, "confirmation", 0) > 0  # (COMMAND_LONG sent again, its ACK lost)
        self._sender = (msg.get_srcSystem(), msg.get_srcComponent())
        handler = self._handlers.get(msg.command)
        if handler is None and msg.target_component == 0:  # a broadcast not for a camera: the others answer it
            return
        result, after = mavlink.MAV_RESULT_UNSUPPORTED, None
        if handler is not None:
            result = handler(params)
            if isinstance(result, tuple):
                result, after = result
        src = (msg.get_srcSystem(), msg.get_srcComponent())
        self.mav.send(mavlink.MAVLink_command_ack_message(msg.command, result, 0, 0, *src))
        for m in after if isinstance(after, list) else [after] if after is not None else []:
            self.mav.send(m)

    def _statustext(self, severity: int, text: str) -> None:
        self.mav.statustext_send(severity, text[:50].encode())

    def _denied(self, text: str) -> int:
        self._statustext(mavlink.MAV_SEVERITY_WARNING, f"Camera: {text}")
        return mavlink.MAV_RESULT_DENIED

    # -- requests
    def _messages(self):
        m = self.media
        capacity = _free_mib(m.media_dir)
        return camera_messages(
            self.desc, self._now_us, self.mode, self.streaming, m.recording, m.recording_started_us,
            m.photo_interval_s, m.image_count, capacity,
        )  # fmt: skip

    def _request_message(self, p: tuple):
        msg_id = p[0]
        if not math.isfinite(msg_id):
            return self._denied("REQUEST_MESSAGE without a message id")
        msg_id = int(msg_id)
        if msg_id == mavlink.MAVLINK_MSG_ID_CAMERA_IMAGE_CAPTURED:
            captured = self._captured.get(int(p[1]) if math.isfinite(p[1]) else -1)
            return (mavlink.MAV_RESULT_ACCEPTED, captured) if captured else self._denied("no image of that index")
        if msg_id == mavlink.MAVLINK_MSG_ID_CAMERA_FOV_STATUS:
            return mavlink.MAV_RESULT_ACCEPTED, self._messages().fov_status(self._pose_now())
        if msg_id == mavlink.MAVLINK_MSG_ID_VIDEO_STREAM_INFORMATION and math.isfinite(p[1]) and p[1] not in (0, 1):
            return self._denied(f"no video stream {p[1]:g} (there is one, id 1)")
        build = self._messages().by_id().get(msg_id)
        if build is None:
            return mavlink.MAV_RESULT_UNSUPPORTED
        if msg_id == mavlink.MAVLINK_MSG_ID_CAMERA_INFORMATION:
            # the stream's next, unasked, as a client that finds the camera wants it next (MAVSDK asks for it only
            # every 20 s of its own; QGroundControl asks at once)
            return mavlink.MAV_RESULT_ACCEPTED, [build(), self._messages().stream_information()]
        return mavlink.MAV_RESULT_ACCEPTED, build()

    def _old_request(self, msg_id: int) -> Callable[[tuple], object]:
        """The older request commands: param1 1 "send it" (0: nothing to do); the video stream's take a stream id
        in param1 (0: all) and the storage's a storage id in param1 and "send it" in param2."""
        stream = msg_id in (mavlink.MAVLINK_MSG_ID_VIDEO_STREAM_INFORMATION, mavlink.MAVLINK_MSG_ID_VIDEO_STREAM_STATUS)
        storage = msg_id == mavlink.MAVLINK_MSG_ID_STORAGE_INFORMATION

        def request(p: tuple):
            if stream:
                return self._request_message((float(msg_id), p[0], *p[2:]))
            if (p[1] if storage else p[0]) == 0.0:
                return mavlink.MAV_RESULT_ACCEPTED
            return self._request_message((float(msg_id), *p[1:]))

        return request

    # -- capture
    def _start_capture(self, p: tuple) -> int:
        interval, count, sequence = p[1], p[2], p[3]
        if not (math.isfinite(interval) and math.isfinite(count)) or interval < 0 or count < 0:
            return self._denied(f"bad capture: interval {interval:g} s, count {count:g}")
        if count != 1 and interval <= 0:
            return self._denied("a series of photos needs an interval > 0 s")
        again = (self._sender, sequence) == self._last_sequence and self._resent and count == 1 and sequence > 0
        if again:  # the same command sent again (its ACK was lost): no second photo
            return mavlink.MAV_RESULT_ACCEPTED
        if count == 1:
            self._last_sequence = (self._sender, sequence)
        self.media.take_photos(self._now_us, interval, int(count), None)
        return mavlink.MAV_RESULT_ACCEPTED

    def _stop_capture(self, p: tuple) -> int:
        self.media.stop_photos()
        return mavlink.MAV_RESULT_ACCEPTED

    def _start_video(self, p: tuple) -> int:
        stream, hz = p[0], p[1]
        if stream not in (0.0, 1.0) or not math.isfinite(hz) or hz < 0:
            return self._denied(f"bad video capture: stream {stream:g}, status {hz:g} Hz")
        if self.media.recording:
            return mavlink.MAV_RESULT_TEMPORARILY_REJECTED
        path = self.media.start_recording(self._now_us)
        self._status_period_us = int(1e6 / hz) if hz > 0 else 0
        self._next_status_us = self._now_us
        self._statustext(mavlink.MAV_SEVERITY_INFO, f"Camera: recording {path.name}")
        return mavlink.MAV_RESULT_ACCEPTED

    def _stop_video(self, p: tuple) -> int:
        self.media.stop_recording()
        self._status_period_us = 0
        return mavlink.MAV_RESULT_ACCEPTED

    def _streaming(self, p: tuple, on: bool) -> int:
        if p[0] not in (0.0, 1.0):
            return self._denied(f"no video stream {p[0]:g} (there is one, id 1)")
        if on and self.media.stream is None:
            return self._denied("the video stream is off (SIM_VID_EN 0)")
        self.streaming = on
        self.media.streaming = on
        return mavlink.MAV_RESULT_ACCEPTED

    def _set_mode(self, p: tuple):
        if p[1] not in (float(mavlink.CAMERA_MODE_IMAGE), float(mavlink.CAMERA_MODE_VIDEO)):
            return self._denied(f"no camera mode {p[1]:g} (0 image, 1 video)")
        self.mode = int(p[1])
        return mavlink.MAV_RESULT_ACCEPTED, self._messages().settings()

    # -- results
    def _report(self, result: PhotoResult | RecordingResult) -> None:
        if isinstance(result, RecordingResult):
            if result.error:
                self._statustext(mavlink.MAV_SEVERITY_ERROR, f"Camera: {result.error}")
            else:
                self._statustext(mavlink.MAV_SEVERITY_INFO, f"Camera: {result.path.name} {result.duration_s:.1f} s")
            self.mav.send(self._messages().capture_status())
            return
        if result.error:
            self._statustext(mavlink.MAV_SEVERITY_ERROR, f"Camera: {result.error}")
        msg = image_captured(result, self.desc.time_boot_ms(result.time_us))
        self._captured[result.index] = msg
        self.mav.send(msg)

    def close(self) -> None:
        self.media.close()
        self.ep.close()


def image_captured(result: PhotoResult, time_boot_ms: int) -> mavlink.MAVLink_camera_image_captured_message:
    """CAMERA_IMAGE_CAPTURED for a photo: its geotag (degE7, mm AMSL and above the start point) and attitude."""
    pose = result.pose
    lat, lon, alt = ned_to_geodetic(pose.pos_ned_m, *pose.home)
    url = result.path.resolve().as_uri() if result.path is not None else ""
    return mavlink.MAVLink_camera_image_captured_message(
        time_boot_ms, 0, 1, round(lat * 1e7), round(lon * 1e7), round(alt * 1000), round(-pose.pos_ned_m[2] * 1000),
        [float(v) for v in pose.q_ned_cam], result.index, int(result.path is not None), url.encode()[:205],
    )  # fmt: skip


def _free_mib(directory) -> float:
    """Free space (MiB) where the media go (the nearest directory that exists)."""
    d = directory
    while not d.exists() and d != d.parent:
        d = d.parent
    try:
        return shutil.disk_usage(d).free / 2**20
    except OSError:
        return 0.0
