"""Parameter files, cross-parameter rules and persistence, without a running vehicle.

QGroundControl's and MAVProxy's formats (read, write, detect, round trip, bad
lines), the diff, the rules of the parameter store, the start-up order of the
flight controller's parameter sources, the state saver and its atomic write
(including a writer killed mid-write), and the pieces of ``gcs param`` that
need no vehicle.  Everything against a vehicle is in tests/test_e2e_params.py.
"""

from __future__ import annotations

import importlib
import io
import os
import signal
import struct
import subprocess
import sys
import time
from pathlib import Path

import pytest

importlib.import_module("autopilot.flight_controller")  # declares every parameter of the flight controller
from autopilot import param_storage
from autopilot.param_catalogue import default_store
from autopilot.param_storage import (
    ParamSaver,
    apply_entries,
    atomic_write_text,
    load_file,
    prepare_parameters,
    state_file,
    store_entries,
)
from autopilot.parameters import RULES, ParamDef, ParamError, ParameterStore, ParamRule, ParamType
from gcs.__main__ import build_parser
from gcs.param_cli import ProgressBar
from mavsim_core.param_encoding import INT32, REAL32
from params.param_file import (
    MAVPROXY,
    QGC,
    ParamEntry,
    ParamFileError,
    apply_in_passes,
    detect_format,
    diff_params,
    format_params,
    format_value,
    parse_param_text,
    read_param_file,
    same_value,
)
from params.vehicle import VEHICLE_DIR

ROOT = Path(__file__).resolve().parent.parent

QGC_TEXT = (
    "# Onboard parameters for Vehicle 1\n"
    "#\n"
    "# Stack: PX4 Pro\n"
    "# Vehicle-Id\tComponent-Id\tName\tValue\tType\n"
    "1\t1\tMC_ROLLRATE_P\t0.150000005960464478\t9\n"
    "1\t1\tSYS_AUTOSTART\t4001\t6\n"
    "1\t100\tCAM_MODE\t2\t6\n"
)


def f32(x: float) -> float:
    return struct.unpack("<f", struct.pack("<f", x))[0]


@pytest.fixture
def store():
    return default_store()


# --------------------------------------------------------------------------- formats


def test_qgc_format_is_read_with_types_and_components():
    pf = parse_param_text(QGC_TEXT)
    assert pf.format == QGC and pf.problems == []
    assert [(e.name, e.value, e.mav_type, e.compid, e.line) for e in pf.entries] == [
        ("MC_ROLLRATE_P", pytest.approx(0.15), REAL32, 1, 5),
        ("SYS_AUTOSTART", 4001, INT32, 1, 6),
        ("CAM_MODE", 2, INT32, 100, 7),
    ]
    assert isinstance(pf.entries[1].value, int) and isinstance(pf.entries[0].value, float)


def test_mavproxy_format_is_read_with_blanks_commas_and_comments():
    text = "# saved by MAVProxy\nMPC_XY_P         1.200000\nSYS_AUTOSTART 4001  # airframe\n\nMC_ROLL_P,6.5\n"
    pf = parse_param_text(text)
    assert pf.format == MAVPROXY and pf.problems == []
    assert pf.values() == {"MPC_XY_P": 1.2, "SYS_AUTOSTART": 4001, "MC_ROLL_P": 6.5}
    assert isinstance(pf.values()["SYS_AUTOSTART"], int)
    assert all(e.mav_type is None for e in pf.entries)


def test_format_detection():
    assert detect_format(QGC_TEXT) == QGC
    assert detect_format("# only a comment\n\nA_B 1\n") == MAVPROXY
    assert detect_format("# nothing\n") is None
    with pytest.raises(ParamFileError, match="no parameter line"):
        parse_param_text("# nothing here\n\n", "empty.params")


