"""The simulator's MAVLink camera (sitl/camera_component.py, camera_media.py, camera_messages.py) over loopback UDP.

A pymavlink socket on the payload link's port plays the flight controller; the test plays the vision companion's
worker, handing frames to the media with their pose, and steps the component in simulated time.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import cv2
import numpy as np
import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from mavsim_core import ports  # noqa: E402
from mavsim_core.geodesy import ned_to_geodetic  # noqa: E402
from mavsim_core.quaternion import from_euler  # noqa: E402
from params.vehicle import CameraSpec  # noqa: E402
from sitl.camera_component import CameraComponent  # noqa: E402
from sitl.camera_media import CameraMedia, CameraPose  # noqa: E402

HOME = (47.397742, 8.545594, 488.0)
SPEC = CameraSpec(rate_hz=20.0, width_px=160, height_px=120, hfov_deg=90.0, mount="gimbal")
POSE = CameraPose(np.array([10.0, -20.0, -5.0]), from_euler(0.0, math.radians(-90.0), 0.3), HOME)
STEP_US = 4000


class Rig:
    """The component, its media, the flight controller's side and simulated time."""

    def __init__(self, inst: int, media_dir: Path) -> None:
        self.fc = mavutil.mavlink_connection(
            f"udpin:127.0.0.1:{ports.payload_local_port(inst)}", source_system=1, source_component=1, dialect="common"
        )
        self.media = CameraMedia(SPEC.width_px, SPEC.height_px, SPEC.rate_hz, media_dir, home=HOME)
        self.cam = CameraComponent(
            self.media, SPEC, 1, ("127.0.0.1", ports.camera_port(inst)), ("127.0.0.1", ports.payload_local_port(inst)),
            f"udp://127.0.0.1:{ports.video_port(inst)}", 20.0, 2000, lambda: POSE,
        )  # fmt: skip
        self.t_us = 0
        self.frame = np.zeros((SPEC.height_px, SPEC.width_px, 3), np.uint8)
        cv2.rectangle(self.frame, (40, 30), (120, 90), (255, 255, 255), -1)
        self.run(0.1)  # the camera's HEARTBEAT: the flight controller's side knows its address

    def run(self, sim_s: float) -> list:
        """Step for ``sim_s`` simulated seconds, a frame every 100 ms (as the companion hands them); the messages."""
        out = []
        for _ in range(round(sim_s * 1e6 / STEP_US)):
            if self.t_us % 100_000 == 0 and self.media.wants(self.t_us):
                self.media.frame(self.frame, self.t_us, POSE)
            self.cam.step(self.t_us)
            self.t_us += STEP_US
            while (m := self.fc.recv_match(blocking=False)) is not None:
                out.append(m)
        return out

    def command(self, command: int, *params: float, component: int = 100, confirmation: int = 0) -> list:
        p = list(params) + [0.0] * (7 - len(params))
        self.fc.mav.command_long_send(1, component, command, confirmation, *p)
        return self.run(0.1)

    def close(self) -> None:
        self.cam.close()
        self.fc.close()


@pytest.fixture
def rig(free_instance, tmp_path):
    r = Rig(free_instance(), tmp_path / "media")
    yield r
    r.close()


def _acks(msgs, command):
    return [m.result for m in msgs if m.get_type() == "COMMAND_ACK" and m.command == command]


def _of(msgs, mtype):
    return [m for m in msgs if m.get_type() == mtype]


def test_heartbeat_and_the_camera_information_on_request(rig):
    got = rig.run(1.1)
    beats = _of(got, "HEARTBEAT")
    assert beats and all(m.type == mavlink.MAV_TYPE_CAMERA and m.get_srcComponent() == 100 for m in beats)
    got = rig.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_CAMERA_INFORMATION)
    assert _acks(got, mavlink.MAV_CMD_REQUEST_MESSAGE) == [mavlink.MAV_RESULT_ACCEPTED]
    (info,) = _of(got, "CAMERA_INFORMATION")
    assert len(_of(got, "VIDEO_STREAM_INFORMATION")) == 1  # the stream's next, unasked (MAVSDK asks every 20 s)
    assert (info.resolution_h, info.resolution_v) == (160, 120)
    assert (
        info.flags & mavlink.CAMERA_CAP_FLAGS_HAS_VIDEO_STREAM and info.flags & mavlink.CAMERA_CAP_FLAGS_CAPTURE_IMAGE
    )
    got = rig.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_VIDEO_STREAM_INFORMATION)
    (vsi,) = _of(got, "VIDEO_STREAM_INFORMATION")
    assert vsi.type == mavlink.VIDEO_STREAM_TYPE_RTPUDP and vsi.uri.startswith("udp://127.0.0.1:56")
    got = rig.command(mavlink.MAV_CMD_REQUEST_CAMERA_INFORMATION, 1)  # the older request command
    assert _acks(got, mavlink.MAV_CMD_REQUEST_CAMERA_INFORMATION) == [mavlink.MAV_RESULT_ACCEPTED]
    assert len(_of(got, "CAMERA_INFORMATION")) == 1
    got = rig.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
    assert _acks(got, mavlink.MAV_CMD_REQUEST_MESSAGE) == [mavlink.MAV_RESULT_UNSUPPORTED]


