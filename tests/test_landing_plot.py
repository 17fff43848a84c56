"""The camera-frame log (sitl/truth_log.py's ``.frames.npy``: the gimbal's angles and the markers used per frame)
written and read back, and the landing figure's panels drawn from it (gcs/plot_landing.py)."""

from __future__ import annotations

import math
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest

from gcs.flight_logs import FlightData, Series, load_truth_log
from gcs.frame_log import frames_beside, frames_path, frames_using, marker_ids
from gcs.plot_landing import fig_landing, has_landing
from sitl.truth_log import MAX_FRAME_MARKERS, CameraFrame, TruthRecorder

IDENTITY = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
GIMBAL_RPY_RAD = (math.radians(5.0), math.radians(-80.0), math.radians(12.5))


@pytest.fixture
def plt():
    """matplotlib's pyplot on the Agg backend, imported by the tests that draw (not at collection: every xdist
    worker collects every file, and matplotlib costs about a second of imports)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot

    return matplotlib.pyplot


def _truth(k: int) -> SimpleNamespace:
    """A :class:`sitl.simulation.SensorTruth` stand-in: level, 2 m up, drifting north."""
    return SimpleNamespace(
        r_ned_frd=IDENTITY, pos_ned_m=(0.01 * k, 0.0, -2.0), vel_ned_m_s=(0.5, 0.0, 0.0), rate_frd_rad_s=(0.0,) * 3
    )


def _ugv(k: int) -> SimpleNamespace:
    return SimpleNamespace(
        deck_pos_ned_m=np.array([0.012 * k, 0.1, -0.5]), vel_ned_m_s=np.array([0.6, 0.0, 0.0]), yaw_rad=0.0
    )


def _fly(log_dir: Path, frames: dict[int, CameraFrame]) -> TruthRecorder:
    """450 periods of 4 ms, armed from period 10 to 150 (the log closes 1 s after); ``frames`` by period."""
    rec = TruthRecorder(log_dir, 4, ugv=True)
    for k in range(450):
        if k in frames:  # the companion releases a frame before the period's truth (sitl/lockstep.py)
            rec.record_frame(frames[k])
        rec.record(4000 * k, _truth(k), 10 <= k < 150, [0.5] * 4, _ugv(k))
    rec.close()
    return rec


def _frame(k: int, ids: tuple[int, ...], rendered: bool = True, gimbal=GIMBAL_RPY_RAD) -> CameraFrame:
    return CameraFrame(4000 * k - 40_000, gimbal, rendered, ids)  # captured 40 ms before its release


def test_camera_frames_round_trip_beside_the_truth_log(tmp_path):
    frames = {
        5: _frame(5, (76,)),  # before arming: no log open, dropped
        20: _frame(20, (76, 42)),
        30: _frame(30, ()),
        40: _frame(40, (), rendered=False),
        50: _frame(50, tuple(range(MAX_FRAME_MARKERS + 2))),  # more than the columns: the first ones kept
        60: _frame(60, (42,), gimbal=None),  # a fixed camera
        420: _frame(420, (76,)),  # after the log closed (1 s after disarming): dropped
    }
    rec = _fly(tmp_path, frames)
    truth_path = next(p for p in rec.files if p.name.endswith(".truth.npy"))
    assert frames_path(truth_path) in rec.files and len(rec.files) == 2
    t_s, cols = frames_beside(truth_path)
    assert t_s.tolist() == pytest.approx([(4000 * k - 40_000) / 1e6 for k in (20, 30, 40, 50, 60)])
    assert cols["gimbal_roll_deg"][0] == pytest.approx(5.0)
    assert cols["gimbal_pitch_deg"][0] == pytest.approx(-80.0)
    assert cols["gimbal_yaw_deg"][0] == pytest.approx(12.5)
    assert np.isnan([cols[k][4] for k in ("gimbal_roll_deg", "gimbal_pitch_deg", "gimbal_yaw_deg")]).all()
    assert cols["rendered"].tolist() == [1, 1, 0, 1, 1]
    assert cols["n_markers"].tolist() == [2, 0, 0, MAX_FRAME_MARKERS, 1]
    assert [cols["marker_0"][0], cols["marker_1"][0], cols["marker_2"][0]] == [76, 42, -1]
    assert [cols[f"marker_{i}"][3] for i in range(MAX_FRAME_MARKERS)] == list(range(MAX_FRAME_MARKERS))
    assert marker_ids(cols).tolist() == list(range(MAX_FRAME_MARKERS)) + [42, 76]
    assert frames_using(cols, 42).tolist() == [True, False, False, False, True]
    assert "ugv_n_m" in load_truth_log(truth_path).cols  # the truth log itself unchanged


def test_a_truth_log_without_camera_frames_has_none(tmp_path):
    rec = _fly(tmp_path, {})
    assert len(rec.files) == 1 and frames_beside(rec.files[0]) is None


def _landing_data(frames: Series | None) -> FlightData:
    """A synthetic precision landing of 10 s with its truth; ``frames`` the camera's, or None (an older log)."""
    t = np.arange(0.0, 10.0, 0.02)
    truth = Series(
        t,
        dict(n_m=0.5 * t, e_m=0.0 * t, ugv_n_m=0.5 * t + 1.0 / (1 + t), ugv_e_m=0.0 * t, armed=(t < 9.0) * 1.0),
    )
    landing = Series(t, dict(tgt_n_m=1.0 / (1 + t), tgt_e_m=0.0 * t, precland_phase=np.minimum(t // 2 + 1, 7)))
    return FlightData(name="synthetic", truth=truth, landing=landing, frames=frames)


def _frames(gimbal: bool = True) -> Series:
    """Camera frames at 10 Hz: marker 76 then 76 and 42 then 42 alone, nothing in the first second."""
    t = np.arange(0.0, 10.0, 0.1)
    ids = np.full((t.size, MAX_FRAME_MARKERS), -1.0)
    ids[(t >= 1) & (t < 6), 0] = 76
    ids[(t >= 4) & (t < 6), 1] = 42
    ids[t >= 6, 0] = 42
    angle = (lambda a: a) if gimbal else (lambda a: np.full_like(a, np.nan))
    cols = dict(
        gimbal_roll_deg=angle(np.sin(t)),
        gimbal_pitch_deg=angle(-90.0 + t),
        gimbal_yaw_deg=angle(0.5 * t),
        rendered=(t >= 0.5) * 1.0,
        n_markers=(ids >= 0).sum(axis=1).astype(float),
        **{f"marker_{i}": ids[:, i] for i in range(MAX_FRAME_MARKERS)},
    )
    return Series(t, cols)


def _axis(fig, ylabel: str):
    found = [ax for ax in fig.axes if ax.get_ylabel() == ylabel]
    return found[0] if found else None


def test_the_landing_figure_shows_the_gimbal_and_the_markers_used(plt):
    data = _landing_data(_frames())
    assert has_landing(data)
    fig = fig_landing(plt, data)
    try:
        gimbal, markers = _axis(fig, "gimbal joint\nangle, deg"), _axis(fig, "markers used")
        assert gimbal is not None and markers is not None and len(fig.axes) == 5
        err = _axis(fig, "horizontal distance\nto the marker, m")
        assert gimbal.get_shared_x_axes().joined(gimbal, err) and markers.get_shared_x_axes().joined(markers, err)
        lines = {line.get_label(): line for line in gimbal.get_lines()}
        assert set(lines) == {"roll", "pitch", "yaw"}
        assert lines["pitch"].get_ydata()[0] == pytest.approx(-90.0)
        assert [tick.get_text() for tick in markers.get_yticklabels()] == ["none", "id 42", "id 76"]
        rows = {
            (int(ln.get_ydata()[0]), ln.get_marker()): ln.get_xdata()
            for ln in markers.get_lines()
            if len(ln.get_xdata())
        }
        t = data.frames.t_s
        assert np.array_equal(rows[2, "|"], t[(t >= 1) & (t < 6)])  # id 76 used from 1 s to 6 s
        assert np.array_equal(rows[1, "|"], t[t >= 4])  # id 42 from 4 s on
        assert np.array_equal(rows[0, "."], t[(t >= 0.5) & (t < 1)])  # rendered, no marker used
        assert np.array_equal(rows[0, "x"], t[t < 0.5])  # not rendered (the pad out of view)
        assert markers.get_xlabel() == "simulated time, s"
    finally:
        plt.close(fig)


def test_the_landing_figure_of_a_fixed_camera_says_so(plt):
    fig = fig_landing(plt, _landing_data(_frames(gimbal=False)))
    try:
        gimbal = _axis(fig, "gimbal joint\nangle, deg")
        assert not gimbal.get_lines() and [t.get_text() for t in gimbal.texts] == ["fixed camera (no gimbal)"]
    finally:
        plt.close(fig)


def test_an_older_log_without_camera_frames_still_plots_as_before(plt, tmp_path):
    fig = fig_landing(plt, _landing_data(None))
    try:
        assert len(fig.axes) == 3 and _axis(fig, "gimbal joint\nangle, deg") is None
        assert _axis(fig, "phase").get_xlabel() == "simulated time, s"
        fig.savefig(tmp_path / "landing.png")
        assert (tmp_path / "landing.png").stat().st_size > 10_000
    finally:
        plt.close(fig)