@pytest.mark.parametrize("fmt", [QGC, MAVPROXY])
def test_round_trip_keeps_every_value_exactly(store, fmt):
    store.set("MPC_XY_P", f32(1.2345678))  # what a vehicle reports: a float32
    store.set("EKF2_ACC_NOISE", 0.01)
    store.set("SYS_AUTOSTART", 98765)
    entries = store_entries(store)
    text = format_params(entries, fmt, "header line\n\nsecond line")
    assert text.startswith("# header line\n#\n# second line\n")
    back = parse_param_text(text)
    assert back.format == fmt and back.problems == []
    assert [e.name for e in back.entries] == store.names()
    for e in back.entries:
        assert same_value(e.value, store.get(e.name), e.mav_type or None), e
        if fmt == QGC:
            assert e.mav_type == (INT32 if store.definition(e.name).ptype == ParamType.INT32 else REAL32)
    assert back.values()["SYS_AUTOSTART"] == 98765


def test_values_are_written_short_but_exact_as_float32():
    assert format_value(0.95, REAL32) == "0.95"
    assert format_value(f32(0.95), REAL32) == "0.95"  # 0.949999988079071 from the wire
    assert format_value(8.54858e-6, REAL32) == "8.54858e-06"
    assert format_value(10.0, REAL32) == "10" and format_value(100000.0, REAL32) == "100000"
    assert format_value(4001.0, INT32) == "4001"
    assert format_value(-7, None) == "-7"
    for x in (0.1, 1 / 3, 123.456, 1e-7, 3.4e38):
        assert f32(float(format_value(x, REAL32))) == f32(x)
    extremes = [ParamEntry("BIG", 2**31 - 1, INT32), ParamEntry("SMALL", -(2**31), INT32)]
    assert parse_param_text(format_params(extremes, QGC)).values() == {"BIG": 2**31 - 1, "SMALL": -(2**31)}


def test_bad_lines_are_reported_with_their_line_and_the_rest_read():
    text = (
        "1\t1\tMPC_XY_P\t1.1\t9\n"
        "1\t1\tMPC_Z_P\tfast\t9\n"  # 2: not a number
        "1\t1\tSYS_AUTOSTART\t4001.5\t6\n"  # 3: INT32 not an integer
        "1\t1\tMPC_XY_CRUISE\t3\t10\n"  # 4: REAL64 unsupported
        "1\t1\tMPC_Z_P\t1\n"  # 5: 4 fields
        "1\t1\tA_NAME_THAT_IS_TOO_LONG\t1\t9\n"  # 6: name
        "x\t1\tMPC_Z_P\t1\t9\n"  # 7: sysid not a number
        "1\t1\tMPC_XY_VEL_MAX\tnan\t9\n"  # 8: not finite
        "1\t1\tMC_ROLL_P\t7\t9\n"
    )
    pf = parse_param_text(text, "tuned.params")
    assert [e.name for e in pf.entries] == ["MPC_XY_P", "MC_ROLL_P"]
    assert [p.line for p in pf.problems] == [2, 3, 4, 5, 6, 7, 8]
    reasons = [str(p) for p in pf.problems]
    assert "line 2: MPC_Z_P: value 'fast' is not a number" in reasons[0]
    assert "not an integer" in reasons[1] and "unsupported MAV_PARAM_TYPE 10" in reasons[2]
    assert "expected 5 fields" in reasons[3] and "bad parameter name" in reasons[4]
    assert "must be integers" in reasons[5] and "not a number" in reasons[6]
    assert "[1\t1\tMPC_Z_P\tfast\t9]" in reasons[0]  # the line itself is shown


def test_missing_file_is_a_clear_error(tmp_path):
    with pytest.raises(ParamFileError, match="cannot read parameter file .*nope.params"):
        read_param_file(tmp_path / "nope.params")


def test_diff():
    ours = {"A": 1.2, "B": 3, "C": 0.1, "D": 5.0}
    theirs = {"A": f32(1.2), "B": 4, "C": 0.1, "E": 1.0}
    types = {"A": REAL32, "B": INT32, "C": REAL32}
    assert [(d.name, d.ours, d.theirs) for d in diff_params(ours, theirs, types)] == [
        ("B", 3, 4),
        ("D", 5.0, None),
        ("E", None, 1.0),
    ]
    assert [d.name for d in diff_params(ours, theirs, types, only_ours=True)] == ["B", "D"]
    assert diff_params({"A": 1.00000001}, {"A": 1.0}, {"A": REAL32}) == []  # same float32
    assert [d.name for d in diff_params({"A": 1.001}, {"A": 1.0}, {"A": REAL32})] == ["A"]


