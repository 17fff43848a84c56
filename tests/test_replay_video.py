"""Flight videos from the logs (issue 35): ``gcs replay LOG --video FILE.mp4`` and ``flight-demo --video``.

One short real flight (module fixture, marked ``e2e``): the real ``sitl`` with the ground vehicle parked 1.2 m ahead
(so the camera renders and its frame log is written) and ``autopilot`` on a free instance, a client takes off to
2 m and lands; the logs stay in a temp dir.  Its video is rendered small (160x96 at 10 fps) and read back with PyAV
as a user would check it: it decodes, its frame count and duration are the truth log's span at that rate, the
vehicle shows in the chase view and the camera's inset in its corner.  The other tests need no flight.
"""

from __future__ import annotations

import argparse
import math
from pathlib import Path

import av
import numpy as np
import pytest

from gcs.__main__ import main as gcs_main
from gcs.launcher import replay
from mavsim_core.npy_log import read_npy_log
from sitl.flight_setup import FlightSetup, guess_setup, read_setup, setup_path
from sitl.replay_video import StatusTrack, frame_count

from e2e_flight_helpers import CLIENT_SPEED  # tests/e2e_flight_helpers.py

WAIT_S = 90.0
SIZE, FPS = (160, 96), 10.0
# the parked ground vehicle ahead; no video stream (nobody watches it here)
UGV_AHEAD = [a for p in ("SIM_UGV_EN=1", "SIM_UGV_X=1.2", "SIM_UGV_SPD=0", "SIM_VID_EN=0") for a in ("--param", p)]


def _decode(path: Path) -> tuple[list[np.ndarray], float, str, str]:
    """Every frame (RGB arrays), the duration (s), the codec and pixel format of an MP4 read with PyAV."""
    with av.open(str(path)) as c:
        stream = c.streams.video[0]
        frames = [f.to_ndarray(format="rgb24") for f in c.decode(stream)]
        return frames, float(stream.duration * stream.time_base), stream.codec_context.name, stream.format.name


# --------------------------------------------------------------------------- no flight needed


def test_replay_of_a_folder_without_a_truth_log_says_so_in_one_line(tmp_path, capsys):
    (tmp_path / "2026-01-02_03-04-05.ulg").write_bytes(b"")  # a flight controller's log is not enough
    rc = gcs_main(["replay", str(tmp_path), "--video", str(tmp_path / "out.mp4")])
    out = capsys.readouterr()
    assert rc == 1
    assert out.out == "" and out.err.count("\n") == 1 and ".truth.npy" in out.err and str(tmp_path) in out.err
    assert not (tmp_path / "out.mp4").exists()


def test_the_flight_setup_round_trips_and_old_flights_get_a_guess(tmp_path):
    setup = FlightSetup("quad_x", "", "", "gimbal", True, ((76, 0.333, 0.3, -0.3),), sim_params={"SIM_UGV_EN": 1.0})
    truth = tmp_path / "2026-01-02_03-04-05_i7.truth.npy"
    assert setup_path(truth).name == "2026-01-02_03-04-05_i7.sim.json"
    setup_path(truth).write_text(setup.to_json())
    back = read_setup(truth)
    assert back == setup and back.pad_layout().pad_id == 76 and back.vehicle_spec().camera.gimballed
    assert read_setup(tmp_path / "other.truth.npy") is None
    guess, note = guess_setup(6, ugv=True, gimbal=False, marker_ids={76})
    assert guess.vehicle_name == "firefly" and guess.camera_mount == "fixed" and guess.pad_layout().pad_id == 76
    assert "firefly" in note and "single pad" in note


def test_frames_cover_the_log_to_within_one_frame_and_the_status_steps():
    for t0, t1, fps in ((4.02, 16.18, 25.0), (0.0, 1.0, 10.0), (3.0, 3.004, 25.0)):
        n = frame_count(t0, t1, fps)
        assert t0 + (n - 1) / fps <= t1 + 1e-9 and 0 <= n / fps - (t1 - t0) <= 1 / fps + 1e-9
    track = StatusTrack(((1.0, "TAKEOFF"), (5.0, "PRECLAND")), ((6.0, "tracking"), (9.0, "")))
    assert track.at(0.5) == ("", "") and track.at(5.5) == ("PRECLAND", "") and track.at(7.0) == ("PRECLAND", "tracking")
    assert track.at(9.5) == ("PRECLAND", "")