def test_a_photo_is_a_jpeg_with_its_geotag_once_per_sequence_number(rig):
    got = rig.command(mavlink.MAV_CMD_IMAGE_START_CAPTURE, 0, 0, 1, 7)
    got += rig.run(0.2)
    assert _acks(got, mavlink.MAV_CMD_IMAGE_START_CAPTURE) == [mavlink.MAV_RESULT_ACCEPTED]
    (cap,) = _of(got, "CAMERA_IMAGE_CAPTURED")
    lat, lon, alt = ned_to_geodetic(POSE.pos_ned_m, *HOME)
    assert (cap.lat, cap.lon, cap.alt, cap.relative_alt) == (round(lat * 1e7), round(lon * 1e7), 493000, 5000)
    assert cap.capture_result == 1 and cap.image_index == 0
    assert np.allclose(cap.q, POSE.q_ned_cam, atol=1e-6)
    image = cv2.imread(cap.file_url.removeprefix("file://"))
    assert image is not None and image.shape == (120, 160, 3) and image[60, 80].mean() > 200
    # The same command resent (confirmation 1: its ACK was lost): no second photo.  The same sequence number in a
    # new command (confirmation 0: another client, or one restarted, counts from 1 again): a second photo.
    got = rig.command(mavlink.MAV_CMD_IMAGE_START_CAPTURE, 0, 0, 1, 7, confirmation=1) + rig.run(0.2)
    assert _acks(got, mavlink.MAV_CMD_IMAGE_START_CAPTURE) == [mavlink.MAV_RESULT_ACCEPTED]
    assert _of(got, "CAMERA_IMAGE_CAPTURED") == []
    got = rig.command(mavlink.MAV_CMD_IMAGE_START_CAPTURE, 0, 0, 1, 7) + rig.run(0.2)
    assert [m.image_index for m in _of(got, "CAMERA_IMAGE_CAPTURED")] == [1]
    got = rig.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_CAMERA_IMAGE_CAPTURED, 0)
    assert [m.image_index for m in _of(got, "CAMERA_IMAGE_CAPTURED")] == [0]  # asked for again, by index


def test_photos_at_an_interval_until_stopped(rig):
    rig.command(mavlink.MAV_CMD_IMAGE_START_CAPTURE, 0, 0.2, 0, 0)
    got = rig.run(1.0)
    status = _of(
        rig.command(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_CAMERA_CAPTURE_STATUS),
        "CAMERA_CAPTURE_STATUS",
    )
    rig.command(mavlink.MAV_CMD_IMAGE_STOP_CAPTURE)
    after = rig.run(0.5)
    indices = [m.image_index for m in _of(got, "CAMERA_IMAGE_CAPTURED")]
    assert indices == list(range(len(indices))) and 5 <= len(indices) <= 6, indices  # 0.2 s apart over 1 s
    assert status[0].image_interval == pytest.approx(0.2) and status[0].image_status == 3
    assert _of(after, "CAMERA_IMAGE_CAPTURED") == []