def test_apply_in_passes_retries_what_another_entry_unlocks():
    state = {"LOW": 1.0, "HIGH": 2.0}

    def apply(e: ParamEntry) -> None:
        trial = dict(state, **{e.name: e.value})
        if e.name == "BAD" or not trial["LOW"] <= trial["HIGH"]:
            raise ValueError(f"{e.name} refused")
        state.update(trial)

    entries = [ParamEntry("LOW", 5.0, line=1), ParamEntry("BAD", 0, line=2), ParamEntry("HIGH", 6.0, line=3)]
    refused = apply_in_passes(entries, apply)
    assert state == {"LOW": 5.0, "HIGH": 6.0}
    assert [(e.name, why) for e, why in refused] == [("BAD", "BAD refused")]


# --------------------------------------------------------------------------- cross-parameter rules


def test_px4_names_of_the_issue_are_declared(store):
    for name in (
        "MC_ROLL_P",
        "MC_ROLLRATE_P",
        "MC_ROLLRATE_I",
        "MC_ROLLRATE_D",
        "MC_YAWRATE_P",
        "MPC_XY_P",
        "MPC_XY_VEL_P_ACC",
        "MPC_XY_VEL_I_ACC",
        "MPC_XY_VEL_D_ACC",
        "MPC_Z_P",
        "MPC_Z_VEL_P_ACC",
        "MPC_Z_VEL_I_ACC",
        "MPC_Z_VEL_D_ACC",
        "MPC_XY_VEL_MAX",
        "MPC_Z_VEL_MAX_UP",
        "MPC_Z_VEL_MAX_DN",
        "MPC_LAND_SPEED",
        "MPC_TILTMAX_AIR",
        "MIS_TAKEOFF_ALT",
        "RTL_RETURN_ALT",
        "COM_DISARM_LAND",
        "SYS_AUTOSTART",
    ):
        assert name in store, name
    assert {str(r) for r in store.rules()} == {str(r) for r in RULES}  # every rule's parameters exist


@pytest.mark.parametrize(
    ("name", "value", "why"),
    [
        ("MPC_LAND_SPEED", 1.8, "MPC_LAND_SPEED 1.8 refused: must be <= MPC_Z_VEL_MAX_DN (1.5 m/s)"),
        ("MPC_Z_VEL_MAX_DN", 0.6, "MPC_Z_VEL_MAX_DN 0.6 refused: must be >= MPC_LAND_SPEED (0.7 m/s)"),
        ("MPC_THR_MIN", 0.5, None),  # allowed: 0.5 < 1.0
        ("MPC_TKO_SPEED", 3.5, "must be <= MPC_Z_VEL_MAX_UP"),
        ("MPC_XY_CRUISE", 6.0, "must be <= MPC_XY_VEL_MAX"),
        ("MPC_XY_VEL_MAX", 2.0, "must be >= MPC_XY_CRUISE"),
        ("LNDMC_Z_VEL_MAX", 0.7, "must be < MPC_LAND_SPEED"),
    ],
)
def test_rules_refuse_and_change_nothing(store, name, value, why):
    seen = []
    store.subscribe(lambda n, v: seen.append(n))
    before = store.values()
    if why is None:
        store.set(name, value)
        assert store.get(name) == value
        return
    with pytest.raises(ParamError, match=why.replace("(", r"\(").replace(")", r"\)")):
        store.set(name, value)
    assert store.values() == before and seen == []


