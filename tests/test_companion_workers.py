"""sitl/companion_workers.py: the camera's frames made in a process of their own (SIM_CAM_PROC 1) are the frames made
on a thread of the simulator (0): the same LANDING_TARGET bytes, the same records, the same frames for the video."""

from __future__ import annotations

import math

import mujoco
import numpy as np
import pytest

from mavsim_core.frames import quat_ned_frd_to_enu_flu
from mavsim_core.quaternion import from_euler
from params.vehicle import load_vehicle
from sitl.companion import LockstepCompanion
from sitl.companion_workers import IN_FLIGHT, STATE_FIELDS, StateCopy
from sitl.sim_settings import CameraSettings, UgvSettings
from sitl.simulation import Simulation

HOME = (47.4, 8.5, 400.0)
QUAD = load_vehicle("quad_x")
STEP_US = 4_000


class MediaRecorder:
    """A camera's media that wants every third frame and keeps what it is given (time, a checksum, detected)."""

    home = HOME

    def __init__(self) -> None:
        self.frames: list[tuple[int, int, bool]] = []

    def wants(self, time_us: int) -> bool:
        return (time_us // 50_000) % 3 == 0

    def frame(self, rgb, time_us, pose, detection=None) -> None:
        self.frames.append((time_us, int(np.asarray(rgb, dtype=np.int64).sum()), detection is not None))


def fly_over_the_deck(process: int, periods: int = 400, render: int = 1, media: bool = False):
    """A vehicle swept over a still deck (its pose set every period, tilted and turning; the gimbal holding the
    camera down), the companion stepped each period: its messages and frame records, and the media's frames."""
    ugv = UgvSettings(enabled=1, north_m=3.0, east_m=0.0, yaw_deg=20.0, path=0)
    sim = Simulation(QUAD, HOME, seed=3, ugv=ugv)
    v = sim.vehicle
    settings = CameraSettings(latency_ms=50, process=process, render=render)
    companion = LockstepCompanion(sim.model, QUAD.camera, settings, seed=5, pad=ugv.pad())
    recorder = MediaRecorder() if media else None
    companion.media = recorder  # type: ignore[assignment]
    records, out = [], []
    companion.on_frame = records.append
    try:
        for k in range(periods):
            t = k * STEP_US * 1e-6
            east, north = v.start_xy_enu[0] + 0.6 * math.sin(1.3 * t), v.start_xy_enu[1] + 3.0 + 0.8 * math.cos(t)
            sim.data.qpos[0:3] = [east, north, 2.6 - 0.7 * t]
            q = from_euler(math.radians(15.0 * math.sin(2.1 * t)), math.radians(-10.0 * math.cos(1.7 * t)), 0.4 * t)
            sim.data.qpos[3:7] = quat_ned_frd_to_enu_flu(q)
            mujoco.mj_forward(sim.model, sim.data)
            v.gimbal.place(sim.data, v.sensor_truth(sim.data).r_ned_frd)
            mujoco.mj_forward(sim.model, sim.data)
            out.append(companion.step(sim.data, k * STEP_US))
    finally:
        companion.close()
    return out, records, (recorder.frames if recorder else None), companion.stats


def test_the_state_a_frame_is_drawn_from_survives_the_pipe():
    ugv = UgvSettings(enabled=1, north_m=3.0, path=2, speed_m_s=2.0)
    sim = Simulation(QUAD, HOME, seed=1, ugv=ugv)
    for _ in range(50):
        sim.step(np.full(4, 0.6))
    copy = StateCopy(sim.model)
    other = mujoco.MjData(sim.model)
    copy.unpack(copy.pack(sim.data), other)
    assert other.time == sim.data.time > 0.0
    for name in STATE_FIELDS:
        np.testing.assert_array_equal(getattr(other, name), getattr(sim.data, name), err_msg=name)


@pytest.mark.parametrize("render", [1, 0])
def test_a_process_of_its_own_makes_the_frames_the_thread_makes(render):
    """The same seed and poses: byte for byte the same LANDING_TARGETs at the same periods, the same records, the
    same statistics of detections (MuJoCo's render, SIM_CAM_RENDER 0, and the fast one, 1)."""
    thread_out, thread_records, _, thread_stats = fly_over_the_deck(0, render=render)
    proc_out, proc_records, _, proc_stats = fly_over_the_deck(1, render=render)
    assert sum(1 for b in thread_out if b) >= 10  # the marker seen (a test that could not fail otherwise)
    assert proc_out == thread_out
    assert proc_records == thread_records and len(thread_records) >= 30
    assert (proc_stats.frames, proc_stats.detections, proc_stats.not_rendered) == (
        thread_stats.frames,
        thread_stats.detections,
        thread_stats.not_rendered,
    )
    assert proc_stats.pose_err_max_m == thread_stats.pose_err_max_m
    assert proc_stats.markers == thread_stats.markers


def test_the_video_gets_the_same_frames_from_either_worker():
    _, _, thread_media, _ = fly_over_the_deck(0, periods=300, media=True)
    _, _, proc_media, _ = fly_over_the_deck(1, periods=300, media=True)
    assert thread_media and any(seen for *_, seen in thread_media)
    assert proc_media == thread_media


def test_a_worker_holds_at_most_in_flight_captures():
    """A latency longer than IN_FLIGHT camera periods: the captures beyond IN_FLIGHT waiting are dropped."""
    ugv = UgvSettings(enabled=1, north_m=3.0, path=0)
    sim = Simulation(QUAD, HOME, seed=1, ugv=ugv)
    period_us = round(1e6 / QUAD.camera.rate_hz)
    companion = LockstepCompanion(sim.model, QUAD.camera, CameraSettings(latency_ms=1000, process=1), pad=ugv.pad())
    records = []
    companion.on_frame = records.append
    try:
        for k in range(IN_FLIGHT + 3):
            companion.step(sim.data, k * period_us)
        assert records == []  # none released yet
        companion.step(sim.data, 1_000_000 + IN_FLIGHT * period_us)
    finally:
        companion.close()
    assert [r.time_us for r in records] == [k * period_us for k in range(IN_FLIGHT)]


def test_the_statistics_come_back_after_answers_never_released_counted_or_not():
    """A simulator stopped mid-flight (SIGTERM) may leave answers in the pipe, one perhaps not counted (sent, then
    stopped before counting it): the companion's close still reads the statistics, not a frame's answer."""
    ugv = UgvSettings(enabled=1, north_m=3.0, path=0)
    sim = Simulation(QUAD, HOME, seed=1, ugv=ugv)
    companion = LockstepCompanion(sim.model, QUAD.camera, CameraSettings(latency_ms=200, process=1), pad=ugv.pad())
    worker = companion._worker
    companion.step(sim.data, 0)  # captured, not released
    worker._conn.send((50_000, 2.0, False, worker._state.pack(sim.data)))  # sent, never counted
    companion.close()
    assert companion.stats.frames == 2 and hasattr(companion.stats, "line")
