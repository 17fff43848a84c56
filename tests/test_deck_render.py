"""The fast camera (sitl/deck_render.py, ``SIM_CAM_RENDER`` 1) against MuJoCo's render (sitl/camera.py) on the same
states: the same picture (the deck's texture the way round MuJoCo lays it, its white and black, the ground's shade),
the same detections and pose errors, the same noise; and the vision companion flying with it."""

from __future__ import annotations

import math
from dataclasses import replace

import cv2
import mujoco
import numpy as np
import pytest

from mavsim_core.frames import quat_enu_flu_to_ned_frd, quat_ned_frd_to_enu_flu
from mavsim_core.quaternion import from_euler
from params.vehicle import load_vehicle
from sitl.camera import DownwardCamera, open_camera
from sitl.companion import LockstepCompanion
from sitl.deck_render import DeckCamera, DeckRenderer, plane_grid
from sitl.gimbal import camera_to_body
from sitl.model import GIMBAL_JOINTS
from sitl.sim_settings import CameraSettings, UgvSettings
from sitl.simulation import Simulation
from vision.camera_model import pinhole
from vision.detector import MarkerDetector, expected_normal_cam
from vision.landing_target import CameraMount, target_offset

SPEC = load_vehicle("quad_x")  # the gimballed camera, 480 x 360, 90 deg
UGV = UgvSettings(enabled=1, north_m=3.0, east_m=1.0, yaw_deg=30.0, path=0)
DECK_TOP_M = 0.30


@pytest.fixture(scope="module")
def world():
    sim = Simulation(SPEC, (47.4, 8.5, 400.0), seed=1, ugv=UGV)
    mj = DownwardCamera(sim.model, SPEC.camera, seed=1)
    yield sim, mj
    mj.close()


def _place(sim, north: float, east: float, height: float, rpy_deg=(0.0, 0.0, 0.0), look_deg=(0.0, -90.0, 0.0)):
    """The multicopter ``height`` m above the deck's top, (north, east) m from the deck's centre, attitude
    ``rpy_deg`` (NED, deg); the gimbal's joints at (roll, pitch, yaw) ``look_deg`` (pitch -90: straight down at
    zero attitude)."""
    deck = sim.ugv_truth().deck_pos_ned_m
    v = sim.vehicle
    sim.data.qpos[0:3] = [v.start_xy_enu[0] + deck[1] + east, v.start_xy_enu[1] + deck[0] + north, DECK_TOP_M + height]
    sim.data.qpos[3:7] = quat_ned_frd_to_enu_flu(from_euler(*(math.radians(a) for a in rpy_deg)))
    joints = dict(zip(("gimbal_roll", "gimbal_pitch", "gimbal_yaw"), look_deg))
    for name, _ in GIMBAL_JOINTS:
        sim.data.qpos[sim.model.jnt_qposadr[sim.model.joint(name).id]] = math.radians(joints[name])
    mujoco.mj_forward(sim.model, sim.data)


def _pose_error(sim, det) -> float:
    """The detection's pad centre against the truth (m), as the companion's pose_err."""
    q = quat_enu_flu_to_ned_frd(np.array(sim.data.qpos[3:7]))
    joints = tuple(float(sim.data.qpos[sim.model.jnt_qposadr[sim.model.joint(n).id]]) for n, _ in GIMBAL_JOINTS)
    mount = CameraMount(SPEC.camera.position_frd_m, np.array(camera_to_body(joints)))
    truth = sim.ugv_truth().deck_pos_ned_m - sim.truth().pos_ned_m
    return float(np.linalg.norm(target_offset(det, mount, q).ned_m - truth))


def _detector():
    cam = SPEC.camera
    return MarkerDetector(pinhole(cam.width_px, cam.height_px, math.radians(cam.hfov_deg)), layout=UGV.pad())


POSES = [  # (north, east, height, rpy deg, gimbal roll/pitch/yaw deg)
    (0.1, -0.2, 1.0, (0, 0, 70), (0, -90, 0)),
    (-0.6, 0.4, 2.8, (8, -12, 200), (-10, -75, 20)),
    (0.3, 0.2, 0.5, (0, 0, -40), (0, -90, 0)),
    (1.2, -0.8, 3.6, (15, 5, 10), (15, -110, -25)),
]


