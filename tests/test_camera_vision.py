"""The downward camera (sitl/camera.py) and the vision companion's code on its frames: the marker's
position against the truth the renderer used, no marker -> no fix, same seed -> same frames, and the
standalone ``python -m vision`` on a recorded video (issue 13, items 2-3)."""

from __future__ import annotations

import math
import socket
import subprocess
import sys
from contextlib import contextmanager

import cv2
import mujoco
import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink.landing_target import decode_landing_target
from mavsim_core.frames import quat_enu_flu_to_ned_frd
from params.vehicle import load_vehicle
from sitl.camera import NOISE_BANK, DownwardCamera, FrameNoise
from sitl.marker_view import MarkerView
from sitl.sim_settings import UgvSettings
from sitl.simulation import Simulation
from vision.camera_model import pinhole
from vision.detector import MarkerDetector
from vision.landing_target import CameraMount, landing_target_message

SPEC = load_vehicle("quad_x")


@pytest.fixture(scope="module")
def world():
    ugv = UgvSettings(enabled=1, north_m=3.0, east_m=1.0, yaw_deg=30.0, path=0)
    sim = Simulation(SPEC, (47.4, 8.5, 400.0), seed=1, ugv=ugv)
    cam = DownwardCamera(sim.model, SPEC.camera, seed=1)
    lens = pinhole(SPEC.camera.width_px, SPEC.camera.height_px, math.radians(SPEC.camera.hfov_deg))
    det = MarkerDetector(lens, layout=ugv.pad())  # the default pad: nested
    yield sim, cam, det
    cam.close()


def _place(sim: Simulation, north: float, east: float, height: float, yaw_deg: float, roll_deg: float = 0.0):
    """Put the multicopter at (north, east) m from its start, ``height`` m up, with yaw and roll (NED)."""
    from scipy.spatial.transform import Rotation

    q_xyzw = Rotation.from_euler("ZYX", [math.radians(90 - yaw_deg), 0.0, -math.radians(roll_deg)]).as_quat()
    sim.data.qpos[0:3] = [east + sim._start_xy_enu[0], north + sim._start_xy_enu[1], height]
    sim.data.qpos[3:7] = [q_xyzw[3], q_xyzw[0], q_xyzw[1], q_xyzw[2]]
    mujoco.mj_forward(sim.model, sim.data)


@pytest.mark.parametrize(
    "north, east, height, yaw_deg, roll_deg",
    [
        (2.5, 1.0, 2.8, 0, 0),
        (3.3, 0.6, 2.8, 0, 0),
        (3.0, 1.0, 1.0, 90, 0),
        (3.4, 1.4, 2.0, 45, 10),
        (2.2, 0.2, 3.4, 0, 0),
    ],
)
def test_marker_position_from_rendered_frames_matches_the_truth(world, north, east, height, yaw_deg, roll_deg):
    sim, cam, det = world
    _place(sim, north, east, height, yaw_deg, roll_deg)
    found = det.detect(cam.capture(sim.data, noise_grey=2.0))
    assert found is not None and found.marker_id == 76
    q = quat_enu_flu_to_ned_frd(np.array(sim.data.qpos[3:7]))
    mount = CameraMount(position_frd_m=SPEC.camera.position_frd_m)
    msg = landing_target_message(found, mount, q, 0, frame=mavlink.MAV_FRAME_BODY_FRD)
    meas = decode_landing_target(msg, q, height, None, 0)  # as the flight controller reads it
    truth = sim.ugv_truth().deck_pos_ned_m - sim.truth().pos_ned_m
    assert np.linalg.norm(meas.rel_pos_ned_m - truth) < 0.03 + 0.01 * height


def test_no_marker_in_view_gives_no_fix(world):
    sim, cam, det = world
    _place(sim, -3.0, -3.0, 2.8, 0)  # the UGV is 6-7 m away: out of the 90 deg view
    assert det.detect(cam.capture(sim.data, noise_grey=2.0)) is None


@contextmanager
def twin_cameras(sim: Simulation, seed: int = 7):
    """Two cameras of the same seed (closed after)."""
    a = DownwardCamera(sim.model, SPEC.camera, seed=seed)
    b = DownwardCamera(sim.model, SPEC.camera, seed=seed)
    try:
        yield a, b
    finally:
        a.close()
        b.close()


def test_same_seed_same_frames(world):
    sim, _, _ = world
    _place(sim, 2.8, 0.9, 2.5, 0)
    with twin_cameras(sim) as (a, b):
        for _ in range(3):
            assert np.array_equal(a.capture(sim.data, 3.0), b.capture(sim.data, 3.0))


def test_the_noise_is_a_bank_image_rolled_by_a_random_number_of_rows():
    """FrameNoise adds, to each frame, one of its bank's images times the noise's grey levels, rolled down by a
    random number of rows (the seed's draws in that order: the bank, then an image and a shift per frame), the sum's
    absolute value rounded to uint8: 400 frames, over 200 different shifts."""
    noise = FrameNoise(SPEC.camera, seed=5)
    rng = np.random.default_rng(5 * 104729 + 5)  # FrameNoise's generator, drawn in the same order
    h, w = SPEC.camera.height_px, SPEC.camera.width_px
    bank = [rng.standard_normal((h, w)).astype(np.float32) for _ in range(NOISE_BANK)]
    frame = np.random.default_rng(1).integers(0, 256, (h, w), dtype=np.uint8)
    frame[:, :40] = 0  # black: the noise below zero comes back as its absolute value
    shifts = set()
    for _ in range(400):
        k, shift = int(rng.integers(NOISE_BANK)), int(rng.integers(h))
        want = np.abs(frame.astype(np.float32) + np.float32(2.5) * np.roll(bank[k], shift, axis=0))
        assert np.array_equal(noise.add(frame, 2.5), np.clip(np.rint(want), 0, 255).astype(np.uint8)), shift
        shifts.add(shift)
    assert len(shifts) > 200