def test_rule_with_strict_order_and_both_sides():
    defs = {n: ParamDef(n, ParamType.REAL32, d, 0.0, 1.0, "norm", n) for n, d in (("T_LO", 0.2), ("T_HI", 0.8))}
    store = ParameterStore(defs, rules=(ParamRule("T_LO", "<", "T_HI", "test"), ParamRule("T_LO", "<", "NOPE", "x")))
    assert [str(r) for r in store.rules()] == ["T_LO < T_HI"]  # rules on missing parameters are dropped
    with pytest.raises(ParamError, match="T_LO 0.8 refused: must be < T_HI"):
        store.set("T_LO", 0.8)
    store.set("T_HI", 1.0)
    store.set("T_LO", 0.8)
    with pytest.raises(ValueError, match="declared defaults break the rule T_HI < T_LO"):
        ParameterStore(defs, rules=(ParamRule("T_HI", "<", "T_LO", "backwards"),))
    with pytest.raises(ValueError, match="operator"):
        ParamRule("T_LO", ">", "T_HI", "no")


def test_vehicle_defaults_replace_declared_ones(store):
    seen = []
    store.subscribe(lambda n, v: seen.append((n, v)))
    store.set_defaults({"SYS_AUTOSTART": 6001, "MPC_XY_P": 1.1})
    assert store.get("SYS_AUTOSTART") == 6001 and store.default("SYS_AUTOSTART") == 6001
    assert store.changed() == {} and seen == [("SYS_AUTOSTART", 6001), ("MPC_XY_P", 1.1)]
    store.set("MPC_XY_P", f32(1.1))  # the default as it comes over MAVLink (float32) is still the default
    assert store.changed() == {}
    store.set("MPC_XY_P", 0.95)
    assert store.changed() == {"MPC_XY_P": 0.95}
    before = store.values()
    with pytest.raises(ParamError, match="default set breaks the rule MPC_LAND_SPEED <= MPC_Z_VEL_MAX_DN"):
        store.set_defaults({"MPC_LAND_SPEED": 1.8})
    with pytest.raises(ParamError, match="outside range"):
        store.set_defaults({"MPC_Z_VEL_MAX_DN": 2.0, "MPC_XY_P": 9.0})
    assert store.values() == before
    store.set_defaults({"MPC_LAND_SPEED": 1.8, "MPC_Z_VEL_MAX_DN": 2.0})  # together they are fine
    assert store.get("MPC_LAND_SPEED") == 1.8


# --------------------------------------------------------------------------- start-up sources


def test_vehicle_default_files_exist_and_load():
    for toml in sorted(VEHICLE_DIR.glob("*.toml")):
        params_file = param_storage.vehicle_defaults_file(toml)
        assert params_file is not None, f"no default parameter set beside {toml.name}"
        s = default_store()
        applied, messages = load_file(s, params_file, as_defaults=True)
        assert messages == [] and applied >= 1 and s.changed() == {}
    s = default_store()
    load_file(s, VEHICLE_DIR / "firefly.params", as_defaults=True)
    assert s.get("SYS_AUTOSTART") == 6001  # PX4's generic hexacopter X airframe


def test_load_file_names_each_bad_line_and_applies_the_rest(store, tmp_path):
    path = tmp_path / "startup.params"
    path.write_text(
        "1\t1\tMC_ROLL_P\t7\t9\n"
        "1\t1\tNO_SUCH_PARAM\t1\t9\n"
        "1\t1\tMPC_XY_P\t50\t9\n"
        "this is not a parameter line\n"
        "1\t1\tSYS_AUTOSTART\t4001\t9\n"  # wrong type
        "1\t100\tCAM_MODE\t1\t6\n"  # another component
        "1\t1\tMPC_LAND_SPEED\t1.8\t9\n"  # needs the next line first
        "1\t1\tMPC_Z_VEL_MAX_DN\t2\t9\n"
    )
    applied, messages = load_file(store, path)
    assert applied == 3
    assert store.get("MC_ROLL_P") == 7 and store.get("MPC_LAND_SPEED") == 1.8 and store.get("MPC_XY_P") == 0.95
    text = "\n".join(messages)
    assert f"{path}, line 2: unknown parameter NO_SUCH_PARAM" in text
    assert f"{path}, line 3: MPC_XY_P: 50 outside range [0, 2] 1/s" in text
    assert f"{path}, line 4: expected 5 fields" in text
    assert f"{path}, line 5: SYS_AUTOSTART is INT32, not REAL32" in text
    assert f"{path}, line 6: CAM_MODE: component 100" in text
    assert len(messages) == 5
    assert load_file(store, tmp_path / "missing.params") == (
        0,
        [f"cannot read parameter file {tmp_path / 'missing.params'}: No such file or directory"],
    )