@pytest.mark.parametrize("pose", POSES, ids=["1m-down", "2.8m-tilted", "0.5m-down", "3.6m-off-axis"])
def test_the_fast_frame_is_mujocos_frame(world, pose):
    """Noise-free, grey level by grey level: within a level or two everywhere (the deck's white 255 and black 0,
    the ground's shade), a few pixels more at the deck's and the markers' edges."""
    sim, mj = world
    _place(sim, *pose)
    ref = mj.capture(sim.data).astype(int)
    fast = DeckRenderer(sim.model, SPEC.camera.width_px, SPEC.camera.height_px).render(sim.data).astype(int)
    diff = np.abs(ref - fast)
    assert diff.mean() < 0.5 and np.percentile(diff, 99) <= 3, (diff.mean(), np.percentile(diff, 99))
    white, black = ref == 255, ref == 0
    assert white.sum() > 500 and black.sum() > 100  # the deck and its markers in the picture
    assert np.mean(fast[white] >= 250) > 0.98 and np.mean(fast[black] <= 5) > 0.97
    ground = cv2.erode((ref < 240).astype(np.uint8) & (ref > 60).astype(np.uint8), np.ones((7, 7))) > 0
    assert np.abs(fast[ground] - ref[ground]).max() <= 3  # the ground's shade, its specular gradient and all


@pytest.mark.parametrize("turn", ["rotated 90 deg", "mirrored", "upside down"])
def test_the_texture_is_pinned_the_way_round_mujoco_lays_it(world, turn):
    """The same comparison fails with the deck's texture turned: the orientation above is the only one that fits."""
    sim, mj = world
    _place(sim, *POSES[0])
    ref = mj.capture(sim.data).astype(int)
    r = DeckRenderer(sim.model, SPEC.camera.width_px, SPEC.camera.height_px)
    op = {"rotated 90 deg": np.rot90, "mirrored": np.fliplr, "upside down": np.flipud}[turn]
    r.decks = [replace(d, levels=[np.ascontiguousarray(op(t)) for t in d.levels]) for d in r.decks]
    assert np.abs(ref - r.render(sim.data).astype(int)).mean() > 10


def test_the_same_detections_and_pose_errors_on_the_same_states(world):
    """Twenty states over the deck (0.3-4 m, tilted, the gimbal off straight down), both renderers with the same
    noise: the pad found in the same frames, its centre within a few millimetres of where MuJoCo's frame puts it."""
    sim, mj = world
    fast = DeckCamera(sim.model, SPEC.camera, seed=1)
    mj.noise = type(fast.noise)(SPEC.camera, 1)  # both cameras from the same first noise draw
    det, rng = _detector(), np.random.default_rng(7)
    found = 0
    for _ in range(20):
        h = rng.uniform(0.3, 4.0)
        pose = (*rng.uniform(-0.4, 0.4, 2) * h, h, (*rng.uniform(-15, 15, 2), rng.uniform(0, 360)))
        look = (rng.uniform(-15, 15), -90 + rng.uniform(-20, 20), rng.uniform(-20, 20))
        _place(sim, *pose, look)
        q = quat_enu_flu_to_ned_frd(np.array(sim.data.qpos[3:7]))
        joints = tuple(float(sim.data.qpos[sim.model.jnt_qposadr[sim.model.joint(n).id]]) for n, _ in GIMBAL_JOINTS)
        up = expected_normal_cam(np.array(camera_to_body(joints)), q)
        a, b = det.detect(mj.capture(sim.data, 2.0), up), det.detect(fast.capture(sim.data, 2.0), up)
        assert (a is None) == (b is None), pose
        if a is not None:
            found += 1
            ea, eb = _pose_error(sim, a), _pose_error(sim, b)
            assert ea < 0.06 and abs(ea - eb) < 0.01, (pose, ea, eb)
    assert found >= 15


def test_a_deck_above_the_camera_is_not_drawn(world):
    """On its legs beside the UGV, the camera 0.15 m below the deck's top and looking at it: its top is not seen
    (MuJoCo draws the box's sides there, left out of the fast path); nothing a detector could take for a marker."""
    sim, mj = world
    _place(sim, -2.5, 0.0, -0.15, look_deg=(0.0, -5.0, 0.0))
    fast = DeckRenderer(sim.model, SPEC.camera.width_px, SPEC.camera.height_px).render(sim.data)
    assert _detector().detect(mj.capture(sim.data)) is None and _detector().detect(fast) is None
    assert np.count_nonzero(fast[:150]) == 0 and fast[200:].min() > 100  # sky above the horizon (row 159), ground


