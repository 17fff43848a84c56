"""End-to-end: the parameter service of the real flight controller, over real sockets.

One max-speed stack (module scope, a free instance) started with ``--state-dir`` and
``--params``; it is never armed.  The clients:

* a :class:`VehicleClient` (pymavlink);
* ``python -m gcs --url ... param ...`` as a subprocess;
* MAVSDK's Param plugin;
* MAVProxy's ``param set`` / ``param show`` through its stdin, in a virtual environment of its own
  (tests/mavproxy_env.py) (these two driven by tests/e2e_params_clients.py).

Every client talks *to* the flight controller's own sockets (``udpout`` to its
ground-station socket, 18570 + instance, or its API socket, 14640 + instance) and so
becomes a peer that gets the replies, the way a ground station on another
machine does.  None binds a fixed port: instance I's ground-station ports
(14540 + I, 14840 + I) may also be bound by a person's clients.
``gcs`` resolving to 14550 is tested in tests/test_gcs_cli.py.

Every test leaves the parameters as it found them.  Wall-clock values are only
"give up waiting" timeouts; the download time is measured and printed, never
asserted.  The simulator's truth port (14740 + I) is turned off.
"""

from __future__ import annotations

import asyncio
import importlib
import re
import statistics
import struct
import subprocess
import sys
import time
from collections import Counter
from pathlib import Path

import pytest

importlib.import_module("autopilot.flight_controller")  # declares every parameter
from autopilot.param_catalogue import default_store
from gcs.client import VehicleClient, mavlink
from gcs.errors import GcsTimeout, ParamRefused, ParamUnknown
from gcs.launcher import Stack
from gcs.plugins.param import DownloadStats, download_parameters
from mavsim_core.param_encoding import INT32, REAL32, raw_param_value
from params.param_file import QGC, parse_param_text, read_param_file

ROOT = Path(__file__).resolve().parent.parent

from mavsim_core import ports

from e2e_flight_helpers import CLIENT_SPEED  # tests/e2e_flight_helpers.py
from e2e_params_clients import WAIT_S, MavproxySession, mavsdk_params  # tests/e2e_params_clients.py

pytestmark = pytest.mark.e2e

# The vehicle's own default of MPC_XY_P (quad_x's design-gains block), which the tests change and put back.
XY_P = float(read_param_file(ROOT / "params" / "vehicles" / "quad_x.params").values()["MPC_XY_P"])
ROLLRATE_P = float(read_param_file(ROOT / "params" / "vehicles" / "quad_x.params").values()["MC_ROLLRATE_P"])

STARTUP_PARAMS = (
    "# start-up file of the end-to-end test (QGroundControl format)\n"
    "1\t1\tMC_ROLL_P\t7\t9\n"
    "1\t1\tNO_SUCH_PARAM\t1\t9\n"
    "1\t1\tMPC_XY_P\t50\t9\n"
)


@pytest.fixture(scope="module")
def state_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("fc-state")


@pytest.fixture(scope="module")
def stack(inst, state_dir):
    startup = state_dir.parent / "startup.params"
    startup.write_text(STARTUP_PARAMS)
    with Stack(
        instance=inst,
        speed=CLIENT_SPEED,
        extra_sitl_args=["--truth-port", "0"],
        extra_autopilot_args=["--state-dir", str(state_dir), "--params", str(startup)],
        flight_logs=False,
    ) as s:
        yield s


@pytest.fixture(scope="module")
def client(stack):
    with VehicleClient(fc_gcs_url(stack), timeout_s=WAIT_S, idle=stack.check_alive) as c:
        yield c


@pytest.fixture(scope="module")
def declared():
    return default_store()


def fc_gcs_url(stack: Stack) -> str:
    """The flight controller's ground-station socket (18570 + instance), as a ``udpout`` url."""
    return f"udpout:127.0.0.1:{ports.gcs_local_port(stack.instance)}"


def run_gcs(stack: Stack, *args: str, timeout_s: float = 120.0) -> subprocess.CompletedProcess:
    """``python -m gcs --url udpout:127.0.0.1:<18570 + instance> ...``."""
    cmd = [sys.executable, "-m", "gcs", "--url", fc_gcs_url(stack), *args]
    return subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=timeout_s)


def state_values(state_dir: Path, stack: Stack) -> dict:
    path = state_dir / f"quad_x-{stack.instance}.params"
    return read_param_file(path, QGC).values() if path.exists() else {}