def test_start_up_order_vehicle_defaults_then_saved_state_then_params_file(tmp_path):
    toml = tmp_path / "v.toml"
    toml.write_text("")
    (tmp_path / "v.params").write_text("1\t1\tSYS_AUTOSTART\t6001\t6\n1\t1\tMPC_XY_P\t1.1\t9\n")
    state = tmp_path / "state.params"
    state.write_text("1\t1\tMPC_XY_P\t1.3\t9\n1\t1\tMC_ROLL_P\t7\t9\n")
    extra = tmp_path / "extra.params"
    extra.write_text("MC_ROLL_P 8\n")
    store = default_store()
    log: list[str] = []
    prepare_parameters(store, vehicle_toml=toml, state_path=state, params_path=extra, log=log.append)
    assert store.get("SYS_AUTOSTART") == 6001 and store.default("MPC_XY_P") == 1.1
    assert store.get("MPC_XY_P") == 1.3 and store.get("MC_ROLL_P") == 8
    assert store.changed() == {"MC_ROLL_P": 8.0, "MPC_XY_P": 1.3}
    assert any("vehicle defaults: 2 values" in line for line in log)
    assert any("saved parameters: 2 values" in line for line in log)
    assert any("parameter file: 1 values" in line for line in log)
    log.clear()
    prepare_parameters(default_store(), vehicle_toml=toml, state_path=tmp_path / "none.params", log=log.append)
    assert any("no saved parameters yet" in line for line in log)


def test_autopilot_options():
    from autopilot.__main__ import build_parser as autopilot_parser

    a = autopilot_parser().parse_args(["--params", "x.params", "--state-dir", "/tmp/s"])
    assert a.params == "x.params" and a.state_dir == "/tmp/s"
    a = autopilot_parser().parse_args([])
    assert a.params is None and a.state_dir is None
    assert state_file("/tmp/s", "quad_x", 3) == Path("/tmp/s/quad_x-3.params")


# --------------------------------------------------------------------------- saving


def wait_for(predicate, timeout_s: float = 10.0):
    deadline = time.monotonic() + timeout_s
    while not predicate():
        assert time.monotonic() < deadline, "timed out"
        time.sleep(0.01)


def test_saver_writes_changes_at_once_then_at_most_once_per_interval(store, tmp_path):
    path = tmp_path / "quad_x-0.params"
    saver = ParamSaver(store, path, vehicle_name="quad_x", min_interval_s=0.3)
    try:
        assert saver.saves == 0 and not path.exists()
        store.set("MPC_XY_P", 1.2)
        wait_for(lambda: saver.saves == 1)
        assert read_param_file(path).values() == {"MPC_XY_P": pytest.approx(1.2)}
        for i in range(50):  # a burst (a ground station loading a file): one more write, not fifty
            store.set("MC_ROLL_P", 5.0 + i * 0.01)
        store.set("SYS_AUTOSTART", 4002)
        wait_for(lambda: saver.saves == 2)
        assert read_param_file(path).values() == {
            "MC_ROLL_P": pytest.approx(5.49),
            "MPC_XY_P": pytest.approx(1.2),
            "SYS_AUTOSTART": 4002,
        }
        store.set("MPC_XY_P", 0.95)  # back to the default: no longer saved
    finally:
        saver.close()  # writes what the interval held back
    assert saver.saves == 3
    assert set(read_param_file(path).values()) == {"MC_ROLL_P", "SYS_AUTOSTART"}
    restored = default_store()
    applied, messages = load_file(restored, path)
    assert applied == 2 and messages == [] and restored.get("SYS_AUTOSTART") == 4002
    assert [p.name for p in tmp_path.iterdir()] == [path.name]  # no temporary file left behind


