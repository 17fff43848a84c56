"""The README cannot rot: each of its code blocks is a file under ``examples/`` that flies the real stack here.

Rule (strict, simple): every fenced block of README.md is, verbatim, the whole content of one file under
``examples/``, or one of the two commands (the demo and the test suite; ``.ci/run`` runs the latter
verbatim); every file under ``examples/`` is shown in the README.  The relative links of the README and of
``docs/*.md`` point to files that exist.

Every example then runs against ONE stack (a free instance, speed max) as the README tells a user to run it,
with the connection pointed at this stack's own ports (the examples take it as an argument; their defaults
are the real ones: 14550 for ground stations, 14540 for MAVSDK), and the test checks what the example
printed and, through a client of its own, what the vehicle did.  The shell example runs with ``.venv/bin``
replaced by this interpreter's directory.  (MAVSDK's example caught a real bug once: MAVSDK sends NaN in
COMPONENT_ARM_DISARM's unused param 2.)
"""

from __future__ import annotations

import math
import re
import subprocess
import sys
from pathlib import Path

import pytest

from gcs.client import VehicleClient
from gcs.launcher import Stack
from mavsim_core import geodesy, ports

from e2e_flight_helpers import CLIENT_SPEED  # tests/e2e_flight_helpers.py

ROOT = Path(__file__).resolve().parents[1]
README = ROOT / "README.md"
EXAMPLES = ROOT / "examples"
DEMO_COMMAND = "python3 -m venv .venv && .venv/bin/pip install . && .venv/bin/flight-demo\n"
TEST_COMMAND = "python3 -m venv .venv && .venv/bin/pip install '.[test]' && .venv/bin/python -m pytest -q\n"
WAIT_S = 120.0  # wall seconds: a safety net for each wait, never an assertion
FENCE = re.compile(r"^```[^\n]*\n(.*?)^```[ \t]*$", re.S | re.M)
LINK = re.compile(r"\]\(([^)#\s]+)(?:#[^)]*)?\)")


def readme_blocks() -> list[str]:
    """The content of each fenced code block of README.md, with its final newline."""
    return FENCE.findall(README.read_text())


def example_files() -> list[Path]:
    return sorted(p for p in EXAMPLES.iterdir() if p.is_file())


# ------------------------------------------------------------------------------ the README's blocks


def test_every_readme_block_is_an_example_file_or_one_of_the_two_commands():
    text = README.read_text()
    blocks = readme_blocks()
    fence_lines = [line for line in text.splitlines() if line.lstrip().startswith("```")]
    assert len(fence_lines) == 2 * len(blocks), "a fence that does not open or close a top-level block"
    files = {p.name: p.read_text() for p in example_files()}
    for block in blocks:
        assert block in (DEMO_COMMAND, TEST_COMMAND) or block in files.values(), (
            f"this README block is neither an examples/ file's whole content nor one of the two commands:\n{block}"
        )
    assert DEMO_COMMAND in blocks and TEST_COMMAND in blocks
    for name, content in files.items():
        assert content in blocks, f"examples/{name} is not shown in the README (verbatim)"


def test_ci_runs_the_readme_test_command_verbatim():
    assert TEST_COMMAND.strip() in (ROOT / ".ci" / "run").read_text()


@pytest.mark.parametrize("page", ["README.md", *sorted(f"docs/{p.name}" for p in (ROOT / "docs").glob("*.md"))])
def test_relative_links_point_to_files_that_exist(page):
    path = ROOT / page
    for target in LINK.findall(path.read_text()):
        if "://" in target or target.startswith("mailto:"):
            continue
        assert (path.parent / target).exists(), f"{page} links to {target}, which does not exist"


# ------------------------------------------------------------------------------ the examples, flown


@pytest.fixture(scope="module")
def stack(free_instance, tmp_path_factory):
    with Stack(instance=free_instance(), speed=CLIENT_SPEED, log_dir=tmp_path_factory.mktemp("examples_stack")) as s:
        yield s


def ready_client(stack: Stack, url: str | None = None) -> VehicleClient:
    """A client of the stack (on its ground-station port unless ``url``) once the vehicle is on the ground,
    disarmed and ready to arm: what a user waits for before running an example."""
    client = VehicleClient(url or stack.gcs_url, timeout_s=WAIT_S, target_system=stack.sysid, idle=stack.check_alive)
    client.wait_until(lambda: client.prearm_ok() and client.landed_and_disarmed(), WAIT_S, "ready to arm")
    return client


def run(command: list[str], cwd: Path) -> subprocess.CompletedProcess:
    done = subprocess.run(command, capture_output=True, text=True, timeout=300, cwd=cwd)  # timeout: a safety net
    assert done.returncode == 0, done.stdout + done.stderr
    assert "Traceback" not in done.stderr
    return done


def landed_here(stack: Stack) -> tuple[float, float, float]:
    """(lat, lon, alt above home) once the vehicle is down and disarmed (checked by a client of its own)."""
    with ready_client(stack) as client:
        lat, lon, _ = client.global_position()
        return lat, lon, client.relative_alt_m()