def test_bad_input_is_denied_with_a_reason_and_a_failed_write_goes_on(rig, tmp_path):
    for params in ((0, -1, 0, 0), (0, 0, 3, 0), (0, math.nan, 1, 0)):
        got = rig.command(mavlink.MAV_CMD_IMAGE_START_CAPTURE, *params)
        assert _acks(got, mavlink.MAV_CMD_IMAGE_START_CAPTURE) == [mavlink.MAV_RESULT_DENIED], params
        assert any(t.text.startswith("Camera: ") for t in _of(got, "STATUSTEXT")), params
    got = rig.command(mavlink.MAV_CMD_SET_CAMERA_MODE, 0, 5)
    assert _acks(got, mavlink.MAV_CMD_SET_CAMERA_MODE) == [mavlink.MAV_RESULT_DENIED]
    got = rig.command(mavlink.MAV_CMD_DO_DIGICAM_CONTROL, 1)
    assert _acks(got, mavlink.MAV_CMD_DO_DIGICAM_CONTROL) == [mavlink.MAV_RESULT_UNSUPPORTED]
    got = rig.command(mavlink.MAV_CMD_DO_LAND_START, component=0)  # a broadcast for the autopilot (MAVProxy's land)
    assert _acks(got, mavlink.MAV_CMD_DO_LAND_START) == []
    blocker = tmp_path / "not_a_dir"
    blocker.write_text("a file where the media directory should be")
    rig.media.media_dir = blocker / "media"  # every write fails (as on a full disk)
    got = rig.command(mavlink.MAV_CMD_IMAGE_START_CAPTURE, 0, 0, 1, 9) + rig.run(0.2)
    (cap,) = _of(got, "CAMERA_IMAGE_CAPTURED")
    assert cap.capture_result == 0 and cap.file_url == ""
    assert any("not saved" in t.text for t in _of(got, "STATUSTEXT"))
    rig.media.media_dir = tmp_path / "media2"  # the camera goes on
    got = rig.command(mavlink.MAV_CMD_IMAGE_START_CAPTURE, 0, 0, 1, 10) + rig.run(0.2)
    assert [m.capture_result for m in _of(got, "CAMERA_IMAGE_CAPTURED")] == [1]


def test_a_recording_is_an_mp4_of_the_simulated_time_and_a_failed_one_says_why(rig, tmp_path):
    import av

    got = rig.command(mavlink.MAV_CMD_VIDEO_START_CAPTURE, 0, 2)  # CAMERA_CAPTURE_STATUS at 2 Hz while recording
    assert _acks(got, mavlink.MAV_CMD_VIDEO_START_CAPTURE) == [mavlink.MAV_RESULT_ACCEPTED]
    got = rig.run(1.0)
    recording = [m for m in _of(got, "CAMERA_CAPTURE_STATUS") if m.video_status == 1]
    assert 2 <= len(recording) <= 3 and max(m.recording_time_ms for m in recording) >= 500
    got = rig.command(mavlink.MAV_CMD_VIDEO_STOP_CAPTURE, 0)
    assert _acks(got, mavlink.MAV_CMD_VIDEO_STOP_CAPTURE) == [mavlink.MAV_RESULT_ACCEPTED]
    (video,) = rig.media.media_dir.glob("VID_*.mp4")
    with av.open(str(video)) as f:
        frames = sum(1 for _ in f.decode(video=0))
    assert frames == 11, frames  # every frame handed over from the start to the stop: 1.1 s, one each 100 ms
    blocker = tmp_path / "not_a_dir"
    blocker.write_text("a file where the media directory should be")
    rig.media.media_dir = blocker / "media"
    rig.command(mavlink.MAV_CMD_VIDEO_START_CAPTURE, 0, 0)
    got = rig.run(0.2)
    assert any("recording not started" in t.text for t in _of(got, "STATUSTEXT")), [t.text for t in got]
    assert not rig.media.recording  # and a new recording may start
    rig.media.media_dir = tmp_path / "media2"
    got = rig.command(mavlink.MAV_CMD_VIDEO_START_CAPTURE, 0, 0)
    assert _acks(got, mavlink.MAV_CMD_VIDEO_START_CAPTURE) == [mavlink.MAV_RESULT_ACCEPTED]


def test_fov_status_puts_the_image_centre_where_the_optical_axis_meets_the_ground():
    """CAMERA_FOV_STATUS from the camera's pose: straight down from 5 m the centre is below it; pitched to -45 deg
    and turned East it is 5 m East; level, it never meets the ground (INT32_MAX)."""
    from sitl.camera_messages import NO_POSITION, CameraDescription, camera_messages

    desc = CameraDescription(SPEC, "udp://127.0.0.1:5600", 20.0, 2000)
    msgs = camera_messages(desc, 1_000_000, 0, True, False, None, 0.0, 0, 100.0)
    above = np.array([0.0, 0.0, -5.0])
    cases = (
        (from_euler(0.0, math.radians(-90.0), 0.0), (0.0, 0.0)),
        (from_euler(0.0, math.radians(-45.0), math.radians(90.0)), (0.0, 5.0)),
    )
    for q, (north, east) in cases:
        fov = msgs.fov_status(CameraPose(above, q, HOME))
        lat, lon, _ = ned_to_geodetic(np.array([north, east, 0.0]), *HOME)
        assert abs(fov.lat_image - lat * 1e7) <= 1 and abs(fov.lon_image - lon * 1e7) <= 1, (north, east, fov)
        assert fov.alt_camera == 493000 and fov.hfov == 90.0
    level = msgs.fov_status(CameraPose(above, from_euler(0.0, 0.0, 0.0), HOME))
    assert level.lat_image == level.lon_image == NO_POSITION
