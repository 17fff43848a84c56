"""The nested landing pad (vision.pad, issue 34 item 4): layouts that cannot be printed or seen are refused naming
the key; the detector's one pose from every marker seen, against the known pose, in synthesized frames of the pad
(the whole pad, the four large markers alone from afar, only the small inner marker from close by), and a lone
large marker's pose chosen by the expected up; the detector's dictionary of the pad's own markers finds them as all
of DICT_ARUCO_ORIGINAL does, corner for corner, beside another deck's markers."""

from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from vision.camera_model import pinhole
from vision.detector import MarkerDetector, expected_normal_cam
from vision.landing_target import CameraMount
from vision.marker import MARKER_BITS, dictionary
from vision.pad import NESTED_PAD, SINGLE_PAD, PadLayout, PadLayoutError, PadMarker, check_pad, vehicle_pad

CAMERA = pinhole(480, 360, math.radians(90.0))  # the vehicles' camera
TEXEL_M = 0.0005  # the synthesized pad's texture pixel: the markers' sizes and offsets whole pixels
DECK_M = 1.3


def _pad_texture(pad: PadLayout) -> np.ndarray:
    """The pad on a white deck of DECK_M, TEXEL_M a pixel (image right = pad x, image up = pad y)."""
    side = int(round(DECK_M / TEXEL_M))
    img = np.full((side, side), 255, np.uint8)
    for m in pad.markers:
        px = int(round(m.size_m / TEXEL_M))
        left, top = int(round(side / 2 + m.x_m / TEXEL_M - px / 2)), int(round(side / 2 - m.y_m / TEXEL_M - px / 2))
        img[top : top + px, left : left + px] = cv2.aruco.generateImageMarker(dictionary(), m.marker_id, px)
    return img


def _render(pad: PadLayout, rotation: np.ndarray, t: np.ndarray) -> np.ndarray:
    """The camera's image of the pad whose frame has ``rotation`` (camera <- pad) and centre ``t`` (camera, m)."""
    tex = _pad_texture(pad)
    c = 0.5 * tex.shape[0]  # the texture's centre (pixel edges at integers: the markers' placement above)
    to_pad = np.array(((TEXEL_M, 0.0, -TEXEL_M * (c - 0.5)), (0.0, -TEXEL_M, TEXEL_M * (c - 0.5)), (0.0, 0.0, 1.0)))
    h = CAMERA.matrix @ np.column_stack((rotation[:, 0], rotation[:, 1], t)) @ to_pad
    size = (CAMERA.width_px, CAMERA.height_px)
    return cv2.warpPerspective(tex, h, size, flags=cv2.INTER_LINEAR, borderValue=128)


def _facing_down(tilt_deg: float) -> np.ndarray:
    """Camera <- pad rotation of a pad face up under a downward camera, tilted about the camera's x axis."""
    a = math.radians(tilt_deg)
    tilt = np.array(((1.0, 0.0, 0.0), (0.0, math.cos(a), -math.sin(a)), (0.0, math.sin(a), math.cos(a))))
    return tilt @ np.diag((1.0, -1.0, -1.0))


def _close(found: np.ndarray, truth: np.ndarray) -> bool:
    """Within 1 cm + 1.5 % of the distance (the synthesized frames' interpolation biases the corners slightly)."""
    return float(np.linalg.norm(found - truth)) < 0.01 + 0.015 * float(np.linalg.norm(truth))


@pytest.mark.parametrize("distance_m, tilt_deg", [(0.9, 2.0), (1.0, 8.0), (0.95, -5.0)])
def test_one_pose_from_the_corners_of_every_marker(distance_m, tilt_deg):
    rot, t = _facing_down(tilt_deg), np.array((0.05, -0.03, distance_m))
    det = MarkerDetector(CAMERA, layout=NESTED_PAD).detect(_render(NESTED_PAD, rot, t))
    assert det is not None and det.marker_ids == tuple(m.marker_id for m in NESTED_PAD.markers)
    assert det.marker_id == 76 and det.corners_px.shape == (4 * len(NESTED_PAD.markers), 2)
    assert _close(det.position_cam_m, t)  # the pad's centre, not a marker's
    assert np.degrees(np.arccos(min(1.0, (np.trace(det.rotation_cam_marker.T @ rot) - 1) / 2))) < 3.0


