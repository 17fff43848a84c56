"""The campaign kinds ``hover_step`` (campaign/hover_step.py) and ``mission`` (campaign/mission_kind.py):
their campaign files, their cells, their checks, their pure measuring functions and the report on their
results.  Nothing flies here (tests/test_e2e_campaign_kinds.py flies a hover_step campaign)."""

from __future__ import annotations

import math
import tomllib
from pathlib import Path

import numpy as np
import pytest
from test_campaign_results import write

from campaign import plan, report, spec
from campaign.__main__ import main
from campaign.hover_step import fault_parameters, step_figures, windy_parameters
from campaign.mission_kind import square_figures
from campaign.results import tag
from campaign.runs import Settings, row

CAMPAIGNS = Path(__file__).resolve().parents[1] / "benchmarks" / "campaigns"


def test_the_campaign_files_expand_into_their_cells_the_same_way_every_time():
    hover = spec.load(CAMPAIGNS / "hover_step.toml")
    runs = plan.expand(hover)
    assert list(dict.fromkeys(r.label for r in runs)) == [
        "quad_x wind 0 m/s hover 30 s",
        "quad_x wind 5 m/s hover 30 s",
        "firefly wind 0 m/s hover 30 s",
        "firefly wind 5 m/s hover 30 s",
    ]
    assert len(runs) == 20 and runs == plan.expand(spec.load(CAMPAIGNS / "hover_step.toml"))
    assert len({r.draws["sim_seed"] for r in runs}) == 20  # every run its own simulator seed
    mission = plan.expand(spec.load(CAMPAIGNS / "mission.toml"))
    assert list(dict.fromkeys(r.label for r in mission)) == [
        "quad_x 15 m square calm",
        "quad_x 15 m square windy",
        "quad_x 30 m square calm",
        "quad_x 30 m square windy",
    ]
    assert [r.run_id for r in mission[:4]] == ["c000-r0000", "c000-r0001", "c000-r0002", "c001-r0000"]


def test_axis_values_and_their_labels():
    c = spec.from_dict(
        {"kind": "hover_step", "runs": 1, "grid": {"vehicle": ["firefly"], "fault": ["none", "motor1_70"]}}
    )
    assert [r.label for r in plan.expand(c)] == [
        "firefly wind 5 m/s hover 30 s",
        "firefly wind 5 m/s motor1_70 hover 30 s",
    ]
    assert fault_parameters("motor1_70") == {"SIM_ENGINE_FAIL": 1, "SIM_ENGINE_MUL": 0.7}
    assert fault_parameters("none") == {}
    m = spec.from_dict({"kind": "mission", "runs": 1, "grid": {"speed": ["max", 2]}})
    assert [r.label for r in plan.expand(m)] == ["quad_x 30 m square calm", "quad_x 30 m square calm at 2x"]


def test_the_wind_axis_scales_the_windy_scenario():
    scenario = tomllib.loads((Path(__file__).resolve().parents[1] / "params/scenarios/windy.toml").read_text())
    assert windy_parameters() == scenario["parameters"]
    half = windy_parameters(2.5)
    assert (half["SIM_WIND_SPD"], half["SIM_WIND_TURB"], half["SIM_GUST_SPD"]) == (2.5, 0.5, 1.0)
    assert half["SIM_WIND_DIR"] == 270.0 and half["SIM_GUST_INT"] == scenario["parameters"]["SIM_GUST_INT"]


def first_order(t: np.ndarray, step_m: float, tau_s: float) -> np.ndarray:
    return step_m * (1.0 - np.exp(-t / tau_s))


def test_step_figures_of_a_response_that_settles():
    t = np.arange(0.0, 25.0, 0.02)  # 50 Hz, as the truth
    f = step_figures(t, first_order(t, 10.0, 1.0), 10.0)
    assert f["step_rise_s"] == pytest.approx(math.log(9.0), abs=0.03)  # 10 % to 90 % of a first-order lag
    assert f["step_overshoot_pct"] == 0.0
    # the centred 1 s average of 10 (1 - exp(-t)) is 10 - 10 exp(-t) sinh(0.5) / 0.5: within 0.1 m of 10 m from
    assert f["step_settle_s"] == pytest.approx(math.log(100.0 * math.sinh(0.5) / 0.5), abs=0.03)
    assert f["step_final_err_m"] == pytest.approx(0.0, abs=1e-6)


