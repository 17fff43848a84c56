"""The vision package: the ArUco pad marker found and its pose recovered in synthetic camera frames,
LANDING_TARGET from a detection against hand-computed values, calibration files, annotation."""

from __future__ import annotations

import json
import math

import cv2
import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink

from mavsim_core import quaternion
from vision.annotate import annotate
from vision.camera_model import load_calibration, pinhole
from vision.detector import MarkerDetection, MarkerDetector
from vision.landing_target import DOWNWARD_CAMERA, landing_target_message, target_offset
from vision.marker import MARKER_BITS, MARKER_SIZE_M, marker_corners_3d, marker_image

CAMERA = pinhole(640, 480, math.radians(60.0))
PIXELS_PER_BIT = 40
LEVEL = (1.0, 0.0, 0.0, 0.0)


def _rot_x(a: float) -> np.ndarray:
    c, s = math.cos(a), math.sin(a)
    return np.array(((1.0, 0.0, 0.0), (0.0, c, -s), (0.0, s, c)))


def _pose(distance_m: float, tilt_deg: float, offset_m=(0.1, -0.05)) -> tuple[np.ndarray, np.ndarray]:
    """Marker lying face up under a downward camera (marker z towards the camera), tilted about
    the camera x axis; returns (rotation camera<-marker, marker centre in the camera frame)."""
    facing = np.diag((1.0, -1.0, -1.0))
    return _rot_x(math.radians(tilt_deg)) @ facing, np.array((offset_m[0], offset_m[1], distance_m))


def _render(rotation: np.ndarray, t: np.ndarray, marker_id: int = 76) -> np.ndarray:
    """The camera image of the marker (with its white border) on a grey background, by the plane's homography."""
    tex = marker_image(PIXELS_PER_BIT, quiet_bits=1, marker_id=marker_id)
    s = MARKER_SIZE_M / ((MARKER_BITS + 2) * PIXELS_PER_BIT)  # metres per texture pixel
    c = 0.5 * (tex.shape[0] - 1)  # texture centre, pixel centres at integers
    tex_to_marker = np.array(((s, 0.0, -s * c), (0.0, -s, s * c), (0.0, 0.0, 1.0)))
    plane = np.column_stack((rotation[:, 0], rotation[:, 1], t))
    h = CAMERA.matrix @ plane @ tex_to_marker
    return cv2.warpPerspective(tex, h, (CAMERA.width_px, CAMERA.height_px), flags=cv2.INTER_LINEAR, borderValue=128)


def test_marker_image_is_detected_as_id_76_with_corners_in_opencv_order():
    tex = marker_image(20, quiet_bits=1)
    assert tex.shape == (180, 180) and tex[0, 0] == 255 and tex[20, 20] == 0
    corners, ids, _ = cv2.aruco.ArucoDetector(
        cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_ARUCO_ORIGINAL)
    ).detectMarkers(tex)
    assert ids.ravel().tolist() == [76]
    tl, tr, br, bl = corners[0].reshape(4, 2)
    assert tl[0] < tr[0] and tl[1] < bl[1] and br[0] > bl[0]  # top-left, top-right, bottom-right, bottom-left
    obj = marker_corners_3d()
    assert obj[0, 0] < obj[1, 0] and obj[0, 1] > obj[3, 1]  # same order in the marker frame (y up)
    assert np.allclose(np.abs(obj[:, :2]), MARKER_SIZE_M / 2)


@pytest.mark.parametrize(
    "distance_m, tilt_deg",
    [(1.0, 0.0), (1.5, 20.0), (2.0, 10.0), (2.8, 0.0), (2.8, 30.0), (3.4, 0.0), (3.4, 20.0)],
)
def test_detector_recovers_the_rendered_pose(distance_m, tilt_deg):
    rotation, t = _pose(distance_m, tilt_deg)
    det = MarkerDetector(CAMERA).detect(_render(rotation, t))
    assert det is not None and det.marker_id == 76
    assert np.linalg.norm(det.position_cam_m - t) < 0.01 + 0.01 * distance_m  # 2 cm at 1 m, 4.4 cm at 3.4 m
    assert abs(det.distance_m - np.linalg.norm(t)) < 0.01 * distance_m
    assert det.angle_x_rad == pytest.approx(math.atan2(t[0], t[2]), abs=0.005)
    assert det.angle_y_rad == pytest.approx(math.atan2(t[1], t[2]), abs=0.005)
    angle_error = np.linalg.norm(cv2.Rodrigues(det.rotation_cam_marker @ rotation.T)[0])
    assert angle_error < math.radians(5.0)


def test_no_marker_and_other_ids_give_none():
    blank = np.full((CAMERA.height_px, CAMERA.width_px), 128, np.uint8)
    assert MarkerDetector(CAMERA).detect(blank) is None
    rotation, t = _pose(1.5, 0.0)
    other = _render(rotation, t, marker_id=77)
    assert MarkerDetector(CAMERA).detect(other) is None
    assert MarkerDetector(CAMERA, marker_id=77).detect(other) is not None  # the frame is fine, the id differs
    bgr = cv2.cvtColor(_render(rotation, t), cv2.COLOR_GRAY2BGR)
    assert MarkerDetector(CAMERA).detect(bgr) is not None  # colour frames too


def _detection(position_cam) -> MarkerDetection:
    t = np.asarray(position_cam, dtype=float)
    return MarkerDetection(
        marker_id=76,
        corners_px=np.zeros((4, 2)),
        position_cam_m=t,
        rotation_cam_marker=np.diag((1.0, -1.0, -1.0)),
        distance_m=float(np.linalg.norm(t)),
        angle_x_rad=math.atan2(t[0], t[2]),
        angle_y_rad=math.atan2(t[1], t[2]),
        size_m=MARKER_SIZE_M,
    )


