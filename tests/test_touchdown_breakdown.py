"""``benchmarks/touchdown_analysis.py``'s offset breakdown: a landing's offset from the deck's centre (truth) split into
the setpoint's aim, the position loop's tracking error and the target estimate's error, which add up to it, in the
UGV's frame, whatever the flight controller's frame is shifted by (an estimator's origin off the truth's)."""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

import numpy as np
import pytest

from gcs.flight_logs import FlightData, Series

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


@pytest.fixture(scope="module")
def analysis():
    sys.path.insert(0, str(BENCHMARKS))  # its ``_cli`` helper, as when it runs as a script
    try:
        spec = importlib.util.spec_from_file_location("touchdown_analysis", BENCHMARKS / "touchdown_analysis.py")
        module = importlib.util.module_from_spec(spec)
        spec.loader.exec_module(module)
        return module
    finally:
        sys.path.remove(str(BENCHMARKS))


def deck_frame_cm(v: np.ndarray, yaw: float) -> tuple[float, float]:
    c, s = math.cos(yaw), math.sin(yaw)
    return 100 * (c * v[0] + s * v[1]), 100 * (-s * v[0] + c * v[1])


def test_the_three_parts_add_up_to_the_offset_on_the_deck_and_a_frame_shift_cancels(analysis):
    yaw = math.radians(30.0)  # the deck drives north-north-east at 2 m/s
    t_s = np.arange(0.0, 3.0, 0.004)
    deck = np.column_stack([2 * math.cos(yaw) * t_s, 2 * math.sin(yaw) * t_s])
    offset = np.array([0.12, -0.05])  # the vehicle, truth, off the deck's centre (NED m)
    truth = np.zeros(len(t_s), dtype=[(k, float) for k in ("pos_n_m", "pos_e_m", "ugv_n_m", "ugv_e_m", "ugv_yaw_rad")]
                     + [("time_us", np.int64)])  # fmt: skip
    truth["time_us"] = np.round(t_s * 1e6)
    truth["ugv_n_m"], truth["ugv_e_m"], truth["ugv_yaw_rad"] = deck[:, 0], deck[:, 1], yaw
    truth["pos_n_m"], truth["pos_e_m"] = deck[:, 0] + offset[0], deck[:, 1] + offset[1]

    shift = np.array([0.4, -0.3])  # the flight controller's frame off the truth's
    est_err = np.array([0.02, 0.01])  # its target estimate (relative to itself) off the truth's
    track_err = np.array([0.06, -0.04])  # its vehicle estimate off its setpoint
    veh = deck + offset + shift
    rel = -offset + est_err  # target minus vehicle, as it estimates it
    sp = veh - track_err
    flight = FlightData(
        name="synthetic",
        estimate=Series(t_s, {"n_m": veh[:, 0], "e_m": veh[:, 1]}),
        setpoint=Series(t_s, {"n_m": sp[:, 0], "e_m": sp[:, 1]}),
        landing=Series(t_s, {"tgt_n_m": np.full(len(t_s), rel[0]), "tgt_e_m": np.full(len(t_s), rel[1])}),
    )
    parts = analysis.offset_parts(flight, truth, len(t_s) - 1)

    for name, vector in (("track", track_err), ("est", est_err), ("aim", offset - track_err - est_err)):
        fwd, right = deck_frame_cm(vector, yaw)
        assert parts[f"{name}_fwd_cm"] == pytest.approx(fwd, abs=1e-6), name
        assert parts[f"{name}_right_cm"] == pytest.approx(right, abs=1e-6), name
    total = [sum(parts[f"{p}_{axis}_cm"] for p in ("aim", "track", "est")) for axis in ("fwd", "right")]
    assert total == pytest.approx(deck_frame_cm(offset, yaw), abs=1e-6)


def test_without_the_flight_controllers_topics_the_parts_are_unknown(analysis):
    truth = np.zeros(3, dtype=[(k, float) for k in ("pos_n_m", "pos_e_m", "ugv_n_m", "ugv_e_m", "ugv_yaw_rad")]
                     + [("time_us", np.int64)])  # fmt: skip
    parts = analysis.offset_parts(FlightData(name="empty"), truth, 2)
    assert all(math.isnan(v) for v in parts.values())