def test_the_chase_camera_eases_towards_the_vehicle_and_turns_the_short_way():
    from sitl.replay_scene import ChaseCamera, Pose

    cam = ChaseCamera()
    first = cam.view(0.0, Pose((0.0, 0.0, -2.0), (0.0, 0.0, math.radians(179.0))))
    assert first.lookat_enu_m == pytest.approx((0.0, 0.0, 2.0)) and first.azimuth_deg == pytest.approx(-89.0)
    later = cam.view(0.04, Pose((1.0, 0.0, -2.0), (0.0, 0.0, math.radians(-179.0))))  # 1 m north, heading past 180
    assert 0.05 < later.lookat_enu_m[1] < 0.5 and later.lookat_enu_m[0] == pytest.approx(0.0)  # part of the way
    assert -89.2 < later.azimuth_deg < -89.0  # towards -91 deg (2 deg away), not round by 358
    near = cam.view(1.0, Pose((1.0, 0.0, -2.0), (0.0, 0.0, 0.0), deck_ned_m=(5.0, 0.0, -0.3)))
    assert near.distance_m > first.distance_m  # the deck 4 m ahead: the camera backs off to frame both


def test_the_replay_puts_the_bodies_where_the_simulator_had_them():
    """The simulator's world in an arbitrary state, its truth as the truth log records it (NED from the start point,
    ZYX angles), and the replay's world posed from that truth: the multicopter and the UGV in the same places and
    attitudes (the replay's origin is the multicopter's start point, the simulator's a few millimetres off)."""
    import mujoco

    from mavsim_core.quaternion import to_euler
    from params.vehicle import load_vehicle
    from sitl.replay_scene import Pose, ReplayScene
    from sitl.sim_settings import UgvSettings
    from sitl.simulation import Simulation

    spec = load_vehicle("quad_x")
    sim = Simulation(spec, (47.0, 8.0, 400.0), ugv=UgvSettings(enabled=1, north_m=3.0, east_m=-1.0, yaw_deg=30.0))
    q, v = sim.data.qpos, sim.vehicle.qadr
    q[v : v + 3] += (1.5, -2.0, 3.0)  # ENU: east, north, up
    q[v + 3 : v + 7] = (0.9, 0.1, -0.2, 0.35)
    q[v + 3 : v + 7] /= np.linalg.norm(q[v + 3 : v + 7])
    mujoco.mj_forward(sim.model, sim.data)
    truth, ugv = sim.truth(), sim.ugv_truth()
    pose = Pose(tuple(truth.pos_ned_m), to_euler(truth.q_ned_frd), tuple(ugv.deck_pos_ned_m), ugv.yaw_rad)
    scene = ReplayScene(spec.with_camera_mount("fixed"), sim.ugv_settings.pad(), (64, 48))
    try:
        scene.place(pose)
        e0, n0 = sim.vehicle.start_xy_enu
        for body in ("vehicle", "ugv"):
            a, b = sim.model.body(body).id, scene.model.body(body).id
            assert scene.data.xpos[b] == pytest.approx(sim.data.xpos[a] - (e0, n0, 0.0), abs=1e-4), body
            qa, qb = sim.data.xquat[a], scene.data.xquat[b]
            assert abs(float(np.dot(qa, qb))) == pytest.approx(1.0, abs=1e-6), body
    finally:
        scene.close()


# --------------------------------------------------------------------------- a real flight


@pytest.fixture(scope="module")
def flight(tmp_path_factory, free_instance) -> Path:
    """The log directory of a hop (take off to 2 m, land) beside the parked ground vehicle."""
    from gcs.client import VehicleClient
    from gcs.launcher import Stack

    logs = tmp_path_factory.mktemp("replay") / "logs"
    extra = ["--truth-port", "0", *UGV_AHEAD]
    with Stack(instance=free_instance(), speed=CLIENT_SPEED, log_dir=logs, extra_sitl_args=extra) as stack:
        with VehicleClient(stack.api_url, timeout_s=WAIT_S, idle=stack.check_alive) as c:
            c.wait_until(c.prearm_ok, WAIT_S, "ready to arm")
            home = c.wait_home(WAIT_S)
            c.arm().check()
            c.wait_armed(True, WAIT_S)
            c.takeoff(home.alt_amsl_m + 2.0).check()
            c.wait_until(lambda: c.takeoff_done(2.0), WAIT_S, "takeoff to 2 m")
            c.land().check()
            c.wait_until(c.landed_and_disarmed, WAIT_S, "landed and disarmed")
    return logs


