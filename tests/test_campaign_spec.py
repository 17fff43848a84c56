"""The campaign file (campaign/spec.py) and its expansion into runs (campaign/plan.py)."""

from __future__ import annotations

import math
from pathlib import Path

import pytest

from campaign import plan, spec
from campaign.__main__ import main
from campaign.landing import setup_for

GOOD = """
kind = "landing"
runs = 3
base_seed = 7
[grid]
vehicle = ["quad_x"]
wind = ["calm", "windy"]
ugv_speed_m_s = [0, 1]
ugv_path = ["line", "circle"]
[random]
ugv_heading_deg = [10, 20]
"""


def campaign(text: str = GOOD, **top) -> spec.Campaign:
    import tomllib

    data = tomllib.loads(text)
    data.update(top)
    return spec.from_dict(data)


def test_cells_follow_the_grid_and_the_static_pad_is_one_cell():
    labels = list(dict.fromkeys(r.label for r in plan.expand(campaign())))
    assert labels == [
        "quad_x static pad calm gimbal camera nested pad",
        "quad_x line 1 m/s calm gimbal camera nested pad",
        "quad_x circle 1 m/s calm gimbal camera nested pad",
        "quad_x static pad windy gimbal camera nested pad",
        "quad_x line 1 m/s windy gimbal camera nested pad",
        "quad_x circle 1 m/s windy gimbal camera nested pad",
    ]


CAMERA_PAD = GOOD.replace(
    'ugv_path = ["line", "circle"]', 'ugv_path = ["circle"]\ncamera = ["gimbal", "fixed"]\npad = ["nested", "single"]'
)


def test_camera_and_pad_are_the_innermost_axes_of_the_grid():
    """A cell's gimbal and fixed-camera runs, nested and single pad, stand next to each other; each its own cell."""
    runs = plan.expand(campaign(CAMERA_PAD))
    labels = list(dict.fromkeys(r.label for r in runs))
    assert labels[:5] == [
        "quad_x static pad calm gimbal camera nested pad",
        "quad_x static pad calm gimbal camera single pad",
        "quad_x static pad calm fixed camera nested pad",
        "quad_x static pad calm fixed camera single pad",
        "quad_x circle 1 m/s calm gimbal camera nested pad",
    ]
    assert len(labels) == len({r.cell for r in runs}) == 16 and len(runs) == 16 * 3
    assert len({r.run_id for r in runs}) == len(runs)
    assert {(r.axes["camera"], r.axes["pad"]) for r in runs if r.cell == 3} == {("fixed", "single")}


def test_without_camera_and_pad_the_cells_and_their_draws_are_as_before():
    """The defaults (gimbal, nested) add no cell: a campaign file that names neither keeps its cells' numbers."""
    runs = plan.expand(campaign())
    assert {(r.axes["camera"], r.axes["pad"]) for r in runs} == {("gimbal", "nested")}
    assert len(runs) == 6 * 3 and runs[4].run_id == "c001-r0001"


@pytest.mark.parametrize("camera,pad,mount,layout", [("gimbal", "nested", 2, 0), ("fixed", "single", 1, 1)])
def test_camera_and_pad_become_the_simulators_parameters(camera, pad, mount, layout):
    from sitl.sim_settings import CameraSettings, UgvSettings
    from vision.pad import SINGLE_PAD

    run = next(r for r in plan.expand(campaign(CAMERA_PAD)) if (r.axes["camera"], r.axes["pad"]) == (camera, pad))
    params = setup_for(run.axes, run.draws).sim_params()
    assert (params["SIM_CAM_MOUNT"], params["SIM_PAD_LAYOUT"]) == (mount, layout)
    # what the simulator makes of those values (sitl/sim_settings.py)
    assert CameraSettings(mount=params["SIM_CAM_MOUNT"]).mount_name("neither") == camera
    assert (UgvSettings(pad_layout=params["SIM_PAD_LAYOUT"]).pad() is SINGLE_PAD) == (pad == "single")