def test_close_by_only_the_inner_marker_is_whole_in_view_and_the_pose_is_found_from_it():
    rot, t = _facing_down(3.0), np.array((0.02, 0.01, 0.2))  # 20 cm: the large marker is cut by the image's edge
    frame = _render(NESTED_PAD, rot, t)
    det = MarkerDetector(CAMERA, layout=NESTED_PAD).detect(frame)
    assert det is not None and det.marker_ids == (42,)
    assert _close(det.position_cam_m, t)
    assert MarkerDetector(CAMERA, layout=SINGLE_PAD).detect(frame) is None  # the seed's pad would be blind here


def test_the_outer_marker_alone_gives_the_pad_centre_from_its_offset():
    rot, t = _facing_down(2.0), np.array((0.35, 0.0, 1.2))  # (exactly face on, IPPE_SQUARE can fail: 2 deg)
    frame = _render(PadLayout(NESTED_PAD.markers[:1]), rot, t)  # a pad printed without the inner marker
    det = MarkerDetector(CAMERA, layout=NESTED_PAD).detect(frame)
    assert det is not None and det.marker_ids == (76,)
    assert _close(det.position_cam_m, t)


def test_from_afar_the_outer_markers_join_though_small_and_the_inner_one_does_not():
    """At 3.5 m the large markers are 23 px, under MIN_JOINT_SIDE_PX, and the inner one 9 px: the four large ones
    (equally small) make the pose, spread over the deck, the small one's corners are left out."""
    rot, t = _facing_down(10.0), np.array((-0.2, 0.3, 3.5))
    det = MarkerDetector(CAMERA, layout=NESTED_PAD).detect(_render(NESTED_PAD, rot, t))
    assert det is not None and det.marker_ids == (76, 151, 113, 813)
    assert _close(det.position_cam_m, t)


def test_the_level_pad_picks_the_outer_marker_pose_alone_from_afar():
    """One large marker alone 0.47 m from the pad's centre, 3 m away: IPPE's two poses fit its corners about
    equally; the expected up (vision.pad_pose.expected_normal_cam) takes the level one, whose centre is right."""
    for tilt_deg in (12.0, -12.0):
        rot, t = _facing_down(tilt_deg), np.array((0.1, 0.2, 3.0))
        frame = _render(PadLayout(NESTED_PAD.markers[:1]), rot, t)
        det = MarkerDetector(CAMERA, layout=NESTED_PAD).detect(frame, up_cam=rot[:, 2])
        assert det is not None and det.marker_ids == (76,)
        assert float(np.linalg.norm(det.position_cam_m - t)) < 0.05
        assert np.degrees(np.arccos(min(1.0, det.rotation_cam_marker[:, 2] @ rot[:, 2]))) < 5.0


def _markers(corners, ids, id_of) -> dict[int, np.ndarray]:
    """A detectMarkers result as id -> (4, 2) corners, ``id_of`` mapping the detector's index to the id."""
    return {} if ids is None else {id_of(int(i)): np.asarray(c).reshape(4, 2) for c, i in zip(corners, ids.ravel())}


def test_the_pad_dictionary_finds_the_pads_markers_as_the_whole_dictionary_does():
    """Sixty noisy frames of the nested pad (0.25-4.5 m, tilted, off-centre) with a second deck's pad beside it
    (vehicle 1's ids): the detector's dictionary of its own five markers (vision.detector.pad_dictionary) gives
    the same markers with the same corners, to the bit, as DICT_ARUCO_ORIGINAL with the same parameters; the
    other deck's markers are seen by the whole dictionary only."""
    det = MarkerDetector(CAMERA, layout=NESTED_PAD, rendered=True)
    whole = cv2.aruco.ArucoDetector(dictionary(), det._detector.getDetectorParameters())
    own, other = {m.marker_id for m in NESTED_PAD.markers}, {m.marker_id for m in vehicle_pad(NESTED_PAD, 1).markers}
    rng = np.random.default_rng(11)
    seen_own = seen_other = 0
    for _ in range(60):
        d = rng.uniform(0.25, 4.5)
        rot, t = _facing_down(rng.uniform(-20.0, 20.0)), np.array((*rng.uniform(-0.3, 0.3, 2) * d, d))
        frame = _render(NESTED_PAD, rot, t)
        beside = _render(vehicle_pad(NESTED_PAD, 1), rot, t + rot[:, 0] * 1.5)  # the next deck, 1.5 m along x
        frame = np.where(beside != 128, beside, frame)
        frame = cv2.add(frame, rng.normal(0.0, 3.0, frame.shape), dtype=cv2.CV_8U)
        ours = _markers(*det._detector.detectMarkers(frame)[:2], lambda i: NESTED_PAD.markers[i].marker_id)
        every = _markers(*whole.detectMarkers(frame)[:2], lambda i: i)
        assert ours.keys() == every.keys() & own
        assert all(np.array_equal(ours[i], every[i]) for i in ours)
        seen_own += len(ours)
        seen_other += len(every.keys() & other)
    assert seen_own >= 150 and seen_other >= 80, (seen_own, seen_other)