def fly_gcs_sh(stack: Stack, path: Path, tmp_path: Path) -> None:
    script = tmp_path / path.name
    script.write_text(path.read_text().replace(".venv/bin", str(Path(sys.executable).parent)))
    # At --speed max, PX4's 10 s disarm-if-no-take-off (COM_DISARM_PRFLT) passes in the wall second between two
    # gcs processes; a person typing at real time has 10 s.  Lifted for this example, restored after.
    with ready_client(stack) as client:
        client.param_set("COM_DISARM_PRFLT", -1.0)
    try:
        out = run(["sh", str(script), "--url", stack.gcs_url, "-i", str(stack.instance)], tmp_path).stdout
    finally:
        with VehicleClient(stack.gcs_url, timeout_s=WAIT_S, target_system=stack.sysid) as client:
            client.param_set("COM_DISARM_PRFLT", 10.0)
    assert re.search(r"^armed", out, re.M) and "landed and disarmed" in out, out
    takeoff_alt_m = float(re.search(r"takeoff (\S+)", path.read_text()).group(1))
    assert float(re.search(r"^at (\S+) m above home", out, re.M).group(1)) == pytest.approx(takeoff_alt_m, abs=0.5)
    target_lat, target_lon = (float(v) for v in re.search(r"goto (\S+) (\S+)", path.read_text()).groups())
    lat, lon, alt = landed_here(stack)
    north, east, _ = geodesy.geodetic_to_ned(target_lat, target_lon, 0.0, lat, lon, 0.0)
    assert math.hypot(north, east) < 1.5, f"landed {math.hypot(north, east):.2f} m from the goto point"
    assert abs(alt) < 0.5


def fly_mavproxy_txt(stack: Stack, path: Path, tmp_path: Path) -> None:
    from e2e_params_clients import MavproxySession  # tests/e2e_params_clients.py (MAVProxy in its own venv)

    observer = ready_client(stack, stack.api_url)  # the vehicle as another client sees it
    # A person types the lines with the vehicle in real time; here each is sent once the last one's effect
    # is seen, on the wall clock, while the stack runs at ~30x: a loaded machine's half second between
    # "arm throttle" and "takeoff 5" is 15 simulated seconds, past COM_DISARM_PRFLT's 10 (disarmed, no
    # take-off).  So the flight runs without that time-out, and gets it back after.
    prflt = observer.param_get("COM_DISARM_PRFLT")
    observer.param_set("COM_DISARM_PRFLT", -1)
    effects = {  # what each line of the file does; a line not listed here fails the test
        "arm throttle": observer.armed,
        "takeoff 5": lambda: observer.takeoff_done(5.0),
        "long DO_SET_MODE 1 4 6": observer.landed_and_disarmed,  # AUTO.LAND (main mode 4, sub-mode 6)
    }
    mavproxy = MavproxySession(stack.gcs_url, modules=None)  # MAVProxy's own default modules, as a user runs it
    try:
        mavproxy.expect(rf"online system {stack.sysid}\b", WAIT_S)
        for line in path.read_text().splitlines():
            mavproxy.send(line)
            observer.wait_until(effects[line], WAIT_S, f"the effect of {line!r}")
    finally:
        mavproxy.close()
        observer.param_set("COM_DISARM_PRFLT", prflt)
        observer.close()


def fly_mavsdk_py(stack: Stack, path: Path, tmp_path: Path) -> None:
    pytest.importorskip("mavsdk", reason="MAVSDK is in the test extras: pip install '.[test]'")
    ready_client(stack).close()
    out = run([sys.executable, str(path), f"udpin://0.0.0.0:{ports.api_port(stack.instance)}"], tmp_path).stdout
    lines = out.splitlines()
    assert lines[0] == "connected: autopilot PX4"  # MAVSDK takes it for PX4 (the heartbeat's identity)
    assert float(lines[1].split()[1]) == pytest.approx(4.0, abs=0.5)  # "at 4.02 m above home; landing"
    assert lines[2] == "landed and disarmed"
    with ready_client(stack) as client:
        assert client.param_get("MIS_TAKEOFF_ALT") == pytest.approx(4.0)  # set by MAVSDK's set_takeoff_altitude
        assert abs(client.relative_alt_m()) < 0.5


def fly_pymavlink_py(stack: Stack, path: Path, tmp_path: Path) -> None:
    with ready_client(stack) as client:
        takeoff_alt_m = float(client.param_get("MIS_TAKEOFF_ALT"))
    lines = run([sys.executable, str(path), stack.gcs_url], tmp_path).stdout.splitlines()
    assert lines[0] == f"heartbeat from system {stack.sysid}"
    assert float(lines[1].split()[2]) == pytest.approx(takeoff_alt_m, abs=0.5)  # "hovering at 2.46 m above home"
    assert lines[2] == "landed and disarmed"
    assert abs(landed_here(stack)[2]) < 0.5


FLIGHTS = {
    "gcs_fly.sh": fly_gcs_sh,
    "mavproxy_fly.txt": fly_mavproxy_txt,
    "mavsdk_fly.py": fly_mavsdk_py,
    "pymavlink_fly.py": fly_pymavlink_py,
}


@pytest.mark.e2e
@pytest.mark.parametrize("name", [p.name for p in example_files()])
def test_the_example_flies_the_stack(stack, name, tmp_path):
    assert name in FLIGHTS, f"examples/{name} has no runner here: add one to FLIGHTS"
    try:
        FLIGHTS[name](stack, EXAMPLES / name, tmp_path)
    finally:
        land_if_flying(stack)  # so that one failed example does not fail the next ones too


def land_if_flying(stack: Stack) -> None:
    with VehicleClient(stack.gcs_url, timeout_s=WAIT_S, target_system=stack.sysid, idle=stack.check_alive) as client:
        client.wait_until(lambda: client.latest("HEARTBEAT") is not None, WAIT_S, "a heartbeat")
        if client.armed():
            client.land()
            client.wait_until(client.landed_and_disarmed, WAIT_S, "the landing after a failed example")
