"""The camera gimbal in the simulator (sitl/gimbal.py, its MJCF in sitl/model.py, the [gimbal] of the vehicle
files): the camera held straight down on a tilted vehicle, the joints' ranges and rate, the vehicle file's
checks, and a marker found through the gimbal put where the truth has it (issue 34, items 1 and 3)."""

from __future__ import annotations

import math
import re

import mujoco
import numpy as np
import pytest

from mavsim_core.frames import quat_enu_flu_to_ned_frd, quat_ned_frd_to_enu_flu
from mavsim_core.quaternion import from_euler, to_matrix
from params.vehicle import VehicleFileError, load_vehicle, vehicle_path
from sitl.camera import DownwardCamera
from sitl.companion import LockstepCompanion
from sitl.gimbal import (
    GimbalSetpoint,
    camera_attitude,
    camera_to_body,
    earth_rotation,
    joint_angles_for,
    joint_rotation,
    wanted_joint_angles,
)
from sitl.sim_settings import CameraSettings, UgvSettings
from sitl.simulation import Simulation
from vision.camera_model import pinhole
from vision.detector import MarkerDetector
from vision.landing_target import DOWNWARD_CAMERA, CameraMount, target_offset

HOME = (47.4, 8.5, 400.0)
QUAD = load_vehicle("quad_x")
RNG = np.random.default_rng(34)


def rows(m: np.ndarray):
    return tuple(tuple(float(x) for x in r) for r in m)


def test_the_shipped_vehicles_hang_their_camera_on_a_gimbal_and_the_fixed_camera_stays_selectable():
    for name in ("quad_x", "firefly"):
        spec = load_vehicle(name)
        assert spec.camera.mount == "gimbal" and spec.camera.gimballed
        assert Simulation(spec, HOME).model.nq == 7 + 3  # the free joint and the gimbal's yaw, roll and pitch
        fixed = spec.with_camera_mount("fixed")
        assert not fixed.camera.gimballed and Simulation(fixed, HOME).model.nq == 7
    with pytest.raises(VehicleFileError, match="mount"):
        QUAD.with_camera_mount("gyro")


@pytest.mark.parametrize(
    "line",
    [
        'mount = "gyro"',
        "roll_range_deg = [10.0, 40.0]",  # a range must hold zero
        "pitch_range_deg = [-90.0]",
        "neutral_pitch_deg = -150.0",  # outside the pitch range
        "max_rate_deg_s = 0.0",
        "time_constant_s = 5.0",
    ],
)
def test_a_broken_gimbal_or_mount_is_refused_naming_the_key(tmp_path, line):
    """The shipped quad_x file with one line of [camera] or [gimbal] broken: refused, the key named."""
    key = line.split(" = ")[0]
    text = vehicle_path("quad_x").read_text()
    broken, n = re.subn(rf"^{key}\s*=.*$", line, text, flags=re.MULTILINE)
    assert n == 1
    path = tmp_path / "broken.toml"
    path.write_text(broken)
    with pytest.raises(VehicleFileError, match=key):
        load_vehicle(str(path))


def test_joint_angles_put_the_camera_where_it_was_told_to_look():
    for _ in range(200):
        roll, pitch, yaw = RNG.uniform(-0.5, 0.5), RNG.uniform(-0.5, 0.5), RNG.uniform(-math.pi, math.pi)
        r_nb = rows(to_matrix(from_euler(roll, pitch, yaw)))
        sp_roll, sp_pitch, sp_yaw = RNG.uniform(-0.2, 0.2), RNG.uniform(-1.6, 0.3), RNG.uniform(-1.0, 1.0)
        earth = bool(RNG.integers(2))
        sp = GimbalSetpoint.from_angles(sp_roll, sp_pitch, sp_yaw, earth)
        assert np.allclose(GimbalSetpoint.from_quaternion(from_euler(sp_roll, sp_pitch, sp_yaw), earth).rows, sp.rows)
        joints = wanted_joint_angles(r_nb, sp)
        heading = sp_yaw if earth else math.atan2(r_nb[1][0], r_nb[0][0]) + sp_yaw
        want = earth_rotation(sp_roll, sp_pitch, heading)
        assert np.allclose(camera_attitude(r_nb, joints), want, atol=1e-9)
        assert np.allclose(joint_angles_for(joint_rotation(*joints)), joints, atol=1e-9)
    # a level vehicle, nobody pointing: the joints' neutral is the fixed camera's rotation
    assert np.allclose(camera_to_body((0.0, 0.0, -math.pi / 2)), DOWNWARD_CAMERA.rotation_frd_cam)


def _airborne(spec, roll_deg: float, pitch_deg: float, yaw_deg: float, **kw) -> Simulation:
    sim = Simulation(spec, HOME, **kw)
    sim.data.qpos[2] = 50.0  # high up, falling freely: only the attitude matters here
    q = from_euler(math.radians(roll_deg), math.radians(pitch_deg), math.radians(yaw_deg))
    sim.data.qpos[3:7] = quat_ned_frd_to_enu_flu(q)
    mujoco.mj_forward(sim.model, sim.data)
    return sim