def test_expansion_is_deterministic_and_independent_of_the_other_runs():
    """Run i of cell c draws from default_rng((base_seed, c, i)): the same whatever else the campaign holds."""
    a, b = plan.expand(campaign()), plan.expand(campaign())
    assert a == b
    more = {r.run_id: r for r in plan.expand(campaign(runs=5))}
    assert all(more[r.run_id].draws == r.draws for r in a)
    assert len({r.draws["sim_seed"] for r in a}) == len(a)  # every run its own simulator seed
    other_seed = plan.expand(campaign(base_seed=8))
    assert [r.draws for r in other_seed] != [r.draws for r in a]
    for r in a:
        assert 10 <= r.draws["ugv_heading_deg"] <= 20  # the file's range
        assert 3.5 <= r.draws["ugv_start_north_m"] <= 4.5  # the kind's default range
        assert isinstance(r.draws["sim_seed"], int)


def test_a_run_becomes_its_landing_setup():
    run = plan.expand(campaign())[4]  # quad_x line 1 m/s calm, run 1
    s = setup_for(run.axes, run.draws)
    assert (s.vehicle, s.path, s.speed_m_s, s.windy, s.seed) == ("quad_x", "line", 1.0, False, run.draws["sim_seed"])
    assert math.degrees(s.ugv_start.yaw_rad) == pytest.approx(run.draws["ugv_heading_deg"])
    assert math.hypot(*s.meet_offset_m) == pytest.approx(run.draws["meet_offset_m"])


def test_the_landing_sets_the_deck_model_for_the_ugv_and_a_campaigns_fc_params_win():
    """A landing sets the deck model its crew would for the simulated UGV (the marker's heading fused, its lag behind
    the axle guessed from the UGV's geometry) before it arms; a campaign's ``[fc_params]`` overrides that."""
    from sitl.ugv import UgvGeometry

    run = plan.expand(campaign())[4]
    assert setup_for(run.axes, run.draws).fc_params == {"PLD_DECK_HDG": 2, "PLD_DECK_LAG": UgvGeometry().wheel_x_m}
    own = setup_for(run.axes, run.draws, fc_params={"PLD_DECK_HDG": 0, "MPC_XY_VEL_MAX": 8.0}).fc_params
    assert own == {"PLD_DECK_HDG": 0, "PLD_DECK_LAG": 0.15, "MPC_XY_VEL_MAX": 8.0}


