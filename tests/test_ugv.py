"""The ground vehicle (sitl.ugv, sitl.ugv_paths) in a world of its own: driving, paths and the deck marker."""

from __future__ import annotations

import math
import os
import subprocess
import sys

import cv2
import mujoco
import numpy as np
import pytest

from sitl.ugv import Ugv, UgvGeometry, build_ugv_world
from sitl.ugv_paths import Pose2, UgvPath, circle, figure8, random_waypoints, straight_line

DT = 0.004


def drive(path: UgvPath, seconds: float):
    """Follow ``path`` for ``seconds``; return times, states, ground-contact flags."""
    model = build_ugv_world(path.start)
    data = mujoco.MjData(model)
    ugv = Ugv(model, data)
    ground = model.geom("ground").id
    ugv_bodies = {model.body(n).id for n in ("ugv", "ugv_wheel_left", "ugv_wheel_right", "ugv_caster")}
    times, states, contact = [], [], []
    for i in range(int(seconds / DT)):
        t = i * DT
        ugv.follow(path.target(t))
        mujoco.mj_step(model, data)
        touching = set()
        for c in data.contact[: data.ncon]:
            other = c.geom2 if c.geom1 == ground else c.geom1 if c.geom2 == ground else None
            if other is not None:
                touching.add(model.geom_bodyid[other])
        times.append(t + DT)
        states.append(ugv.state())
        contact.append(touching >= ugv_bodies - {model.body("ugv").id})
    return np.array(times), states, np.array(contact)


@pytest.mark.parametrize("speed", [1.0, 3.0])
def test_straight_line_speed_heading_upright_and_acceleration_limit(speed):
    path = straight_line(Pose2(2.0, -1.0, 0.7), speed)
    t, states, contact = drive(path, 4.0)
    v = np.array([np.linalg.norm(s.velocity_ned_m_s[:2]) for s in states])
    settled = t > speed / 1.5 + 1.0
    assert np.all(np.abs(v[settled] - speed) < 0.05 * speed)
    assert max(abs(math.remainder(s.yaw_rad - 0.7, 2 * math.pi)) for s in states) < math.radians(3)
    assert contact[50:].all(), "both wheels and the caster stay on the ground"
    for s in states:  # upright: body down axis stays within 5 deg of world down
        r = s.quat_ned_frd
        down_z = 1 - 2 * (r[1] ** 2 + r[2] ** 2)
        assert down_z > math.cos(math.radians(5))
    acc = np.diff(np.convolve(v[t > 0.3], np.ones(25) / 25, mode="valid")) / DT  # after settling on the wheels
    assert acc.max() < 1.5 * 1.1, "acceleration limit 1.5 m/s^2"
    final = states[-1].position_ned_m
    assert abs(final[2] - (-0.1)) < 0.01, "axle height stays at the wheel radius (NED down -0.1 m)"
    assert np.hypot(*(final[:2] - [path.target(t[-1]).pose.north_m, path.target(t[-1]).pose.east_m])) < 0.3


def test_circle_radius_5m():
    path = circle(Pose2(0.0, 0.0, 0.0), 5.0, 2.0)
    t, states, _ = drive(path, 6.0)
    centre = np.array([0.0, 5.0])  # clockwise from above, heading North: centre to the East
    r = np.array([np.linalg.norm(s.position_ned_m[:2] - centre) for s in states])
    assert np.all(np.abs(r[t > 2.0] - 5.0) < 0.3)
    assert states[-1].yaw_rad != pytest.approx(0.0, abs=1.0), "it has turned"


def test_path_targets_are_consistent():
    for path in (figure8(Pose2(1.0, 2.0, 0.3), 4.0, 2.0), circle(Pose2(0, 0, 0), 5.0, 3.0)):
        # velocity is the derivative of position, and speed never exceeds the set speed
        for t in np.linspace(0.0, 40.0, 57):
            a, b = path.target(t), path.target(t + 1e-4)
            dn = (b.pose.north_m - a.pose.north_m) / 1e-4
            de = (b.pose.east_m - a.pose.east_m) / 1e-4
            assert dn == pytest.approx(a.velocity_ne_m_s[0], abs=1e-2)
            assert de == pytest.approx(a.velocity_ne_m_s[1], abs=1e-2)
            assert a.speed_m_s <= path.speed_m_s + 1e-12
    f8 = figure8(Pose2(0, 0, 0), 4.0, 2.0)  # two circles of 4 m (8 pi m each) through the start
    half, lap = f8.pose_at(8 * math.pi)[0], f8.pose_at(16 * math.pi)[0]
    assert (half.north_m, half.east_m, lap.north_m, lap.east_m) == pytest.approx((0, 0, 0, 0), abs=1e-9)
    assert f8.pose_at(4 * math.pi)[0].east_m == pytest.approx(8.0), "first circle to the East (right turn)"
    assert f8.pose_at(12 * math.pi)[0].east_m == pytest.approx(-8.0), "second circle to the West"
    assert straight_line(Pose2(0, 0, 0), 0.0).target(10.0).pose == Pose2(0, 0, 0), "speed 0 stands still"
    with pytest.raises(ValueError):
        straight_line(Pose2(0, 0, 0), 10.0)