def get_when_up(client: VehicleClient, name: str, timeout_s: float = WAIT_S) -> int | float:
    """Read a parameter from a flight controller that may still be starting (short tries until it answers)."""
    deadline = time.monotonic() + timeout_s
    while True:
        try:
            return client.param_get(name, timeout_s=0.5, retries=1)
        except GcsTimeout:
            if time.monotonic() > deadline:
                raise


def wait_for(predicate, timeout_s: float = WAIT_S, what: str = "a condition"):
    deadline = time.monotonic() + timeout_s
    while not (value := predicate()):
        assert time.monotonic() < deadline, f"timed out waiting for {what}"
        time.sleep(0.05)
    return value


# --------------------------------------------------------------------------- start-up and download


def test_startup_param_file_applied_and_bad_lines_reported(stack, client):
    assert client.param_get("MC_ROLL_P") == pytest.approx(7.0)
    assert client.param_get("MPC_XY_P") == pytest.approx(XY_P)  # 50 was refused
    log = stack.tail("autopilot", 200)
    assert "line 3: unknown parameter NO_SUCH_PARAM" in log
    assert "line 4: MPC_XY_P: 50 outside range [0, 2] 1/s" in log
    assert "parameter changes are saved to" in log


def test_full_download_is_complete_and_consistent(client, declared):
    raw: list = []

    def note(msg) -> None:
        if msg.get_type() == "PARAM_VALUE":
            raw.append(msg)

    times, stats = [], DownloadStats()
    client.add_listener(note)
    try:
        for attempt in range(3):
            raw.clear()
            start = time.monotonic()
            params = client.param_list()
            times.append(time.monotonic() - start)
            if attempt == 0:
                first_raw = list(raw)
        download_parameters(client, stats=stats)
    finally:
        client.remove_listener(note)
    count = len(params)
    print(
        f"\nfull parameter download: {count} parameters in {min(times) * 1000:.1f} ms (best of 3), "
        f"median {statistics.median(times) * 1000:.1f} ms; re-requested {stats.re_requested}"
    )
    assert count == len(declared) and [p.index for p in params] == list(range(count))
    names = [p.name for p in params]
    assert len(set(names)) == count and names == declared.names()  # the registry, in index order
    assert {m.param_count for m in first_raw} == {count}
    indices = Counter(m.param_index for m in first_raw)
    assert set(indices) == set(range(count))  # every index 0..count-1 came in the list stream ...
    assert all(n == 1 for n in indices.values())  # ... exactly once
    by_name = {p.name: p for p in params}
    assert by_name["SYS_AUTOSTART"].mav_type == INT32 and by_name["SYS_AUTOSTART"].value == 4001
    assert by_name["MPC_XY_P"].mav_type == REAL32
    for p in params:  # types as declared
        assert p.mav_type == (INT32 if declared.definition(p.name).ptype == "INT32" else REAL32)


# --------------------------------------------------------------------------- set, read back, refuse


def test_set_and_read_back_int32_and_real32(client):
    echoes: list = []

    def note(msg) -> None:
        if msg.get_type() == "PARAM_VALUE":
            echoes.append(msg)

    client.add_listener(note)
    try:
        assert client.param_set("SYS_AUTOSTART", 4002) == 4002
        got = client.param_get("SYS_AUTOSTART")
        assert got == 4002 and isinstance(got, int)
        echo = next(m for m in reversed(echoes) if m.param_id == "SYS_AUTOSTART")
        assert raw_param_value(echo) == struct.pack("<i", 4002)  # PX4's byte-wise encoding on the wire
        assert client.param_set("MPC_XY_P", 1.25) == pytest.approx(1.25)
        got = client.param_get("MPC_XY_P")
        assert got == pytest.approx(1.25) and isinstance(got, float)
    finally:
        client.remove_listener(note)
        client.param_set("SYS_AUTOSTART", 4001)
        client.param_set("MPC_XY_P", XY_P)


def test_refused_sets_are_answered_and_change_nothing(client):
    before = {p.name: p.value for p in client.param_list()}
    n_texts = len(client.statustexts)
    with pytest.raises(ParamRefused, match=rf"MPC_XY_P not set to 5.0: vehicle kept {XY_P:g}.*outside range \[0, 2\]"):
        client.param_set("MPC_XY_P", 5.0)
    with pytest.raises(ParamRefused, match="vehicle kept 4001 .*SYS_AUTOSTART is INT32, not REAL32"):
        client.param_set("SYS_AUTOSTART", 4010.0, param_type=mavlink.MAV_PARAM_TYPE_REAL32)
    with pytest.raises(ParamRefused, match="MPC_LAND_SPEED 1.8 refused: must be <= MPC_Z_VEL_MAX_DN"):
        client.param_set("MPC_LAND_SPEED", 1.8)
    with pytest.raises(ParamUnknown, match="unknown parameter NO_SUCH_PARAM"):  # no PARAM_VALUE: a PARAM_ERROR ...
        client.param_set("NO_SUCH_PARAM", 1.0, param_type=mavlink.MAV_PARAM_TYPE_REAL32)
    texts = [t.text for t in client.statustexts[n_texts:]]
    assert "unknown parameter NO_SUCH_PARAM" in texts  # ... but a STATUSTEXT says why
    assert {p.name: p.value for p in client.param_list()} == before


