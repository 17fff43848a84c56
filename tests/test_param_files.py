"""Parameter files, without a running vehicle: QGroundControl's and MAVProxy's formats.

Read, write, detect, round trip, bad lines, the diff, and applying entries in passes.  The rules
of the parameter store are in tests/test_param_rules.py, start-up sources and the state saver in
tests/test_param_storage.py, the pieces of ``gcs param`` that need no vehicle in
tests/test_gcs_param_offline.py.  Everything against a vehicle is in tests/test_e2e_params.py.
"""

from __future__ import annotations

import importlib

import pytest

importlib.import_module("autopilot.flight_controller")  # declares every parameter of the flight controller
from autopilot.param_storage import store_entries
from autopilot.parameters import ParamType
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

from float32 import f32  # tests/float32.py

QGC_TEXT = (
    "# Onboard parameters for Vehicle 1\n"
    "#\n"
    "# Stack: PX4 Pro\n"
    "# Vehicle-Id\tComponent-Id\tName\tValue\tType\n"
    "1\t1\tMC_ROLLRATE_P\t0.150000005960464478\t9\n"
    "1\t1\tSYS_AUTOSTART\t4001\t6\n"
    "1\t100\tCAM_MODE\t2\t6\n"
)


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