def test_saver_initial_save_and_write_errors_are_reported(store, tmp_path):
    reports: list[str] = []
    saver = ParamSaver(
        store, tmp_path / "missing-dir" / "x.params", initial_save=True, report=reports.append, min_interval_s=0.01
    )
    wait_for(lambda: reports)
    saver.close()
    assert "cannot save parameters to" in reports[0] and saver.saves == 0
    saver = ParamSaver(store, tmp_path / "x.params", initial_save=True)
    saver.close()
    assert saver.saves == 1 and read_param_file(tmp_path / "x.params", QGC).entries == []


def test_atomic_write_failure_leaves_the_old_file(tmp_path, monkeypatch):
    path = tmp_path / "state.params"
    atomic_write_text(path, "old complete content\n")

    def broken_fsync(fd):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(os, "fsync", broken_fsync)
    with pytest.raises(OSError, match="No space left"):
        atomic_write_text(path, "new content that never fully reaches the disk\n")
    assert path.read_text() == "old complete content\n"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["state.params"]


WRITER = """
import sys
from autopilot.param_storage import atomic_write_text
path = sys.argv[1]
texts = ["A" * 200_000 + "\\n", "B" * 300_000 + "\\n"]
atomic_write_text(path, texts[0])
print("ready", flush=True)
i = 0
while True:
    i += 1
    atomic_write_text(path, texts[i % 2])
"""


def test_atomic_write_survives_a_writer_killed_mid_write(tmp_path):
    """SIGKILL a process that rewrites the file in a loop: the file is always one whole version."""
    path = tmp_path / "state.params"
    whole = {"A" * 200_000 + "\n", "B" * 300_000 + "\n"}
    for delay_s in (0.01, 0.037, 0.081):
        proc = subprocess.Popen(
            [sys.executable, "-c", WRITER, str(path)],
            cwd=ROOT,
            stdout=subprocess.PIPE,
            text=True,
            env=dict(os.environ, PYTHONPATH=str(ROOT)),
        )
        try:
            assert proc.stdout.readline().strip() == "ready"
            time.sleep(delay_s)
        finally:
            proc.send_signal(signal.SIGKILL)
            proc.wait()
            proc.stdout.close()
        assert path.read_text() in whole
    leftovers = [p for p in tmp_path.iterdir() if p != path]  # a killed write may leave its temp file,
    assert all(p.name.startswith(".state.params.") and p.suffix == ".tmp" for p in leftovers)  # never a bad file


# --------------------------------------------------------------------------- gcs param (no vehicle)


def test_gcs_param_sub_commands_parse():
    p = build_parser()
    a = p.parse_args(["param", "save", "out.params", "--format", "mavproxy"])
    assert (a.param_command, a.file, a.format) == ("save", "out.params", MAVPROXY)
    assert p.parse_args(["param", "save", "x"]).format == QGC
    assert p.parse_args(["param", "list", "MPC_*", "MC_*"]).patterns == ["MPC_*", "MC_*"]
    assert p.parse_args(["param", "load", "f"]).param_command == "load"
    assert p.parse_args(["param", "diff", "f"]).param_command == "diff"
    with pytest.raises(SystemExit):
        p.parse_args(["param", "save", "x", "--format", "json"])


class FakeTty(io.StringIO):
    def isatty(self) -> bool:
        return True


def test_progress_bar_on_a_terminal_only():
    tty = FakeTty()
    bar = ProgressBar(tty, width=10, min_interval_s=0.0)
    for i in range(1, 5):
        bar(i, 4)
    bar.finish("downloaded 4 parameters in 0.01 s")
    out = tty.getvalue()
    assert "\r[##........] 1/4 parameters" in out and "\r[##########] 4/4 parameters" in out
    assert out.endswith("\rdownloaded 4 parameters in 0.01 s\n")
    plain = io.StringIO()
    bar = ProgressBar(plain)
    bar(1, 4)
    bar.finish("downloaded 4 parameters in 0.01 s")
    assert plain.getvalue() == "downloaded 4 parameters in 0.01 s\n"


