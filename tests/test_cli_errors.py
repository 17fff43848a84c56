"""Bad invocations of ``sitl``, ``autopilot``, ``flight-demo`` and ``python -m vision``, as a user types them.

Each runs the console script's ``main(argv)`` (in the test's process, ``tests/cli_in_process.py``: no stack,
each fails before anything starts) and must end with the documented exit code (2 usage error, argparse's
own; 1 refused or failed: a file that cannot be read, a directory that cannot be created, a port already in
use) and ONE line on stderr that names the option (or the port) - argparse's ``usage:`` lines aside - and
never a traceback.  Three of them find the
instance's port already taken (this test holds it).  Then ``--help`` of each script, and ``--version`` of each
installed console script as a process of its own: the entry point and the interpreter's part run for real once
per script.

All of them run in a module fixture (the processes four at a time), the tests read their results.  Instance
numbers come from ``free_instance``; files are under pytest's temporary directory.
"""

from __future__ import annotations

import importlib
import socket
import subprocess
import sys
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

import pytest

from mavsim_core import ports
from mavsim_core.cli_args import EXIT_CODES_EPILOG, version

from cli_in_process import call_main  # tests/cli_in_process.py

# each script's main, imported by the fixture (not when every xdist worker collects this file)
MAINS = {"sitl": "sitl.__main__", "autopilot": "autopilot.__main__", "flight-demo": "gcs.launcher.demo"}
MAINS |= {"python -m vision": "vision.__main__"}
BIN = Path(sys.executable).parent  # the console scripts of the environment running the tests
SCRIPTS = {"sitl": [str(BIN / "sitl")], "autopilot": [str(BIN / "autopilot")]}
SCRIPTS |= {"flight-demo": [str(BIN / "flight-demo")], "python -m vision": [sys.executable, "-m", "vision"]}
TIMEOUT_S = 120  # a safety net: each should end in about a second

# id: (script, arguments, exit code, what the one line must contain).  {i}: a free instance, {tmp}: a
# temporary directory with broken.toml, bad_scenario.toml, a_file (a file where a directory is asked for),
# not_a_video.avi; missing.* do not exist.
BAD = {
    "sitl-instance-too-big": ("sitl", "--instance 70000", 2, "--instance"),
    "sitl-instance-negative": ("sitl", "-i -1", 2, "--instance"),
    "sitl-unknown-vehicle": ("sitl", "-i {i} --vehicle nope", 2, "--vehicle"),
    "sitl-broken-vehicle-file": ("sitl", "-i {i} --vehicle {tmp}/broken.toml", 2, "--vehicle"),
    "sitl-broken-scenario-file": ("sitl", "-i {i} --scenario {tmp}/bad_scenario.toml", 2, "--scenario"),
    "sitl-unknown-param": ("sitl", "-i {i} --param SIM_NOPE=1", 2, "--param"),
    "sitl-home-out-of-range": ("sitl", "-i {i} --home 91,0,0", 2, "--home"),
    "sitl-speed-zero": ("sitl", "-i {i} --speed 0", 2, "--speed"),
    "sitl-port-too-big": ("sitl", "-i {i} --port 70000", 2, "--port"),
    "sitl-log-dir-not-creatable": ("sitl", "-i {i} --log-dir {tmp}/a_file/logs", 1, "--log-dir"),
    "sitl-port-in-use": ("sitl", "-i {i} --speed max", 1, "TCP 127.0.0.1:{sim_port}"),
    "autopilot-instance-too-big": ("autopilot", "--instance 70000", 2, "--instance"),
    "autopilot-missing-params-file": ("autopilot", "-i {i} --no-log --params {tmp}/missing.params", 1, "--params"),
    "autopilot-sysid-too-big": ("autopilot", "-i {i} --sysid 256", 2, "--sysid"),
    "autopilot-port-zero": ("autopilot", "-i {i} --gcs-port 0", 2, "--gcs-port"),
    "autopilot-unknown-input-clock": ("autopilot", "-i {i} --input-clock wall", 2, "--input-clock"),
    "autopilot-state-dir-is-a-file": ("autopilot", "-i {i} --no-log --state-dir {tmp}/a_file", 1, "--state-dir"),
    "autopilot-log-dir-not-creatable": ("autopilot", "-i {i} --log-dir {tmp}/a_file/logs", 1, "--log-dir"),
    "autopilot-port-in-use": ("autopilot", "-i {i} --no-log", 1, "UDP 0.0.0.0:{gcs_local_port}"),
    "flight-demo-instance-too-big": ("flight-demo", "-i 100", 2, "--instance"),
    "flight-demo-log-dir-not-creatable": ("flight-demo", "-i {i} --log-dir {tmp}/a_file/logs", 1, "--log-dir"),
    "flight-demo-port-in-use": ("flight-demo", "-i {i}", 1, "TCP {sim_port}"),
    "vision-missing-video": ("python -m vision", "-i {i} --video {tmp}/missing.avi", 1, "--video"),
    "vision-not-a-video": ("python -m vision", "-i {i} --video {tmp}/not_a_video.avi", 1, "--video"),
    "vision-port-too-big": ("python -m vision", "--video {tmp}/missing.avi --to 127.0.0.1:99999", 2, "--to"),
    "vision-hfov-too-wide": ("python -m vision", "--video {tmp}/missing.avi --hfov 180", 2, "--hfov"),
}
IN_USE = {"sitl-port-in-use", "autopilot-port-in-use", "flight-demo-port-in-use"}  # these say what to do, too