def _truth_span_s(logs: Path) -> float:
    t = read_npy_log(next(logs.glob("*.truth.npy")))["time_us"] / 1e6
    return float(t[-1] - t[0])


@pytest.mark.e2e
def test_the_simulator_writes_the_flights_setup_beside_its_truth_log(flight):
    (truth,) = flight.glob("*.truth.npy")
    setup = read_setup(truth)
    assert setup is not None and setup.vehicle_name == "quad_x" and setup.ugv and len(setup.pad) == 5
    assert setup.sim_params["SIM_UGV_X"] == pytest.approx(1.2) and "name = " in setup.vehicle_toml
    assert truth.with_name(truth.name.replace(".truth.npy", ".frames.npy")).exists()  # the camera's frame log


@pytest.mark.e2e
def test_replay_video_decodes_spans_the_flight_and_shows_the_vehicle_and_the_camera(flight, tmp_path, capsys):
    videos = {}
    for name, extra in (("inset", []), ("plain", ["--no-inset"])):
        videos[name] = tmp_path / f"{name}.mp4"
        args = ["replay", str(flight), "--video", str(videos[name]), "--size", "160x96", "--fps", str(FPS)]
        assert gcs_main([*args, "--no-progress", *extra]) == 0
    out = capsys.readouterr().out
    assert "with the camera inset" in out and "no camera inset" in out and "note:" not in out  # setup and FC log found

    span = _truth_span_s(flight)
    frames, duration, codec, pix_fmt = _decode(videos["inset"])
    plain, _, _, _ = _decode(videos["plain"])
    assert (codec, pix_fmt) == ("h264", "yuv420p")
    assert len(frames) == len(plain) == math.floor(span * FPS + 1e-9) + 1
    assert span <= duration <= span + 1 / FPS + 1e-6
    assert all(f.shape == (SIZE[1], SIZE[0], 3) for f in frames)
    w, h = SIZE
    middle = [f[h // 4 : 3 * h // 4, w // 4 : 3 * w // 4] for f in plain]
    assert all(m.std() > 8 for m in middle)  # not one flat colour
    assert all((m.max(axis=2) < 90).any() for m in middle)  # the vehicle's dark frame, never the lit ground
    corner = (slice(h - h // 2, h), slice(w - w // 3, w))  # the inset: the bottom-right corner
    rest = (slice(h // 5, h // 2), slice(0, w // 2))  # left of and above it: the same chase view in both
    inset_diff = [np.abs(a[corner].astype(int) - b[corner]).mean() for a, b in zip(frames, plain)]
    rest_diff = [np.abs(a[rest].astype(int) - b[rest]).mean() for a, b in zip(frames, plain)]
    assert min(inset_diff) > 12 and max(rest_diff) < 6  # the inset in every frame, nowhere else (x264 noise: ~3)


@pytest.mark.e2e
def test_flight_demo_video_renders_the_demos_flight(flight, tmp_path, monkeypatch):
    monkeypatch.setattr(replay, "DEFAULT_SIZE", SIZE)  # the demo's size and rate, small for the test
    monkeypatch.setattr(replay, "DEFAULT_FPS", FPS)
    args = argparse.Namespace(video=str(tmp_path / "demo.mp4"), count=1, log_dir=str(flight), instance=0, wait=False)
    flown = []
    assert replay.demo_with_video(args, lambda a: flown.append(a) or 0) == 0  # a demo that flew and succeeded
    assert flown == [args]
    frames, _, _, _ = _decode(tmp_path / "demo.mp4")
    assert len(frames) == math.floor(_truth_span_s(flight) * FPS + 1e-9) + 1
    assert replay.demo_with_video(argparse.Namespace(**{**vars(args), "count": 2}), lambda a: 0) == 2  # one vehicle