BROKEN = [
    ('runs = 3\n[grid]\nwind = ["calm"]\n', "key kind: missing"),
    ('kind = "landing"\nruns = 0\n', "key runs: must be 1 to"),
    ('kind = "landing"\nruns = "ten"\n', "key runs: must be an integer"),
    ('kind = "hover"\n', "key kind: 'hover' is not one of: landing, hover_step, mission"),
    ('kind = "landing"\n[grid]\nwind = ["gale"]\n', "key grid.wind: 'gale' is not one of"),
    ('kind = "landing"\n[grid]\nfault = ["motor"]\n', "key grid.fault: not an axis of kind 'landing'"),
    ('kind = "landing"\n[grid]\nvehicle = ["octo"]\n', "key grid.vehicle: unknown vehicle 'octo'"),
    ('kind = "landing"\n[grid]\ncamera = ["pan"]\n', "key grid.camera: 'pan' is not one of 'gimbal', 'fixed'"),
    ('kind = "landing"\n[grid]\ncamera = "fixed"\n', "key grid.camera: must be a non-empty list"),
    ('kind = "landing"\n[grid]\npad = ["nested", "nested"]\n', "key grid.pad: lists a value twice"),
    ('kind = "landing"\n[grid]\npad = [1]\n', "key grid.pad: 1 is not one of 'nested', 'single'"),
    ('kind = "mission"\n[grid]\ncamera = ["fixed"]\n', "key grid.camera: not an axis of kind 'mission'"),
    ('kind = "landing"\n[random]\nsim_seed = [5, 1]\n', "key random.sim_seed: must have 0 <= low <= high"),
    ('kind = "landing"\nrecord = ["speed"]\n', "key record: 'speed' is not a figure"),
    ('kind = "landing"\n[fc_params]\npld_x = 1\n', "key fc_params.pld_x: not a parameter name"),
    ('kind = "landing"\nwhat = 1\n', "key what: unknown"),
    # a simulator parameter that a grid key or a draw sets for each run (it would override it silently)
    (
        'kind = "landing"\n[sim_params]\nSIM_CAM_MOUNT = 1\n',
        "key sim_params.SIM_CAM_MOUNT: is set by the landing campaign's grid.camera",
    ),
    (
        'kind = "landing"\n[sim_params]\nSIM_PAD_LAYOUT = 1\n',
        "key sim_params.SIM_PAD_LAYOUT: is set by the landing campaign's grid.pad",
    ),
    (
        'kind = "landing"\n[sim_params]\nSIM_WIND_SPD = 3\n',
        "key sim_params.SIM_WIND_SPD: is set by the landing campaign's grid.wind",
    ),
    (
        'kind = "landing"\n[sim_params]\nSIM_UGV_YAW = 3\n',
        "key sim_params.SIM_UGV_YAW: is set by the landing campaign's random.ugv_heading_deg",
    ),
    ('kind = "landing"\nruns = \n', "key (file): not valid TOML"),
    # the other kinds' axes (campaign/hover_step.py, mission_kind.py)
    ('kind = "hover_step"\n[grid]\nfault = ["motor1_150"]\n', "key grid.fault: 'motor1_150' is not 'none' nor"),
    ('kind = "hover_step"\n[grid]\nwind_m_s = [20]\n', "key grid.wind_m_s: 20 is not in [0, 15]"),
    ('kind = "hover_step"\n[grid]\nhover_s = ["long"]\n', "key grid.hover_s: 'long' is not a number"),
    ('kind = "hover_step"\n[grid]\nugv_path = ["line"]\n', "key grid.ugv_path: not an axis of kind 'hover_step'"),
    ('kind = "mission"\n[grid]\nspeed = ["fast"]\n', "key grid.speed: 'fast' is not 'max' nor a real-time"),
    ('kind = "mission"\n[grid]\nside_m = [1]\n', "key grid.side_m: 1 is not in [5, 200]"),
    ('kind = "mission"\n[grid]\nwind = ["gale"]\n', "key grid.wind: 'gale' is not one of"),
    ('kind = "mission"\n[grid]\nvehicle = ["octo"]\n', "key grid.vehicle: unknown vehicle 'octo'"),
    ('kind = "mission"\nrecord = ["touchdown_error_m"]\n', "key record: 'touchdown_error_m' is not a figure"),
]


@pytest.mark.parametrize("text,message", BROKEN, ids=[m.split(":")[0] + str(i) for i, (_, m) in enumerate(BROKEN)])
def test_a_broken_file_is_one_line_naming_the_key(text, message, tmp_path, capsys):
    path = tmp_path / "broken.toml"
    path.write_text(text)
    assert main(["run", str(path), "--out", str(tmp_path / "out.csv")]) == 2
    err = capsys.readouterr().err
    assert err.startswith(f"campaign: {path}: {message}"), err
    assert err.count("\n") == 1
    assert not (tmp_path / "out.csv").exists()


def test_a_missing_file_is_a_usage_error(tmp_path, capsys):
    assert main(["run", str(tmp_path / "none.toml")]) == 2
    assert "No such file" in capsys.readouterr().err


def test_the_benchmark_campaign_files_are_valid():
    for path in sorted((Path(__file__).resolve().parents[1] / "benchmarks" / "campaigns").glob("*.toml")):
        assert plan.expand(spec.load(path)), path
    assert len(plan.expand(spec.load(path.parent / "landing.toml"))) == 680


def test_the_radius_is_a_cell_of_the_turning_paths_only():
    """ugv_radius_m (SIM_UGV_RAD) makes cells of the circle and the figure-8; the static pad and the line keep one."""
    text = GOOD.replace('ugv_path = ["line", "circle"]', 'ugv_path = ["line", "figure8"]\nugv_radius_m = [2, 3]')
    runs = plan.expand(campaign(text.replace('wind = ["calm", "windy"]', 'wind = ["calm"]')))
    labels = list(dict.fromkeys(r.label for r in runs))
    assert labels == [
        "quad_x static pad calm gimbal camera nested pad",
        "quad_x line 1 m/s calm gimbal camera nested pad",
        "quad_x figure8 1 m/s calm gimbal camera nested pad",
        "quad_x figure8 1 m/s r 3 m calm gimbal camera nested pad",
    ]
    assert {r.axes["ugv_radius_m"] for r in runs if r.label == labels[-1]} == {3}
