"""``campaign report`` (campaign/report.py): Wilson intervals, the table per cell, the plots."""

from __future__ import annotations

import math

import pytest
from test_campaign_results import CAMPAIGN, fake_rows, write

from campaign import report, spec
from campaign.__main__ import main


@pytest.mark.parametrize(
    "k,n,low,high",
    [(0, 10, 0.0, 0.2775), (10, 10, 0.7225, 1.0), (5, 10, 0.2366, 0.7634), (18, 20, 0.6990, 0.9721)],
)
def test_wilson_interval_matches_the_textbook_values(k, n, low, high):
    lo, hi = report.wilson(k, n)
    assert (lo, hi) == (pytest.approx(low, abs=1e-4), pytest.approx(high, abs=1e-4))


def test_wilson_of_no_runs_is_undefined():
    assert all(math.isnan(x) for x in report.wilson(0, 0))


def test_the_table_per_cell(tmp_path):
    c = spec.from_dict({**CAMPAIGN, "runs": 4})
    rows = fake_rows(c, ["ok", "ok", "flight_failed", "infra_failed", "ok", "ok", "ok", "ok"])
    write(tmp_path / "r.csv", c, rows)
    stats = report.cells(report.load(tmp_path / "r.csv"))
    pad, line = stats
    label = "quad_x static pad calm gimbal camera nested pad"
    assert (pad.label, pad.runs, pad.successes, pad.infra_failed) == (label, 3, 2, 1)
    assert pad.ci95 == report.wilson(2, 3)
    assert pad.err_mean_m == pytest.approx(0.01)  # 0, 0.01, 0.02: the infra failure is no flight
    assert pad.err_max_m == pytest.approx(0.02)
    assert (line.runs, line.successes) == (4, 4)
    text = report.table(stats)
    assert text.splitlines()[1].split()[:12] == label.split() + ["3", "2/3", "67%", "21-94%"]
    assert "quad_x line 1 m/s calm gimbal camera nested pad" in text.splitlines()[2]


def test_report_command_prints_the_table_and_writes_the_plots(tmp_path, capsys):
    c = spec.from_dict(CAMPAIGN)
    write(tmp_path / "r.csv", c, fake_rows(c, ["ok", "flight_failed", "ok", "ok"]))
    assert main(["report", str(tmp_path / "r.csv"), "--plots", str(tmp_path / "plots")]) == 0
    out = capsys.readouterr().out
    assert "quad_x static pad calm gimbal camera nested pad" in out and "95% CI" in out
    names = sorted(p.name for p in (tmp_path / "plots").iterdir())
    assert names == ["errors.png", "success_vs_speed.png", "success_vs_wind.png"]
    assert all((tmp_path / "plots" / n).stat().st_size > 5000 for n in names)


def test_the_plots_of_cells_that_all_succeeded(tmp_path):
    """10 of 10: the Wilson interval's top rounds a hair below 100 %; the plot once refused the negative bar."""
    c = spec.from_dict({**CAMPAIGN, "runs": 10})
    write(tmp_path / "r.csv", c, fake_rows(c, ["ok"] * 20))
    assert main(["report", str(tmp_path / "r.csv"), "--plots", str(tmp_path / "plots")]) == 0
    assert (tmp_path / "plots" / "success_vs_speed.png").stat().st_size > 5000


def test_report_of_a_file_that_is_not_results_fails_with_one_line(tmp_path, capsys):
    (tmp_path / "x.csv").write_text("a,b\n1,2\n")
    assert main(["report", str(tmp_path / "x.csv")]) == 1
    err = capsys.readouterr().err
    assert err.startswith(f"campaign: {tmp_path / 'x.csv'}: ") and err.count("\n") == 1


def test_camera_and_pad_cells_each_have_their_line_and_their_plot_series(tmp_path, capsys):
    c = spec.from_dict({**CAMPAIGN, "grid": {**CAMPAIGN["grid"], "camera": ["gimbal", "fixed"], "pad": ["single"]}})
    write(tmp_path / "r.csv", c, fake_rows(c, ["ok", "ok", "flight_failed", "flight_failed"] * 2))
    stats = report.cells(report.load(tmp_path / "r.csv"))
    assert [(s.label, s.successes) for s in stats] == [
        ("quad_x static pad calm gimbal camera single pad", 2),
        ("quad_x static pad calm fixed camera single pad", 0),
        ("quad_x line 1 m/s calm gimbal camera single pad", 2),
        ("quad_x line 1 m/s calm fixed camera single pad", 0),
    ]
    from campaign.plots import _series

    rows = [r for s in stats for r in s.rows]
    assert _series(rows, ("vehicle",)) == ("vehicle", "camera", "pad")  # the gimbal's and the fixed camera's apart
    assert main(["report", str(tmp_path / "r.csv"), "--plots", str(tmp_path / "plots")]) == 0
    assert "fixed camera single pad" in capsys.readouterr().out


def test_a_landing_results_file_from_before_the_camera_and_pad_axes_is_still_reported(tmp_path):
    """Written without the camera and pad columns: still the landing kind's, its error and time columns found."""
    c = spec.from_dict(CAMPAIGN)
    write(tmp_path / "r.csv", c, fake_rows(c, ["ok", "ok", "ok", "ok"]))
    lines = (tmp_path / "r.csv").read_text().splitlines()
    header = lines[0].split(",")
    drop = [header.index("camera"), header.index("pad")]
    old = "\n".join(",".join(f for k, f in enumerate(line.split(",")) if k not in drop) for line in lines) + "\n"
    (tmp_path / "old.csv").write_text(old)
    rows = report.load(tmp_path / "old.csv")
    assert "camera" not in rows[0]
    assert report.figure_columns(rows)[:2] == ("touchdown_error_m", "time_to_land_s")
    assert report.cells(rows)[1].err_mean_m == pytest.approx(0.025)