# --------------------------------------------------------------------------- persistence


def test_values_persist_across_a_restart(stack, client, state_dir):
    client.param_set("MC_ROLLRATE_P", 14.5)
    client.param_set("SYS_AUTOSTART", 4003)  # within the save interval: written at exit
    stack.restart_autopilot()
    assert get_when_up(client, "SYS_AUTOSTART") == 4003
    assert client.param_get("MC_ROLLRATE_P") == pytest.approx(14.5)
    assert client.param_get("MC_ROLL_P") == pytest.approx(7.0)  # --params applies again
    saved = state_values(state_dir, stack)
    assert saved["SYS_AUTOSTART"] == 4003 and saved["MC_ROLLRATE_P"] == pytest.approx(14.5)
    assert "saved parameters:" in stack.tail("autopilot", 40)

    client.param_set("MC_ROLLRATE_P", ROLLRATE_P)
    client.param_set("SYS_AUTOSTART", 4001)
    wait_for(lambda: set(state_values(state_dir, stack)) == {"MC_ROLL_P"}, what="defaults dropped from the state file")


# --------------------------------------------------------------------------- gcs param


def test_gcs_param_list_get_set(stack, client):
    p = run_gcs(stack, "param", "list", "MPC_XY_*")
    assert p.returncode == 0, p.stderr
    lines = p.stdout.splitlines()
    assert lines[0].startswith("MPC_XY_CRUISE") and all(line.startswith("MPC_XY_") for line in lines)
    assert f"MPC_XY_P         {XY_P:g}" in lines
    assert re.search(r"downloaded \d+ parameters in \d+\.\d\d s", p.stderr)
    p = run_gcs(stack, "param", "set", "MPC_XY_P", "1.1")
    assert p.returncode == 0 and p.stdout.strip() == "MPC_XY_P = 1.1", p.stderr
    p = run_gcs(stack, "param", "get", "MPC_XY_P")
    assert p.returncode == 0 and p.stdout.strip() == "MPC_XY_P = 1.1"
    p = run_gcs(stack, "param", "set", "MPC_XY_P", "7")
    assert p.returncode == 1 and "outside range" in p.stderr
    client.param_set("MPC_XY_P", XY_P)


def test_qgc_file_round_trips_through_gcs_param_save_and_load(stack, client, tmp_path):
    saved = tmp_path / "vehicle.params"
    p = run_gcs(stack, "param", "save", str(saved))
    assert p.returncode == 0, p.stderr
    pf = read_param_file(saved)
    vehicle = {q.name: q for q in client.param_list()}
    assert pf.format == QGC and pf.problems == [] and len(pf.entries) == len(vehicle)
    sysid = stack.sysid  # QGroundControl writes the vehicle's system id into each line
    assert all(e.mav_type == vehicle[e.name].mav_type and e.sysid == sysid and e.compid == 1 for e in pf.entries)

    client.param_set("MPC_XY_P", 1.1)
    client.param_set("SYS_AUTOSTART", 4004)
    p = run_gcs(stack, "param", "diff", str(saved))
    assert p.returncode == 0, p.stderr
    diff = {line.split()[0]: line.split()[1:] for line in p.stdout.splitlines()[1:]}
    assert diff == {"MPC_XY_P": [f"{XY_P:g}", "1.1"], "SYS_AUTOSTART": ["4001", "4004"]}

    p = run_gcs(stack, "param", "load", str(saved))
    assert p.returncode == 0, p.stderr
    assert f"MPC_XY_P: 1.1 -> {XY_P:g}" in p.stdout and "SYS_AUTOSTART: 4004 -> 4001" in p.stdout
    assert f"loaded {saved}: 2 set, {len(vehicle) - 2} unchanged, 0 refused" in p.stdout
    assert client.param_get("MPC_XY_P") == pytest.approx(XY_P) and client.param_get("SYS_AUTOSTART") == 4001

    mavproxy_copy = tmp_path / "copy.parm"
    assert run_gcs(stack, "param", "save", str(mavproxy_copy), "--format", "mavproxy").returncode == 0
    again = parse_param_text(mavproxy_copy.read_text())
    assert again.format == "mavproxy" and again.values().keys() == pf.values().keys()