def test_random_waypoints_deterministic_for_a_seed():
    def make(seed):
        return random_waypoints(Pose2(0, 0, 0), 1.5, np.random.default_rng(seed))

    a, b, c = make(7), make(7), make(8)
    times = np.linspace(0.0, 60.0, 31)
    pa = [a.target(t).pose for t in times]
    assert pa == [b.target(t).pose for t in times]
    assert pa != [c.target(t).pose for t in times]
    _, states, _ = drive(a, 4.0)
    end = a.target(4.0).pose
    assert np.hypot(states[-1].position_ned_m[0] - end.north_m, states[-1].position_ned_m[1] - end.east_m) < 0.3


# MuJoCo picks its GL backend when first imported, so the render runs in a fresh interpreter
# with MUJOCO_GL=egl (headless), whatever the test session imported before.
RENDER_SCRIPT = """
import sys, mujoco, cv2
from sitl.ugv import build_ugv_world
from sitl.ugv_paths import Pose2
from vision.pad import NESTED_PAD, SINGLE_PAD
pad = {"nested": NESTED_PAD, "single": SINGLE_PAD}[sys.argv[2]]
model = build_ugv_world(Pose2(3.0, -2.0, 0.4), pad=pad)
data = mujoco.MjData(model)
mujoco.mj_forward(model, data)
renderer = mujoco.Renderer(model, 240, 320)
cam = mujoco.MjvCamera()
cam.lookat[:] = data.body("ugv").xpos + [0.0, 0.0, 0.15]
cam.distance, cam.elevation, cam.azimuth = 2.0, -90.0, 90.0
renderer.update_scene(data, cam)
for flag in (mujoco.mjtRndFlag.mjRND_SHADOW, mujoco.mjtRndFlag.mjRND_REFLECTION, mujoco.mjtRndFlag.mjRND_SKYBOX):
    renderer.scene.flags[flag] = 0
renderer.update_scene(data, cam)
cv2.imwrite(sys.argv[1], renderer.render()[:, :, ::-1])
"""


@pytest.mark.parametrize("pad", ["nested", "single"])
def test_deck_markers_decode_from_above_with_their_sizes_and_offsets(tmp_path, pad):
    """The deck shows the pad's markers (vision.pad) at their true sizes, and their offsets along the UGV's axes."""
    from vision.pad import NESTED_PAD, SINGLE_PAD

    layout = {"nested": NESTED_PAD, "single": SINGLE_PAD}[pad]
    out = tmp_path / "deck.png"
    env = dict(os.environ, MUJOCO_GL="egl", PYOPENGL_PLATFORM="egl")
    run = subprocess.run([sys.executable, "-c", RENDER_SCRIPT, str(out), pad], env=env, capture_output=True, text=True)
    assert run.returncode == 0, f"offscreen rendering with MUJOCO_GL=egl failed (is EGL available?):\n{run.stderr}"
    image = cv2.imread(str(out), cv2.IMREAD_GRAYSCALE)
    assert image.shape == (240, 320)
    detector = cv2.aruco.ArucoDetector(cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_ARUCO_ORIGINAL))
    corners, ids, _ = detector.detectMarkers(image)
    assert ids is not None and sorted(ids.ravel().tolist()) == sorted(m.marker_id for m in layout.markers)
    # seen from 2 m above the point 0.15 m above the axle (the deck is 0.2 m above it), with MuJoCo's 45 deg
    # vertical field of view: the texture has the markers' true sizes and offsets
    deck_above_axle = UgvGeometry().deck_top_m - UgvGeometry().wheel_radius_m
    px_per_m = 240 / (2 * (2.0 - (deck_above_axle - 0.15)) * math.tan(math.radians(22.5)))
    seen = {i: c.reshape(4, 2) for c, i in zip(corners, ids.ravel().tolist())}
    for m in layout.markers:
        side_px = np.mean([np.linalg.norm(seen[m.marker_id][i] - seen[m.marker_id][(i + 1) % 4]) for i in range(4)])
        assert side_px == pytest.approx(m.size_m * px_per_m, rel=0.1)
    if pad == "nested":  # the four large markers around the small one at the centre, each at its offset
        inner = seen[layout.markers[1].marker_id].mean(axis=0)
        for m in layout.markers[:1] + layout.markers[2:]:
            offset_px = np.linalg.norm(seen[m.marker_id].mean(axis=0) - inner)
            assert offset_px == pytest.approx(math.hypot(m.x_m, m.y_m) * px_per_m, rel=0.1)


def test_ugv_merges_into_the_multicopter_world_behind_a_switch():
    from params.vehicle import load_vehicle
    from sitl.model import build_mjcf, build_model

    spec = load_vehicle("quad_x")
    assert "ugv" not in build_mjcf(spec), "off by default"
    model = build_model(spec, ugv_start=Pose2(6.0, 0.0, 0.0))
    assert [model.actuator(i).name for i in range(4)] == ["rotor1", "rotor2", "rotor3", "rotor4"]
    data = mujoco.MjData(model)
    ugv, path = Ugv(model, data), straight_line(Pose2(6.0, 0.0, 0.0), 1.0)
    for i in range(500):
        ugv.follow(path.target(i * DT))
        mujoco.mj_step(model, data)
    assert ugv.state().position_ned_m[0] == pytest.approx(path.target(2.0).pose.north_m, abs=0.2)
    assert data.body("vehicle").xpos[:2] == pytest.approx([0.0, 0.0], abs=1e-3), "the multicopter stays put"
