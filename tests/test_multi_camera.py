"""A camera on every vehicle (issue 38, part 4): in a world of several multicopters each with its own ground
vehicle, vehicle k's camera renders its own view, its companion finds its own deck (its own marker ids) and its
LANDING_TARGET matches the truth; no two decks share an id; the fast renderer draws every deck."""

from __future__ import annotations

import math
from copy import deepcopy

import mujoco
import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink

from params.vehicle import load_vehicle
from sitl.camera import DownwardCamera
from sitl.companion import LockstepCompanion
from sitl.deck_render import DeckRenderer
from sitl.model import part_name
from sitl.sim_settings import CameraSettings, UgvSettings
from sitl.simulation import UGV_SPACING_M, VehicleView, World, spread
from vision.pad import NESTED_PAD, SINGLE_PAD, vehicle_pad

SPEC = load_vehicle("quad_x").with_camera_mount("fixed")
COUNT = 3


@pytest.fixture(scope="module")
def world():
    ugv = UgvSettings(enabled=1, north_m=3.0, east_m=0.5, yaw_deg=20.0, path=0)
    ugvs = [ugv] + [deepcopy(ugv) for _ in range(1, COUNT)]
    cams = [CameraSettings(render=1, noise_grey=2.0) for _ in range(COUNT)]
    return World(spread(SPEC, COUNT, UGV_SPACING_M), (47.4, 8.5, 400.0), 3, ugv=ugv, ugvs=ugvs, cameras=cams)


def _place(world: World, k: int, north: float, east: float, height: float) -> None:
    """Vehicle ``k`` at (north, east) m from its own start, ``height`` m up, level, facing North."""
    v = world.vehicles[k]
    adr = int(world.model.jnt_qposadr[world.model.joint(part_name(k, "root")).id])
    world.data.qpos[adr : adr + 3] = [east + v.start_xy_enu[0], north + v.start_xy_enu[1], height]
    world.data.qpos[adr + 3 : adr + 7] = [math.cos(math.pi / 4), 0.0, 0.0, math.sin(math.pi / 4)]
    mujoco.mj_forward(world.model, world.data)


def test_no_two_decks_share_a_marker_id():
    for pad in (NESTED_PAD, SINGLE_PAD):
        ids = [m.marker_id for k in range(10) for m in vehicle_pad(pad, k).markers]
        assert len(ids) == len(set(ids))
        assert vehicle_pad(pad, 0) == pad  # vehicle 0's deck is the single-vehicle world's
        assert [m.size_m for m in vehicle_pad(pad, 4).markers] == [m.size_m for m in pad.markers]


def test_each_vehicle_has_its_own_ugv_deck_and_pad(world):
    assert len(world.ugvs) == COUNT and world.pads is not None
    for k in range(COUNT):
        view = VehicleView(world, k)
        deck = view.ugv_truth().deck_pos_ned_m  # NED from its own start: each UGV starts where its settings say
        assert np.allclose(deck[:2], (3.0, 0.5), atol=0.15)
        assert view.pad is world.pads[k]
        assert view.ugv is world.ugvs[k] and view.ugv_settings is not VehicleView(world, (k + 1) % COUNT).ugv_settings


def _landing_target(world: World, k: int) -> tuple[object, object]:
    """Vehicle ``k``'s companion on one frame: the LANDING_TARGET it sends and the frame's record."""
    view = VehicleView(world, k)
    settings = CameraSettings(render=1, noise_grey=2.0, latency_ms=0)
    companion = LockstepCompanion(world.model, SPEC.camera, settings, seed=k, sysid=1 + k, pad=view.pad, vehicle=k,
                                  ugv=k)  # fmt: skip
    frames = []
    companion.on_frame = frames.append
    try:
        packed = companion.step(world.data, 0)
    finally:
        companion.close()
    parser = mavlink.MAVLink(None)
    msgs = parser.parse_buffer(packed) or []
    return (msgs[0] if msgs else None), frames[0]


@pytest.mark.parametrize("k", range(COUNT))
def test_each_companion_finds_its_own_deck_and_the_truth(world, k):
    for j in range(COUNT):
        _place(world, j, 2.8, 0.6, 2.8)
    msg, frame = _landing_target(world, k)
    assert msg is not None and msg.get_srcSystem() == 1 + k
    own_ids = {m.marker_id for m in world.pads[k].markers}
    assert frame.marker_ids and set(frame.marker_ids) <= own_ids
    view = VehicleView(world, k)
    truth_ned = view.ugv_truth().deck_pos_ned_m - view.truth().pos_ned_m  # body FRD = NED here (level, North)
    assert np.linalg.norm(np.array([msg.x, msg.y, msg.z]) - truth_ned) < 0.08


def test_a_companion_ignores_another_vehicles_deck(world):
    """Vehicle 1 flown over vehicle 0's deck sees a pad, not its own: no LANDING_TARGET."""
    _place(world, 0, -5.0, 0.0, 2.8)
    _place(world, 1, 2.8, 0.6 - UGV_SPACING_M, 2.8)  # over deck 0 (10 m West of its own start)
    msg, frame = _landing_target(world, 1)
    assert msg is None and not frame.marker_ids


@pytest.mark.parametrize("k", [1, 2])
def test_the_fast_renderer_draws_each_vehicles_own_view(world, k):
    """SIM_CAM_RENDER 1 renders vehicle k's camera as MuJoCo does (its own deck under it), not vehicle 0's."""
    for j in range(COUNT):
        _place(world, j, 2.6, 0.4, 2.5)
    name = part_name(k, "downward")
    w, h = SPEC.camera.width_px, SPEC.camera.height_px
    fast = DeckRenderer(world.model, w, h, name).render(world.data)
    cam = DownwardCamera(world.model, SPEC.camera, camera=name)
    try:
        full = cam.capture(world.data)
    finally:
        cam.close()
    diff = np.abs(fast.astype(float) - full.astype(float))
    assert np.mean(diff) < 2.0
    dark = full < 60  # the markers' black cells, where both draw them
    assert dark.sum() > 1000 and np.mean(fast[dark] < 128) > 0.95