def test_landing_target_level_vehicle():
    det = _detection((0.2, -0.1, 2.0))  # 0.2 m right in the image, 0.1 m up the image (forward), 2 m below
    off = target_offset(det, DOWNWARD_CAMERA, LEVEL)
    assert off.frd_m == pytest.approx((0.1, 0.2, 2.0))
    assert off.ned_m == pytest.approx((0.1, 0.2, 2.0))
    msg = landing_target_message(det, DOWNWARD_CAMERA, LEVEL, time_usec=1_500_000)
    assert msg.get_type() == "LANDING_TARGET" and msg.frame == mavlink.MAV_FRAME_LOCAL_NED
    assert (msg.x, msg.y, msg.z) == pytest.approx((0.1, 0.2, 2.0))
    assert msg.position_valid == 1 and msg.target_num == 76 and msg.time_usec == 1_500_000
    assert msg.type == mavlink.LANDING_TARGET_TYPE_VISION_FIDUCIAL
    assert msg.angle_x == pytest.approx(0.0996687) and msg.angle_y == pytest.approx(-0.0499584)
    assert msg.distance == pytest.approx(2.0124612)
    assert msg.size_x == pytest.approx(2 * math.atan(0.1665 / 2.0124612)) and msg.size_y == msg.size_x
    # the face-up marker, its top forward: marker x = east, y = north, z = up
    assert quaternion.to_matrix(msg.q) == pytest.approx(np.array(((0, 1, 0), (1, 0, 0), (0, 0, -1))), abs=1e-9)
    absolute = landing_target_message(det, DOWNWARD_CAMERA, LEVEL, 0, vehicle_position_ned_m=(5.0, -3.0, -2.0))
    assert (absolute.x, absolute.y, absolute.z) == pytest.approx((5.1, -2.8, 0.0))
    packed = mavlink.MAVLink(None).decode(bytearray(msg.pack(mavlink.MAVLink(None, srcSystem=1, srcComponent=197))))
    assert packed.x == pytest.approx(0.1) and packed.frame == mavlink.MAV_FRAME_LOCAL_NED


def test_landing_target_rolled_10_deg():
    det = _detection((0.2, -0.1, 2.0))
    q = quaternion.from_euler(math.radians(10.0), 0.0, 0.0)  # right side down
    body = landing_target_message(det, DOWNWARD_CAMERA, q, 0, frame=mavlink.MAV_FRAME_BODY_FRD)
    assert body.frame == mavlink.MAV_FRAME_BODY_FRD and (body.x, body.y, body.z) == pytest.approx((0.1, 0.2, 2.0))
    ned = landing_target_message(det, DOWNWARD_CAMERA, q, 0)
    # NED = Rx(10 deg) (0.1, 0.2, 2.0): y = 0.2 cos10 - 2 sin10, z = 0.2 sin10 + 2 cos10
    assert (ned.x, ned.y, ned.z) == pytest.approx((0.1, -0.1503348, 2.0043456), abs=1e-6)
    assert ned.angle_x == body.angle_x and ned.distance == body.distance  # camera-frame quantities
    with pytest.raises(ValueError):
        landing_target_message(det, DOWNWARD_CAMERA, q, 0, frame=mavlink.MAV_FRAME_GLOBAL)


def test_mount_offset_is_added_in_body_axes():
    from vision.landing_target import CameraMount

    mount = CameraMount(position_frd_m=(0.05, 0.0, 0.1))
    assert target_offset(_detection((0.0, 0.0, 1.0)), mount, LEVEL).frd_m == pytest.approx((0.05, 0.0, 1.1))


def test_pinhole_and_calibration_files(tmp_path):
    assert CAMERA.fx == pytest.approx(320.0 / math.tan(math.radians(30.0))) and CAMERA.fy == CAMERA.fx
    assert (CAMERA.cx, CAMERA.cy) == (319.5, 239.5) and CAMERA.horizontal_fov_rad == pytest.approx(math.radians(60))
    k = np.array(((600.0, 0.0, 330.0), (0.0, 610.0, 235.0), (0.0, 0.0, 1.0)))
    d = np.array((0.1, -0.2, 0.001, 0.002, 0.05))
    yml = tmp_path / "cam.yml"
    fs = cv2.FileStorage(str(yml), cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", 640)
    fs.write("image_height", 480)
    fs.write("camera_matrix", k)
    fs.write("dist_coeffs", d.reshape(1, 5))
    fs.release()
    js = tmp_path / "cam.json"
    js.write_text(
        json.dumps({"camera_matrix": k.tolist(), "dist_coeffs": d.tolist(), "image_width": 640, "image_height": 480})
    )
    for path in (yml, js):
        cam = load_calibration(path)
        assert (cam.width_px, cam.height_px, cam.fx, cam.fy, cam.cx, cam.cy) == (640, 480, 600.0, 610.0, 330.0, 235.0)
        assert cam.distortion == pytest.approx(tuple(d))
        assert np.allclose(cam.matrix, k)


def test_annotate_draws_on_a_copy_of_the_same_shape():
    rotation, t = _pose(1.5, 10.0)
    frame = _render(rotation, t)
    det = MarkerDetector(CAMERA).detect(frame)
    out = annotate(frame, det, CAMERA)
    assert out.shape == (*frame.shape, 3) and out.dtype == np.uint8
    assert np.any(out[:, :, 1] != out[:, :, 2])  # coloured drawing on a grey frame
    assert np.array_equal(frame, _render(rotation, t))  # the input is untouched
    assert annotate(frame, None, CAMERA).shape == out.shape