def test_expected_normal_is_up_in_the_camera_frame():
    down = CameraMount().rotation_frd_cam  # looking straight down, the image's top forward
    level = np.array((1.0, 0.0, 0.0, 0.0))
    assert np.allclose(expected_normal_cam(down, level), (0.0, 0.0, -1.0))  # up: towards the camera
    pitched_up = np.array((math.cos(math.radians(10)), 0.0, math.sin(math.radians(10)), 0.0))  # nose up 20 deg
    up = expected_normal_cam(down, pitched_up)
    assert up[2] == pytest.approx(-math.cos(math.radians(20))) and abs(up[0]) < 1e-12


def test_the_single_seed_pad_is_the_marker_at_the_centre():
    rot, t = _facing_down(2.0), np.array((0.0, 0.1, 1.5))
    det = MarkerDetector(CAMERA, layout=SINGLE_PAD).detect(_render(SINGLE_PAD, rot, t))
    assert det is not None and det.marker_ids == (76,) and det.size_m == 0.333
    assert _close(det.position_cam_m, t)


def test_the_shipped_layouts_fit_the_deck():
    assert check_pad(NESTED_PAD, DECK_M) is NESTED_PAD and check_pad(SINGLE_PAD, DECK_M) is SINGLE_PAD
    inner = NESTED_PAD.marker(42)
    assert inner is not None and (inner.x_m, inner.y_m) == (0.0, 0.0), "the small marker at the landing point"


@pytest.mark.parametrize(
    "markers, key, reason",
    [
        ((), "pad.markers", "at least one marker"),
        (((76, 0.333, 0, 0), (76, 0.1, 0.4, 0.4)), "pad.markers[1].id", "twice"),
        (((76, 0.333, 0, 0), (1024, 0.1, 0.4, 0.4)), "pad.markers[1].id", "not an id"),
        (((76, 0.0, 0, 0),), "pad.markers[0].size_m", "must be > 0"),
        (((76, -0.2, 0, 0),), "pad.markers[0].size_m", "must be > 0"),
        (((76, 0.333, 0.45, 0),), "pad.markers[0]", "does not fit"),
        (((76, 1.3, 0, 0),), "pad.markers[0]", "does not fit"),
        (((76, 0.333, 0, 0), (42, 0.125, 0.0, 0.0)), "pad.markers[1]", "overlaps pad.markers[0]"),
        (((76, 0.333, -0.3, 0), (42, 0.125, 0.0, 0.0), (7, 0.1, -0.05, 0.05)), "pad.markers[2]", "overlaps"),
        # touching only through the white border: still refused (the detector needs it white)
        (((76, 0.333, -0.25, 0), (42, 0.125, 0.0, 0.0)), "pad.markers[1]", "or its white border"),
    ],
)
def test_bad_layouts_are_refused_naming_the_key(markers, key, reason):
    pad = PadLayout(tuple(PadMarker(*m) for m in markers))
    with pytest.raises(PadLayoutError) as err:
        check_pad(pad, DECK_M)
    assert err.value.key == key and reason in err.value.reason and "\n" not in str(err.value)


def test_quiet_border_is_one_cell():
    assert PadMarker(1, 0.7).quiet_border_m == pytest.approx(0.7 / (MARKER_BITS + 2))