def _files(tmp: Path) -> None:
    (tmp / "broken.toml").write_text("name = 'broken'\n[body\n")
    (tmp / "bad_scenario.toml").write_text("[parameters]\nSIM_WIND_SPD = 999\n")
    (tmp / "a_file").write_text("a file, not a directory\n")
    (tmp / "not_a_video.avi").write_text("not a video\n")


def _hold_ports(instance: int) -> list[socket.socket]:
    """Take the instance's simulator TCP port (listening, as a running sitl does) and its ground-station UDP port."""
    tcp = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    tcp.bind(("127.0.0.1", ports.sim_tcp_port(instance)))
    tcp.listen()
    udp = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    udp.bind(("0.0.0.0", ports.gcs_local_port(instance)))
    return [tcp, udp]


def _run(command: list[str], cwd: Path) -> subprocess.CompletedProcess:
    return subprocess.run(command, cwd=cwd, capture_output=True, text=True, timeout=TIMEOUT_S)


@pytest.fixture(scope="module")
def runs(tmp_path_factory, free_instance):
    """Every invocation's completed process (BAD by id, then ``--version`` and ``--help`` by script name)."""
    tmp = tmp_path_factory.mktemp("cli-errors")
    _files(tmp)
    instance = free_instance()
    fill = {"i": instance, "tmp": tmp}
    calls = {key: (script, args.format(**fill).split()) for key, (script, args, _, _) in BAD.items()}
    calls |= {("--help", name): (name, ["--help"]) for name in SCRIPTS}
    held = _hold_ports(instance)
    try:
        with ThreadPoolExecutor(max_workers=4) as pool:
            futures = {
                ("--version", name): pool.submit(_run, command + ["--version"], tmp)
                for name, command in SCRIPTS.items()
            }
            mains = {script: importlib.import_module(module).main for script, module in MAINS.items()}
            done = {key: call_main(mains[script], script, argv, tmp) for key, (script, argv) in calls.items()}
            done |= {key: future.result() for key, future in futures.items()}
    finally:
        for sock in held:
            sock.close()
    done["instance"] = instance
    return done


def message_lines(stderr: str) -> list[str]:
    """stderr's lines without argparse's ``usage:`` block (its first line and their indented continuations)."""
    lines = [line for line in stderr.splitlines() if line.strip()]
    if lines and lines[0].startswith("usage:"):
        lines = lines[1:]
        while lines and lines[0].startswith(" "):
            lines = lines[1:]
    return lines


@pytest.mark.parametrize("key", list(BAD))
def test_bad_invocation_is_one_line_naming_the_option(runs, key):
    script, _args, code, names = BAD[key]
    done = runs[key]
    instance = runs["instance"]
    names = names.format(sim_port=ports.sim_tcp_port(instance), gcs_local_port=ports.gcs_local_port(instance))
    shown = f"exit {done.returncode}\nstdout:\n{done.stdout[-2000:]}\nstderr:\n{done.stderr[-2000:]}"
    assert "Traceback" not in done.stderr, shown
    assert done.returncode == code, shown
    lines = message_lines(done.stderr)
    assert len(lines) == 1, shown
    assert names in lines[0], shown
    if key in IN_USE:
        assert f"instance {instance}? choose another -i" in lines[0], shown


@pytest.mark.parametrize("script", list(SCRIPTS))
def test_version(runs, script):
    done = runs[("--version", script)]
    assert done.returncode == 0, done.stderr
    assert done.stdout.strip() == f"{script} {version()}"


@pytest.mark.parametrize("script", list(SCRIPTS))
def test_help_documents_the_exit_codes(runs, script):
    done = runs[("--help", script)]
    assert done.returncode == 0, done.stderr
    assert EXIT_CODES_EPILOG in " ".join(done.stdout.split())  # argparse wraps it to the terminal's width