def test_the_fast_camera_draws_the_noise_mujocos_camera_draws(world):
    """Same seed, same frames: the fast camera's frames repeat, a skipped frame leaves the next ones as they were,
    and each frame gets the very noise image MuJoCo's camera adds to its own (sitl/camera.py's FrameNoise)."""
    sim, mj = world
    _place(sim, *POSES[1])
    a, b = DeckCamera(sim.model, SPEC.camera, seed=3), DeckCamera(sim.model, SPEC.camera, seed=3)
    mj.noise = type(a.noise)(SPEC.camera, 3)
    clean = a.renderer.render(sim.data).astype(int)
    ref_clean = mj.capture(sim.data).astype(int)  # (noise 0: no draw)
    a.capture(sim.data, 3.0)
    a.skip(3.0)
    mj.capture(sim.data, 3.0)
    mj.skip(3.0)
    b.capture(sim.data, 3.0)
    b.capture(sim.data, 3.0)
    frame = a.capture(sim.data, 3.0)
    assert np.array_equal(frame, b.capture(sim.data, 3.0)) and a.frames == b.frames == 3
    ref = mj.capture(sim.data, 3.0).astype(int)
    inside = (clean > 20) & (clean < 235) & (ref_clean > 20) & (ref_clean < 235)  # no clipping at 0 or 255
    assert inside.sum() > 10_000
    assert np.array_equal((frame - clean)[inside], (ref - ref_clean)[inside])
    rgb = a.last_rgb  # the video's frame: without the noise, grey in three channels
    assert rgb.shape == (360, 480, 3) and rgb.dtype == np.uint8
    assert np.array_equal(rgb[:, :, 0], clean) and np.array_equal(rgb[:, :, 2], clean)


def test_sim_cam_render_chooses_the_camera(world):
    sim, _ = world
    assert CameraSettings().render == 1  # the default (benchmarks/camera_fast_path.py: the same detections)
    assert isinstance(open_camera(sim.model, SPEC.camera, 0, render=1), DeckCamera)
    mj = open_camera(sim.model, SPEC.camera, 0, render=0)
    try:
        assert isinstance(mj, DownwardCamera)
    finally:
        mj.close()


class _Media:
    """What sitl/camera_media.py's CameraMedia is to the companion: wants every frame, keeps the pictures."""

    home = (47.4, 8.5, 400.0)

    def __init__(self) -> None:
        self.pictures: list[np.ndarray] = []

    def wants(self, time_us: int) -> bool:
        return True

    def frame(self, rgb, time_us, pose, detection=None) -> None:
        self.pictures.append(rgb)


def test_the_companion_flies_with_the_fast_camera(world):
    """SIM_CAM_RENDER 1: the companion sends LANDING_TARGET over the deck and skips a frame with the pad out of
    view (counted, not rendered), as with MuJoCo's render; with the video on, every frame's picture goes to it."""
    sim, _ = world
    for media in (None, _Media()):
        settings = CameraSettings(latency_ms=0, render=1)
        companion = LockstepCompanion(sim.model, SPEC.camera, settings, pad=UGV.pad())
        companion.media = media
        try:
            _place(sim, 0.2, 0.1, 1.5)
            assert companion.step(sim.data, 0) != b""
            _place(sim, 8.0, 8.0, 1.5)  # the deck far behind the frame
            assert companion.step(sim.data, companion.period_us) == b""
        finally:
            companion.close()
        st = companion.stats
        assert st.frames == 2 and st.detections == 1 and st.not_rendered == 1 and st.pose_err_max_m < 0.02
    assert len(media.pictures) == 2 and all(p.shape == (360, 480, 3) and p.dtype == np.uint8 for p in media.pictures)
    assert media.pictures[0].max() == 255 and media.pictures[0].min() == 0  # the deck and its markers


def test_the_ground_is_tessellated_as_mujoco_draws_a_plane():
    """The 500 m ground's vertex lines every 5.05 m, one through the origin (MuJoCo's makePlane)."""
    lines = plane_grid(500.0, 0.1)
    assert lines[0] == -500.0 and lines[-1] == 500.0 and len(lines) == 201
    assert np.diff(lines[1:-1]) == pytest.approx(1000.0 / 198) and np.min(np.abs(lines)) < 1e-9
