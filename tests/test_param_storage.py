"""Where the flight controller's parameters come from and where they go (:mod:`autopilot.param_storage`).

The start-up order of the parameter sources (vehicle defaults, saved state, ``--params``),
the state saver and its atomic write (including a writer killed mid-write).  No running vehicle:
persistence across a real restart is tested in tests/test_e2e_params.py.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from autopilot import param_storage
from autopilot.param_catalogue import default_store
from autopilot.param_storage import (
    ParamSaver,
    SaveOutcome,
    atomic_write_text,
    load_file,
    prepare_parameters,
    state_file,
)
from params.param_file import QGC, read_param_file
from params.vehicle import VEHICLE_DIR

ROOT = Path(__file__).resolve().parent.parent


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


def test_the_rtk_gps_file_loads_and_lowers_the_gps_noise_floors():
    """params/rtk_gps.params (with sitl --scenario rtk_gps): every line applies, each floor below the default."""
    s = default_store()
    applied, messages = load_file(s, ROOT / "params" / "rtk_gps.params")
    assert messages == [] and applied == 2
    for name in ("EKF2_GPS_P_NOISE", "EKF2_GPS_V_NOISE"):
        assert s.get(name) < s.definition(name).default


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


def test_refused_vehicle_defaults_are_a_warning_for_the_ground_station(tmp_path):
    toml = tmp_path / "v.toml"
    toml.write_text("")
    (tmp_path / "v.params").write_text("1\t1\tMPC_XY_P\t1.1\t9\n1\t1\tMC_ROLL_P\t999\t9\n")  # 999: out of range
    store, log = default_store(), []
    warnings = prepare_parameters(store, vehicle_toml=toml, log=log.append)
    assert warnings == ["Vehicle defaults v.params refused (see the log): declared defaults used"]
    assert store.default("MPC_XY_P") == default_store().default("MPC_XY_P")  # all or nothing
    assert any("MC_ROLL_P" in line and "not applied" in line for line in log)
    (tmp_path / "v.params").write_text("1\t1\tMPC_XY_P\t1.1\t9\n")
    assert prepare_parameters(default_store(), vehicle_toml=toml, log=log.append) == []


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


def test_saver_writes_each_requested_snapshot_in_its_thread_and_skips_unchanged_text(store, tmp_path):
    path = tmp_path / "quad_x-0.params"
    saver = ParamSaver(store, path, vehicle_name="quad_x")
    try:
        assert saver.saves == 0 and not path.exists()
        store.set("MPC_XY_P", 1.2)
        assert not path.exists()  # written when asked (the link asks before it acknowledges a change)
        ticket = saver.request_save()
        assert saver.wait(ticket) == SaveOutcome(True) and saver.save_outcome(ticket) == SaveOutcome(True)
        assert saver.saves == 1 and read_param_file(path).values() == {"MPC_XY_P": pytest.approx(1.2)}
        for i in range(50):  # a burst (a ground station loading a file) within one link update: one snapshot
            store.set("MC_ROLL_P", 5.0 + i * 0.01)
        store.set("SYS_AUTOSTART", 4002)
        assert saver.wait(saver.request_save()).ok and saver.saves == 2
        assert read_param_file(path).values() == {
            "MC_ROLL_P": pytest.approx(5.49),
            "MPC_XY_P": pytest.approx(1.2),
            "SYS_AUTOSTART": 4002,
        }
        store.set("SYS_AUTOSTART", 4002)  # the same value again (a resent PARAM_SET): nothing to write
        assert saver.wait(saver.request_save()).ok and saver.saves == 2
        tickets = [saver.request_save() for _ in range(20)]  # requests made while a write runs are merged
        assert all(saver.wait(t).ok for t in tickets)
        store.set("MPC_XY_P", 0.95)  # back to the default: no longer saved
    finally:
        saver.close()  # writes what is left and stops the thread
    assert saver.saves == 3 and not saver._thread.is_alive()
    assert set(read_param_file(path).values()) == {"MC_ROLL_P", "SYS_AUTOSTART"}
    restored = default_store()
    applied, messages = load_file(restored, path)
    assert applied == 2 and messages == [] and restored.get("SYS_AUTOSTART") == 4002
    assert [p.name for p in tmp_path.iterdir()] == [path.name]  # no temporary file left behind


def test_saver_initial_save_and_write_errors_are_reported_and_retried(store, tmp_path):
    reports: list[str] = []
    missing = tmp_path / "missing-dir"
    saver = ParamSaver(store, missing / "x.params", initial_save=True, report=reports.append)
    assert "cannot save parameters to" in reports[0] and saver.saves == 0 and saver.failures == 1
    store.set("MPC_XY_P", 1.2)
    assert saver.wait(saver.request_save()) == SaveOutcome(False, "No such file or directory")  # for a STATUSTEXT
    missing.mkdir()
    assert saver.wait(saver.request_save()).ok and saver.saves == 1  # tried again
    saver.close()
    saver = ParamSaver(store, tmp_path / "y.params", initial_save=True)
    saver.close()
    assert saver.saves == 1 and read_param_file(tmp_path / "y.params", QGC).values() == {"MPC_XY_P": 1.2}


def test_start_up_removes_stale_temporaries_and_keeps_a_corrupt_state_file(store, tmp_path):
    path = state_file(tmp_path, "quad_x", 3)
    path.write_bytes(b"\x00\xffnot a parameter file\n1\t1\tMPC_XY_P\t1.3\t9\n")
    ours = [tmp_path / ".quad_x-3.params.a1b2.tmp", tmp_path / ".quad_x-3.plan.json.c3d4.tmp"]
    theirs = [tmp_path / ".quad_x-31.params.e5f6.tmp", tmp_path / ".firefly-3.params.g7h8.tmp"]
    for p in ours + theirs:
        p.write_text("half")
    log: list[str] = []
    warnings = prepare_parameters(store, state_path=path, log=log.append)
    assert not any(p.exists() for p in ours) and all(p.exists() for p in theirs)
    kept = tmp_path / "quad_x-3.params.corrupt"
    assert kept.read_bytes().startswith(b"\x00\xffnot a parameter") and not path.exists()
    assert store.changed() == {}  # nothing of a damaged file is applied, not even its good line
    assert warnings == ["Saved parameters corrupt, defaults used; file kept as quad_x-3.params.corrupt"]
    assert any(f"kept as {kept}, defaults used" in line and "line 1:" in line for line in log)
    assert any("removed 2 temporary file(s)" in line for line in log)
    path.write_text("garbage again\n")  # a second damaged file does not replace the first one kept
    assert prepare_parameters(store, state_path=path, log=log.append) != []
    assert (tmp_path / "quad_x-3.params.1.corrupt").read_text() == "garbage again\n" and kept.exists()
    ParamSaver(store, path, initial_save=True).close()  # a header-only state file (no change) is not corrupt
    assert prepare_parameters(store, state_path=path, log=log.append) == []
    assert any("saved parameters: 0 values" in line for line in log)


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
