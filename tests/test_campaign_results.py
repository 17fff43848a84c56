"""The results CSV (campaign/results.py): appended row by row, and what a resume skips."""

from __future__ import annotations

import csv
from pathlib import Path

import pytest

from campaign import plan, runner, spec
from campaign.results import ResultsError, ResultsFile, read, tag
from campaign.runs import Settings, row

CAMPAIGN = {
    "kind": "landing",
    "runs": 2,
    "grid": {"vehicle": ["quad_x"], "wind": ["calm"], "ugv_speed_m_s": [0, 1], "ugv_path": ["line"]},
}


def fake_rows(campaign: spec.Campaign, statuses: list[str]) -> list[dict]:
    """Rows as the runs would give them (made here: nothing flies in this file)."""
    settings = Settings(kind="landing", campaign=tag(campaign), record=campaign.record)
    runs = plan.expand(campaign)
    return [
        row(r, settings, {"status": s, "reason": "", "touchdown_error_m": 0.01 * k, "success": s == "ok"}, 1)
        for k, (r, s) in enumerate(zip(runs, statuses))
    ]


def write(path: Path, campaign: spec.Campaign, rows: list[dict], resume: bool = False) -> set[str]:
    results, done = ResultsFile.open(path, campaign, plan.expand(campaign), resume)
    with results:
        for r in rows:
            results.append(r)
    return done


def test_rows_are_written_in_full_and_read_back(tmp_path):
    c = spec.from_dict(CAMPAIGN)
    rows = fake_rows(c, ["ok", "flight_failed"])
    write(tmp_path / "r.csv", c, rows)
    back = read(tmp_path / "r.csv")
    assert [r["run_id"] for r in back] == ["c000-r0000", "c000-r0001"]
    assert float(back[1]["touchdown_error_m"]) == rows[1]["touchdown_error_m"]  # full precision
    assert back[0]["ugv_heading_deg"] == repr(rows[0]["ugv_heading_deg"])
    assert back[0]["campaign"] == tag(c)


def test_resume_skips_ok_and_failed_flights_and_runs_infrastructure_failures_again(tmp_path):
    c = spec.from_dict(CAMPAIGN)
    path = tmp_path / "r.csv"
    write(path, c, fake_rows(c, ["ok", "flight_failed", "infra_failed"]))
    with path.open("a") as f:
        f.write("c001-r0001,1,1,quad_x line 1 m/s ca")  # a row cut short by a kill
    done = write(path, c, [], resume=True)
    assert done == {"c000-r0000", "c000-r0001"}
    assert path.read_text().endswith("\n") and "c001-r0001" not in path.read_text()


def test_a_resume_with_everything_done_flies_nothing(tmp_path):
    """runner.run skips the done runs: with all four done no worker starts and no row is added."""
    c = spec.from_dict(CAMPAIGN)
    path = tmp_path / "r.csv"
    write(path, c, fake_rows(c, ["ok", "ok", "flight_failed", "ok"]))
    before = path.read_text()
    outcome = runner.run(c, runner.Options(out=path, resume=True))
    assert (outcome.total, outcome.skipped, sum(outcome.statuses.values())) == (4, 4, 0)
    assert path.read_text() == before


def test_an_existing_file_needs_resume_and_another_campaigns_file_is_refused(tmp_path):
    c = spec.from_dict(CAMPAIGN)
    path = tmp_path / "r.csv"
    write(path, c, fake_rows(c, ["ok"]))
    with pytest.raises(ResultsError, match="add --resume"):
        write(path, c, [])
    other = spec.from_dict({**CAMPAIGN, "base_seed": 2})  # other draws: another campaign
    with pytest.raises(ResultsError, match="another campaign file"):
        write(path, other, [], resume=True)
    with path.open() as f:
        assert len(list(csv.reader(f))) == 2  # untouched


def test_camera_and_pad_are_columns_and_part_of_the_results_identity(tmp_path):
    """Each (camera, pad) its own cell, run ids and columns; a file of other camera or pad values is another's."""
    grid = {**CAMPAIGN["grid"], "camera": ["gimbal", "fixed"], "pad": ["single"]}
    c = spec.from_dict({**CAMPAIGN, "grid": grid})
    path = tmp_path / "r.csv"
    write(path, c, fake_rows(c, ["ok"] * 8))
    back = read(path)
    assert [(r["run_id"], r["camera"], r["pad"]) for r in back[:4]] == [
        ("c000-r0000", "gimbal", "single"),
        ("c000-r0001", "gimbal", "single"),
        ("c001-r0000", "fixed", "single"),
        ("c001-r0001", "fixed", "single"),
    ]
    assert back[2]["label"] == "quad_x static pad calm fixed camera single pad"
    assert write(path, c, [], resume=True) == {r["run_id"] for r in back}  # resumed: all done
    for other in ({"camera": ["fixed", "gimbal"]}, {"pad": ["nested"]}):  # other cells: another campaign
        changed = spec.from_dict({**CAMPAIGN, "grid": {**grid, **other}})
        with pytest.raises(ResultsError, match="another campaign file"):
            write(path, changed, [], resume=True)


def test_what_is_retried_and_what_is_a_result():
    """Machinery trouble, or a timeout before the vehicle armed, is retried; a refusal or a failure in flight is not."""
    from campaign.runs import FLIGHT_FAILED, INFRA_FAILED, TimeLimit, classify
    from gcs.errors import CommandRefused, CommandResult, GcsTimeout
    from gcs.launcher import StackError

    refused = CommandRefused(CommandResult(command=400, result=4, reason="Arming denied"))
    assert classify(refused, started=False) == FLIGHT_FAILED
    assert classify(StackError("sitl exited early with code 1"), started=True) == INFRA_FAILED
    assert classify(OSError("Address already in use"), started=False) == INFRA_FAILED
    assert classify(GcsTimeout("ready to arm"), started=False) == INFRA_FAILED
    assert classify(GcsTimeout("the motors cut on the deck"), started=True) == FLIGHT_FAILED
    assert classify(TimeLimit("time limit"), started=False) == INFRA_FAILED
    assert classify(TimeLimit("time limit"), started=True) == FLIGHT_FAILED


def test_a_run_without_a_free_instance_is_retried_then_recorded_as_infra_failed(free_instance):
    """Its only allowed instance is held (by the fixture's lease): every attempt fails before a stack starts."""
    from campaign.runs import execute

    n = free_instance()
    c = spec.from_dict(CAMPAIGN)
    settings = Settings(kind="landing", campaign=tag(c), retries=1, record=c.record, instances=(n, n))
    out = execute(plan.expand(c)[0], settings)
    assert (out["status"], out["attempts"], out["instance"]) == ("infra_failed", 2, -1)
    assert out["reason"].startswith(f"RuntimeError: no free test instance in {n}-{n}")