def test_gcs_param_load_reports_each_refusal(stack, client, tmp_path):
    bad = tmp_path / "bad.parm"
    bad.write_text(
        "MPC_XY_P 5\nNOPE_PARAM 1\nMPC_LAND_SPEED 1.8\nMPC_Z_VEL_MAX_DN 2\nSYS_AUTOSTART 4001.5\nnot a line at all\n"
    )
    try:
        p = run_gcs(stack, "param", "load", str(bad))
        assert p.returncode == 1
        err = p.stderr
        assert f"{bad}, line 1: MPC_XY_P refused: MPC_XY_P not set to 5" in err and "outside range" in err
        assert f"{bad}, line 2: NOPE_PARAM refused: the vehicle has no such parameter" in err
        assert f"{bad}, line 5: SYS_AUTOSTART refused: SYS_AUTOSTART is an integer on the vehicle" in err
        assert f"{bad}, line 6: expected 'NAME VALUE'" in err
        # MPC_LAND_SPEED 1.8 needs MPC_Z_VEL_MAX_DN 2 first: the second pass sets it
        assert "MPC_Z_VEL_MAX_DN: 1.5 -> 2" in p.stdout and "MPC_LAND_SPEED: 0.7 -> 1.8" in p.stdout
        assert client.param_get("MPC_LAND_SPEED") == pytest.approx(1.8)
    finally:
        client.param_set("MPC_LAND_SPEED", 0.7)
        client.param_set("MPC_Z_VEL_MAX_DN", 1.5)


# --------------------------------------------------------------------------- other ground stations


def test_mavsdk_param_plugin_sets_and_gets_int_and_float(stack, client):
    pytest.importorskip("mavsdk", reason="MAVSDK is in the test extras: pip install '.[test]'")
    seen = asyncio.run(mavsdk_params(ports.api_local_port(stack.instance)))
    assert seen == {
        "int_before": 4001,
        "int_after": 4005,
        "float_before": pytest.approx(XY_P),
        "float_after": pytest.approx(1.15),
    }
    assert client.param_get("SYS_AUTOSTART") == 4001 and client.param_get("MPC_XY_P") == pytest.approx(XY_P)


def shown_once_settled(session: MavproxySession, name: str, wanted: str) -> str:
    """What MAVProxy's ``param show NAME`` prints once it shows ``wanted`` (compared as floats), or the last
    value it showed after WAIT_S wall seconds.  MAVProxy shows its own copy, updated when the vehicle's
    PARAM_VALUE echo reaches it; on a loaded machine our client can read the new value first, so the first
    ``show`` after the set may still print the old one (0.825 once, beside a second suite)."""
    deadline = time.monotonic() + WAIT_S
    while True:
        session.send(f"param show {name}")
        shown = session.expect(rf"^(?:\S+> )*{name}\s+([-+0-9.eE]+)").group(1)
        if float(shown) == pytest.approx(float(wanted)) or time.monotonic() > deadline:
            return shown
        time.sleep(0.2)


def test_mavproxy_param_set_and_show(stack, client):
    session = MavproxySession(fc_gcs_url(stack))
    try:
        count = int(session.expect(r"Received (\d+) parameters").group(1))
        assert count == len(client.param_list())
        session.send("param set MPC_XY_P 1.3")
        wait_for(lambda: client.param_get("MPC_XY_P") == pytest.approx(1.3), what="MAVProxy's set")
        assert float(shown_once_settled(session, "MPC_XY_P", "1.3")) == pytest.approx(1.3)
        session.send("param set SYS_AUTOSTART 4006")
        wait_for(lambda: client.param_get("SYS_AUTOSTART") == 4006, what="MAVProxy's set")
        assert shown_once_settled(session, "SYS_AUTOSTART", "4006") == "4006"  # byte-wise integer
        session.send("param set MPC_XY_P 7")  # refused: the vehicle's reason is shown
        session.expect(r"MPC_XY_P: 7 outside range \[0, 2\]")
        assert client.param_get("MPC_XY_P") == pytest.approx(1.3)
    finally:
        session.close()
        client.param_set("MPC_XY_P", XY_P)
        client.param_set("SYS_AUTOSTART", 4001)