def _optical_axis_ned(sim: Simulation) -> np.ndarray:
    cam = sim.model.camera("downward").id
    axis_enu = -sim.data.cam_xmat[cam].reshape(3, 3)[:, 2]  # MuJoCo's camera looks along its -z
    return np.array([axis_enu[1], axis_enu[0], -axis_enu[2]])


def test_the_gimbal_holds_the_camera_straight_down_on_a_tilted_vehicle_with_the_image_top_to_the_nose():
    sim = _airborne(QUAD, 25.0, -15.0, 30.0)
    before = math.degrees(math.acos(_optical_axis_ned(sim)[2]))
    assert before > 25.0  # the joints still where they were: the camera tilted with the frame
    for _ in range(100):  # 0.4 s: 29 deg at 180 deg/s plus the motors' 20 ms
        sim.step(np.zeros(4))
    assert math.degrees(math.acos(_optical_axis_ned(sim)[2])) < 0.2
    cam = sim.model.camera("downward").id
    up_enu = sim.data.cam_xmat[cam].reshape(3, 3)[:, 1]  # the image's up
    heading_deg = math.degrees(math.atan2(up_enu[0], up_enu[1]))  # from North toward East
    assert heading_deg == pytest.approx(30.0, abs=0.5)


def test_the_joints_stay_inside_their_ranges_and_move_no_faster_than_the_rate_limit():
    sim = _airborne(QUAD, 60.0, 0.0, 0.0)  # more roll than the joint's 45 deg
    g, lo_hi = sim.vehicle.gimbal, math.radians(45.0)
    step_max = math.radians(QUAD.camera.gimbal.max_rate_deg_s) * 0.004
    last = g.command
    for _ in range(150):
        sim.step(np.zeros(4))
        assert max(abs(a - b) for a, b in zip(g.command, last)) <= step_max + 1e-12
        last = g.command
    assert g.at_limit and abs(g.command[1]) == pytest.approx(lo_hi)
    assert abs(g.joints(sim.data)[1]) < lo_hi + math.radians(0.5)  # the servo's own overshoot


def test_a_marker_seen_through_the_gimbal_is_where_the_truth_has_it():
    """The vehicle rolled 20 deg above the deck, the gimbal holding the camera down: the companion's mount at
    capture (the encoders' rotation) puts the marker where it is; the fixed camera's mount would not."""
    ugv = UgvSettings(enabled=1, north_m=3.0, east_m=1.0, yaw_deg=30.0, path=0)
    sim = Simulation(QUAD, HOME, seed=1, ugv=ugv)
    v = sim.vehicle
    sim.data.qpos[0:3] = [1.0 + v.start_xy_enu[0], 3.4 + v.start_xy_enu[1], 2.2]
    q = from_euler(math.radians(20.0), math.radians(-8.0), math.radians(10.0))
    sim.data.qpos[3:7] = quat_ned_frd_to_enu_flu(q)
    mujoco.mj_forward(sim.model, sim.data)
    v.gimbal.place(sim.data, v.sensor_truth(sim.data).r_ned_frd)  # stabilised: joints where it holds them
    mujoco.mj_forward(sim.model, sim.data)
    spec = QUAD.camera
    cam = DownwardCamera(sim.model, spec, seed=1)
    try:
        det = MarkerDetector(
            pinhole(spec.width_px, spec.height_px, math.radians(spec.hfov_deg)), layout=ugv.pad()
        ).detect(cam.capture(sim.data, noise_grey=2.0))
    finally:
        cam.close()
    assert det is not None
    companion = LockstepCompanion(sim.model, spec, CameraSettings())
    try:
        mount = companion._mount_at_capture(
            CameraMount(position_frd_m=spec.position_frd_m), companion._joints(sim.data)
        )
    finally:
        companion.close()
    q_now = quat_enu_flu_to_ned_frd(np.array(sim.data.qpos[3:7]))
    truth = sim.ugv_truth().deck_pos_ned_m - sim.truth().pos_ned_m
    seen = target_offset(det, mount, q_now).ned_m
    assert np.linalg.norm(seen[:2] - truth[:2]) < 0.03 + 0.01 * 2.2
    fixed = target_offset(det, CameraMount(position_frd_m=spec.position_frd_m), q_now).ned_m
    assert np.linalg.norm(fixed[:2] - truth[:2]) > 0.5  # taken for a body-fixed camera: 20 deg of roll off