def test_step_figures_of_a_response_that_never_settles_or_overshoots():
    t = np.arange(0.0, 25.0, 0.02)
    short = step_figures(t, first_order(t, 9.7, 1.0), 10.0)  # stops 0.3 m short
    assert math.isnan(short["step_settle_s"]) and short["step_final_err_m"] == pytest.approx(0.3, abs=1e-3)
    zeta, omega = 0.3, 2.0  # an underdamped second-order response: overshoot exp(-pi zeta / sqrt(1 - zeta^2))
    wd, k = omega * math.sqrt(1 - zeta**2), zeta / math.sqrt(1 - zeta**2)
    over = step_figures(t, 10.0 * (1 - np.exp(-zeta * omega * t) * (np.cos(wd * t) + k * np.sin(wd * t))), 10.0)
    assert over["step_overshoot_pct"] == pytest.approx(100 * math.exp(-math.pi * k), abs=0.2)
    assert 5.0 < over["step_settle_s"] < 9.0  # its envelope is within 1 % after ~7.7 s


def test_square_figures_from_the_legs():
    side = 30.0
    along = np.linspace(0.0, side, 61)
    on_square = np.concatenate([np.c_[0 * along + side, along], np.c_[side - along, 0 * along + side]])  # legs 2, 3
    f = square_figures(on_square, np.full(len(on_square), 2.0), side)
    assert f["xtrack_rms_m"] == pytest.approx(0.0) and f["xtrack_max_m"] == pytest.approx(0.0)
    assert f["mean_speed_m_s"] == 2.0
    assert [f[f"corner{k}_m"] for k in (1, 2, 3)] == [pytest.approx(0.0)] * 3
    assert f["corner4_m"] == pytest.approx(side)  # the last leg was not flown: its end is the start, 30 m away
    outside = square_figures(on_square[:61] + np.array([0.5, 0.0]), np.ones(61), side)  # 0.5 m North of leg 2
    assert outside["xtrack_rms_m"] == pytest.approx(0.5) and outside["xtrack_max_m"] == pytest.approx(0.5)


def test_the_report_takes_its_error_and_time_columns_from_the_kind(tmp_path, capsys):
    c = spec.from_dict({"kind": "mission", "runs": 2, "grid": {"wind": ["calm", "windy"]}})
    settings = Settings(kind="mission", campaign=tag(c), record=c.record)
    rows = [
        row(r, settings, {"status": "ok", "reason": "", "xtrack_rms_m": 0.1 * (k + 1), "legs_s": 40.0 + k}, 1)
        for k, r in enumerate(plan.expand(c))
    ]
    write(tmp_path / "m.csv", c, rows)
    calm, windy = report.cells(report.load(tmp_path / "m.csv"))
    assert (calm.err_mean_m, calm.err_max_m, calm.time_mean_s) == (pytest.approx(0.15), pytest.approx(0.2), 40.5)
    assert windy.err_mean_m == pytest.approx(0.35)
    assert main(["report", str(tmp_path / "m.csv"), "--plots", str(tmp_path / "plots")]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[0].split()[-3:] == ["legs", "RTF", "infra"]
    assert "no success_vs_speed.png: the results have no UGV speed axis" in out
    assert sorted(p.name for p in (tmp_path / "plots").iterdir()) == ["errors.png", "success_vs_wind.png"]


def test_the_landing_kind_reads_the_simulators_camera_line():
    """campaign.landing.camera_figures parses the line sitl/companion.py prints at exit."""
    from campaign.landing import CAMERA_HZ, camera_figures
    from sitl.companion import CompanionStats

    stats = CompanionStats(frames=400, not_rendered=300, detections=60, render_s=0.9, detect_s=0.1, max_range_m=3.72)
    stats.pose_err_sum_m, stats.pose_err_max_m = 60 * 0.014, 0.083
    figures = camera_figures("[sitl] " + stats.line() + "\n")
    assert figures["detections_per_s"] == pytest.approx(60 / (400 / CAMERA_HZ))
    assert (figures["farthest_m"], figures["pose_err_mean_cm"], figures["pose_err_max_cm"]) == (3.72, 1.4, 8.3)