def test_standalone_vision_on_a_recorded_video_sends_landing_target(world, tmp_path):
    sim, cam, _ = world
    video = tmp_path / "descent.avi"
    out = cv2.VideoWriter(
        str(video), cv2.VideoWriter_fourcc(*"MJPG"), 20.0, (SPEC.camera.width_px, SPEC.camera.height_px)
    )
    heights = np.linspace(3.0, 1.2, 20)
    for h in heights:  # a descent over the deck
        _place(sim, 2.9, 1.0, float(h), 0)
        out.write(cv2.cvtColor(cam.capture(sim.data, 2.0), cv2.COLOR_GRAY2BGR))
    out.release()
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    rx.settimeout(0.2)
    port = rx.getsockname()[1]
    cmd = [sys.executable, "-m", "vision", "--video", str(video), "--hfov", str(SPEC.camera.hfov_deg), "--quiet"]
    cmd += ["--to", f"127.0.0.1:{port}", "--mount-frd", ",".join(str(v) for v in SPEC.camera.position_frd_m)]
    done = subprocess.run(cmd, capture_output=True, text=True, timeout=120)
    assert done.returncode == 0, done.stderr
    assert "20 frames, marker in 20" in done.stdout
    mav = mavlink.MAVLink(None)
    targets = []
    while True:
        try:
            data = rx.recv(4096)
        except TimeoutError:
            break
        targets += [m for m in mav.parse_buffer(data) or [] if m.get_type() == "LANDING_TARGET"]
    rx.close()
    assert len(targets) == 20
    assert all(t.frame == mavlink.MAV_FRAME_BODY_FRD and t.get_srcComponent() == 191 for t in targets)
    deck = 0.3  # the deck's top above the ground
    for t, h in zip(targets, heights):  # the marker straight below: z = height above the deck
        assert t.z == pytest.approx(h - deck, abs=0.05) and abs(t.x - 0.1) < 0.05 and abs(t.y) < 0.05


def test_a_frame_the_view_test_skips_is_one_without_the_marker(world):
    """sitl.marker_view: "out of view" only where the rendered frame shows no marker; in view where it does."""
    sim, cam, det = world
    view = MarkerView(sim.model, "downward", det.camera, det.layout)
    rng = np.random.default_rng(3)
    outs = ins = 0
    for _ in range(60):
        north, east = rng.uniform(-3.0, 9.0), rng.uniform(-5.0, 7.0)
        _place(sim, north, east, rng.uniform(0.6, 4.0), rng.uniform(0, 360), rng.uniform(-25, 25))
        if view.out_of_view(sim.data):
            outs += 1
            assert det.detect(cam.capture(sim.data, noise_grey=2.0)) is None
        else:
            ins += 1
    assert outs > 20 and ins > 3  # both kinds were drawn
    _place(sim, -3.0, -3.0, 2.8, 0)
    assert view.out_of_view(sim.data)
    _place(sim, 2.5, 1.0, 2.8, 0)  # the first case of the detection test above
    assert not view.out_of_view(sim.data)


def test_a_frame_the_stricter_view_test_skips_is_one_without_a_marker_found(world):
    """sitl.marker_view's ``detectable`` (the fast camera skips what it rejects): a frame in view but with no marker
    whole and large enough is one in which the detector finds nothing; and it does reject some frames in view (the
    pad cut by the frame's edge, or small from afar), and keeps those the pad is found in."""
    sim, cam, det = world
    view = MarkerView(sim.model, "downward", det.camera, det.layout)
    rng = np.random.default_rng(11)
    rejected = found = 0
    for _ in range(90):
        north, east = 3.0 + rng.uniform(-2.5, 2.5), 1.0 + rng.uniform(-2.5, 2.5)
        _place(sim, north, east, rng.uniform(0.5, 7.0), rng.uniform(0, 360), rng.uniform(-25, 25))
        if view.out_of_view(sim.data):
            continue
        seen = det.detect(cam.capture(sim.data, noise_grey=2.0)) is not None
        if not view.detectable(sim.data):
            rejected += 1
            assert not seen, (north, east)
        found += seen
    assert rejected >= 10 and found >= 10, (rejected, found)


def test_a_skipped_frame_leaves_the_next_frames_as_they_were(world):
    sim, _, _ = world
    _place(sim, 2.8, 0.9, 2.5, 0)
    with twin_cameras(sim) as (a, b):
        a.capture(sim.data, 3.0)
        a.skip(3.0)
        b.capture(sim.data, 3.0)
        b.capture(sim.data, 3.0)
        assert np.array_equal(a.capture(sim.data, 3.0), b.capture(sim.data, 3.0)) and a.frames == b.frames == 3
