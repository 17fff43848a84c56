"""The campaign kind ``multi_landing`` (campaign/multi_landing_kind.py): its campaign file, cells, checks and
the scoring of a run from each vehicle's landing.  Nothing flies here (tests/test_e2e_multi_world.py flies the
three-vehicle landing)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from campaign import plan, spec
from campaign.kinds import get_kind, kind_of_columns
from campaign.multi_landing_kind import multi_figures
from campaign.spec import SpecError
from gcs.launcher.landing_run import LandingResult

CAMPAIGNS = Path(__file__).resolve().parents[1] / "benchmarks" / "campaigns"


def test_the_campaign_file_expands_into_its_cells():
    runs = plan.expand(spec.load(CAMPAIGNS / "multi_landing.toml"))
    assert [r.label for r in runs] == ["3 x quad_x circle 1 m/s calm gimbal camera nested pad"] * 3
    assert all(r.axes["vehicles"] == 3 for r in runs) and len({r.draws["sim_seed"] for r in runs}) == 3


def test_the_vehicles_axis_multiplies_the_landing_cells():
    c = spec.from_dict(
        {
            "kind": "multi_landing",
            "runs": 1,
            "grid": {"vehicles": [2, 3], "vehicle": ["quad_x"], "wind": ["calm"], "ugv_speed_m_s": [0, 1],
                     "ugv_path": ["line"]},
        }
    )  # fmt: skip
    assert [r.label for r in plan.expand(c)] == [
        "2 x quad_x static pad calm gimbal camera nested pad",
        "2 x quad_x line 1 m/s calm gimbal camera nested pad",
        "3 x quad_x static pad calm gimbal camera nested pad",
        "3 x quad_x line 1 m/s calm gimbal camera nested pad",
    ]


@pytest.mark.parametrize("bad", [1, 6, 2.5, "3", True])
def test_a_vehicle_count_outside_2_to_5_is_refused(bad):
    with pytest.raises(SpecError, match="grid.vehicles"):
        spec.from_dict({"kind": "multi_landing", "runs": 1, "grid": {"vehicles": [bad]}})


def test_the_sim_params_the_runs_set_are_refused():
    with pytest.raises(SpecError, match="SIM_UGV_X"):
        spec.from_dict({"kind": "multi_landing", "runs": 1, "sim_params": {"SIM_UGV_X": 5}})


def _landed(err: float, ok: bool = True, reason: str = "", t: float = 8.0) -> LandingResult:
    return LandingResult(success=ok, touchdown_error_m=err, time_to_land_s=t, reason=reason, sim_s=20.0, wall_s=10.0)


def test_a_run_succeeds_only_with_every_vehicle_on_its_deck():
    f = multi_figures([_landed(0.03), _landed(0.05, t=9.5), _landed(0.04)])
    assert f["success"] and f["status"] == "ok" and f["on_deck"] == 3 and f["reason"] == ""
    assert f["touchdown_error_m"] == pytest.approx(0.05)  # the worst: the report's error column
    assert f["touchdown_error_mean_m"] == pytest.approx(0.04)
    assert f["touchdown_errors_m"] == "0.030 0.050 0.040" and f["on_deck_each"] == "1 1 1"
    assert f["time_to_land_s"] == 9.5 and f["real_time_factor"] == pytest.approx(2.0)
    g = multi_figures([_landed(0.03), _landed(0.6, ok=False, reason="touched down off the deck"), _landed(0.04)])
    assert not g["success"] and g["status"] == "flight_failed" and g["on_deck"] == 2
    assert g["reason"] == "vehicle 1: touched down off the deck" and g["on_deck_each"] == "1 0 1"
    h = multi_figures([_landed(0.03), _landed(math.nan, ok=False, reason="no touchdown in time")])
    assert math.isnan(h["touchdown_error_m"]) and h["touchdown_error_mean_m"] == pytest.approx(0.03)


def test_a_results_file_is_recognised_as_its_kind():
    multi, landing = get_kind("multi_landing"), get_kind("landing")
    columns = [a.name for a in multi.axes] + [r.name for r in multi.ranges] + list(multi.figures)
    assert kind_of_columns(columns) is multi
    columns = [a.name for a in landing.axes] + [r.name for r in landing.ranges] + list(landing.figures)
    assert kind_of_columns(columns) is landing
