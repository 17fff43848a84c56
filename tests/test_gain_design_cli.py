"""``design-gains``: the console script designs a vehicle's gains and writes them as a .params file."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

from autopilot.control.gains_from_params import PARAMS
from params.param_file import read_param_file
from sitl.gain_design import BEGIN, END, update_file

SCRIPT = Path(sys.executable).parent / "design-gains"
GAINS = (
    [f"MC_{a}RATE_{k}" for a in ("ROLL", "PITCH", "YAW") for k in ("P", "I", "D")]
    + ["MC_ROLL_P", "MC_PITCH_P", "MC_YAW_P", "MPC_XY_P", "MPC_Z_P"]
    + [f"MPC_{a}_VEL_{k}_ACC" for a in ("XY", "Z") for k in ("P", "I", "D")]
)


def _run(*args: str) -> subprocess.CompletedProcess:
    return subprocess.run([str(SCRIPT), *args], capture_output=True, text=True, timeout=120)


@pytest.fixture(scope="module")
def quad_x(tmp_path_factory):
    out = tmp_path_factory.mktemp("gains") / "quad_x_gains.params"
    return _run("quad_x", "--out", str(out)), out


def test_writes_every_gain_within_its_declared_range(quad_x):
    proc, out = quad_x
    assert proc.returncode == 0, proc.stderr
    parsed = read_param_file(out)
    assert not parsed.problems
    values = parsed.values()
    assert set(GAINS) <= set(values)
    declared = {d.name: d for d in PARAMS}
    for name in GAINS:
        d = declared[name]
        assert d.min <= values[name] <= d.max, (name, values[name], d.min, d.max)
    assert values["MC_ROLLRATE_P"] > 0 and values["MPC_XY_P"] > 0


def test_prints_each_loop_with_its_margins(quad_x):
    proc, _ = quad_x
    rows = {line[:14].strip(): line.split() for line in proc.stdout.splitlines()}
    for loop in ("roll rate", "pitch rate", "yaw rate", "roll angle", "velocity xy", "position xy", "position z"):
        assert loop in rows, proc.stdout
    roll = rows["roll rate"]  # name(2) P I D crossover GM PM BW
    gm, pm = float(roll[6]), float(roll[7])
    assert gm >= 6.0 and pm >= 44.5
    assert float(rows["position xy"][-1]) >= 3.9  # inner / outer bandwidth
    assert "predicted 10 m step, horizontal" in proc.stdout


def test_bad_vehicle_is_one_error_line_exit_2(tmp_path):
    proc = _run(str(tmp_path / "nosuch.toml"), "--out", str(tmp_path / "x.params"))
    assert proc.returncode == 2
    errors = [line for line in proc.stderr.splitlines() if "error:" in line]
    assert len(errors) == 1 and "nosuch.toml" in errors[0]
    assert "Traceback" not in proc.stderr
    assert not (tmp_path / "x.params").exists()


def test_update_rewrites_only_the_marked_block(tmp_path):
    path = tmp_path / "v.params"
    path.write_text(f"# head\n1\t1\tSYS_AUTOSTART\t4001\t6\n{BEGIN} old\n1\t1\tMPC_XY_P\t0.5\t9\n{END}\n# tail\n")
    update_file(path, f"{BEGIN} new\n1\t1\tMPC_XY_P\t0.9\t9\n{END}\n")
    text = path.read_text()
    assert text.startswith("# head\n1\t1\tSYS_AUTOSTART\t4001\t6\n")
    assert text.endswith("# tail\n") and "0.5" not in text and text.count(BEGIN) == 1
    assert read_param_file(path).values()["MPC_XY_P"] == pytest.approx(0.9)


@pytest.mark.parametrize("vehicle", ["quad_x", "firefly"])
def test_vehicle_files_carry_the_designed_gains_as_valid_defaults(params, vehicle):
    """The --update block is in each vehicle's .params and the whole file is accepted as its default set
    (all or nothing: one value out of range and the vehicle would fly on the declared defaults)."""
    path = Path(__file__).resolve().parents[1] / "params" / "vehicles" / f"{vehicle}.params"
    text = path.read_text()
    assert text.count(BEGIN) == 1 and text.count(END) == 1
    values = read_param_file(path).values()
    params.set_defaults(values)
    for name in GAINS:
        assert params.get(name) == pytest.approx(values[name], rel=1e-6), name