def test_apply_entries_counts(store):
    applied, problems = apply_entries(
        store, [ParamEntry("MPC_XY_P", 1.5, REAL32, 1), ParamEntry("MPC_XY_P", 3.0, REAL32, 2)]
    )
    assert applied == 1 and [(p.line, p.reason) for p in problems] == [(2, "MPC_XY_P: 3 outside range [0, 2] 1/s")]


# --------------------------------------------------------------------------- full download logic (fake link)


class FakeVehicleLink:
    """Stands in for a VehicleClient: a vehicle of ``count`` parameters that loses some list messages.

    The list stream drops the indices in ``drop``; reads by index are answered.  With
    ``rename_at`` that index is sent twice, the second time under another name (an inconsistent vehicle).
    """

    def __init__(
        self, count: int, drop: set[int] = frozenset(), answer_reads: bool = True, rename_at: int | None = None
    ) -> None:
        from pymavlink.dialects.v20 import common as mavlink

        self.mavlink = mavlink
        self.encoder = mavlink.MAVLink(None, 1, 1)
        self.count, self.drop, self.answer_reads, self.rename_at = count, set(drop), answer_reads, rename_at
        self.target_system = self.target_component = 1
        self._param_types: dict[str, int] = {}
        self._listeners: list = []
        self.queue: list = []
        self.reads: list[int] = []
        self.answers: dict[int, int] = {}
        self.conn = self
        self.mav = self

    # VehicleClient's surface used by download_parameters
    def _timeout(self, timeout_s):
        return 2.0 if timeout_s is None else timeout_s

    def add_listener(self, cb):
        self._listeners.append(cb)

    def remove_listener(self, cb):
        self._listeners.remove(cb)

    def pump(self, timeout_s=0.0):
        if not self.queue:
            time.sleep(min(timeout_s, 0.01))
        msgs, self.queue = self.queue, []
        for m in msgs:
            for cb in list(self._listeners):
                cb(m)
        return msgs

    def drain(self):
        self.pump(0.0)

    def param_request_list_send(self, sysid, compid):
        for i in range(self.count):
            if i not in self.drop:
                self.queue.append(self._value(i))
            if i == self.rename_at:
                self.queue.append(self._value(i))

    def param_request_read_send(self, sysid, compid, name, index):
        self.reads.append(index)
        if self.answer_reads:
            self.queue.append(self._value(index))

    def _value(self, i: int):
        self.answers[i] = self.answers.get(i, 0) + 1
        name = f"P_{i:03d}" if not (i == self.rename_at and self.answers[i] > 1) else "RENAMED"
        msg = self.mavlink.MAVLink_param_value_message(name.encode(), float(i), REAL32, self.count, i)
        msg.pack(self.encoder)
        return msg


def test_download_re_reads_missing_indices_by_index():
    from gcs.plugins.param import DownloadStats, download_parameters

    link = FakeVehicleLink(45, drop={3, 17, 44})
    progress: list[tuple[int, int]] = []
    stats = DownloadStats()
    params = download_parameters(link, lambda got, n: progress.append((got, n)), 5.0, stats)
    assert [p.index for p in params] == list(range(45)) and params[17].name == "P_017" and params[17].value == 17.0
    assert sorted(link.reads) == [3, 17, 44] and stats.re_requested == 3
    assert progress[-1] == (45, 45) and len(progress) == 45
    assert link._param_types["P_003"] == REAL32


def test_download_times_out_naming_missing_indices_and_catches_inconsistency():
    from gcs.errors import GcsTimeout, ParamListError
    from gcs.plugins.param import download_parameters

    with pytest.raises(GcsTimeout, match="43 of 45 received, missing indices 3, 17"):
        download_parameters(FakeVehicleLink(45, drop={3, 17}, answer_reads=False), timeout_s=0.8)
    with pytest.raises(ParamListError, match="index 3 was P_003, now RENAMED"):
        download_parameters(FakeVehicleLink(10, rename_at=3), timeout_s=2.0)