@pytest.mark.parametrize("process", [1, 0])
def test_the_companion_hands_each_frame_with_the_gimbals_angles_and_the_markers_used_to_on_frame(process):
    """Rolled 20 deg over the deck, the gimbal holding the camera down: the frame's record (what the truth log's
    .frames.npy keeps) carries the encoders' angles at capture as (roll, pitch, yaw) and the pad's markers used;
    the frames made in a process of their own (SIM_CAM_PROC 1) or on a thread (0)."""
    ugv = UgvSettings(enabled=1, north_m=3.0, east_m=1.0, yaw_deg=30.0, path=0)
    sim = Simulation(QUAD, HOME, seed=1, ugv=ugv)
    v = sim.vehicle
    sim.data.qpos[0:3] = [1.0 + v.start_xy_enu[0], 3.4 + v.start_xy_enu[1], 2.2]
    sim.data.qpos[3:7] = quat_ned_frd_to_enu_flu(from_euler(math.radians(20.0), math.radians(-8.0), 0.1))
    mujoco.mj_forward(sim.model, sim.data)
    v.gimbal.place(sim.data, v.sensor_truth(sim.data).r_ned_frd)
    mujoco.mj_forward(sim.model, sim.data)
    yaw, roll, pitch = v.gimbal.joints(sim.data)
    companion = LockstepCompanion(sim.model, QUAD.camera, CameraSettings(latency_ms=50, process=process), pad=ugv.pad())
    frames = []
    companion.on_frame = frames.append
    try:
        assert companion.step(sim.data, 0) == b"" and frames == []  # captured; released after the latency
        assert companion.step(sim.data, 50_000) != b""
    finally:
        companion.close()
    assert len(frames) == 1 and frames[0].time_us == 0 and frames[0].rendered
    assert frames[0].gimbal_rpy_rad == pytest.approx((roll, pitch, yaw)) and abs(roll) > math.radians(15.0)
    assert frames[0].marker_ids and set(frames[0].marker_ids) <= {m.marker_id for m in ugv.pad().markers}


def _set_attitude(q, flags: int = 0):
    from pymavlink.dialects.v20 import common as mavlink

    return mavlink.MAVLink_gimbal_device_set_attitude_message(1, 154, flags, list(q), math.nan, math.nan, math.nan)


def _status(link, sim, mav):
    """Step to the next status time and decode the GIMBAL_DEVICE_ATTITUDE_STATUS the link sends."""
    from pymavlink.dialects.v20 import common as mavlink

    while True:
        sim.step(np.zeros(4))
        out = link.status(sim.time_us, sim.data, sim.vehicle.sensor_truth(sim.data).r_ned_frd, mav)
        if out:
            return mavlink.MAVLink(None).parse_buffer(out)[0]


def test_the_simulator_link_points_the_gimbal_and_reports_what_its_encoders_say():
    """GIMBAL_DEVICE_SET_ATTITUDE in (a yaw locked to the earth, then back to neutral), the status out: the
    attitude it holds, in the frame its flags say; a quaternion that is no rotation is refused, nothing moves."""
    from pymavlink.dialects.v20 import common as mavlink

    from sitl.gimbal_link import GimbalDeviceLink

    sim = _airborne(QUAD, 10.0, 5.0, 40.0)
    link, mav = GimbalDeviceLink(sim.vehicle.gimbal), mavlink.MAVLink(None, 1, 200)
    want = from_euler(0.0, math.radians(-60.0), math.radians(90.0))  # 60 deg down, facing East
    assert link.handle(_set_attitude(want, mavlink.GIMBAL_DEVICE_FLAGS_YAW_LOCK))
    for _ in range(40):  # 0.8 s
        st = _status(link, sim, mav)
    assert st.flags & mavlink.GIMBAL_DEVICE_FLAGS_YAW_IN_EARTH_FRAME
    err = to_matrix(np.array(st.q)).T @ to_matrix(want)
    assert math.degrees(math.acos(min(1.0, (np.trace(err) - 1) / 2))) < 0.3
    assert st.failure_flags == 0 and st.delta_yaw == pytest.approx(math.radians(40.0), abs=0.02)
    held = sim.vehicle.gimbal.setpoint
    assert link.handle(_set_attitude((0.0, 0.0, 0.0, 0.0))) and link.refused == 1
    assert link.handle(_set_attitude((math.nan,) * 4))  # rates only: kept
    assert sim.vehicle.gimbal.setpoint is held
    assert link.handle(_set_attitude((1.0, 0.0, 0.0, 0.0), mavlink.GIMBAL_DEVICE_FLAGS_NEUTRAL))
    for _ in range(40):
        st = _status(link, sim, mav)
    assert st.flags & mavlink.GIMBAL_DEVICE_FLAGS_YAW_IN_VEHICLE_FRAME  # the neutral: down, facing the nose
    down = to_matrix(np.array(st.q)) @ np.array([1.0, 0.0, 0.0])  # the optical axis, heading frame
    assert down[2] == pytest.approx(1.0, abs=1e-4)
    assert not link.handle(mavlink.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3))  # not the device's
