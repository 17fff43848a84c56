"""Bad invocations of the ``gcs`` console script: one line that says what is wrong, the right exit code.

Each row runs the ``gcs`` script's ``main(argv)`` (in the test's process, ``tests/cli_in_process.py``, in the
test's own temporary directory) with something a person could type wrong, and no vehicle anywhere: a bad
option value is argparse's usage line plus one ``error:`` line naming the argument and the allowed range
(exit 2); a file that cannot be read is one line (exit 1) before anything is sent; a vehicle that does not
answer is one line (exit 3).  Never a traceback, nothing on stdout.  Also: ``--version`` (the installed
console script, a process of its own: its entry point runs for real), and every sub-command's ``--help``
ends with the exit codes.
"""

from __future__ import annotations

import argparse
import socket
import subprocess
import sys
from pathlib import Path

import pytest

from gcs.cli_parser import build_parser
from mavsim_core import cli_args

from cli_in_process import call_main  # tests/cli_in_process.py

GCS = Path(sys.executable).with_name("gcs")  # the console script beside this interpreter (the venv's bin)
COMMAND = [str(GCS)] if GCS.exists() else [sys.executable, "-m", "gcs"]


def run_gcs(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    """``gcs ARGS`` as the installed console script: a process."""
    return subprocess.run(COMMAND + args, cwd=cwd, capture_output=True, text=True, timeout=60)


def call_gcs(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    """``gcs ARGS`` as its ``main(argv)`` in this process."""
    from gcs.__main__ import main

    return call_main(main, "gcs", args, cwd)


def silent_url() -> str:
    """A UDP port nobody sends to (free a moment ago)."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return f"udpin:127.0.0.1:{s.getsockname()[1]}"


INSTANCE_RANGE = "argument -i/--instance: must be 0-99 (PX4's port scheme leaves room for no more), not"
BAD = [  # (id, arguments, exit code, the message line starts with, ... and contains)
    ("instance-too-big", ["--instance", "70000", "status"], 2, "gcs: error:", f"{INSTANCE_RANGE} 70000"),
    ("instance-negative", ["-i", "-1", "arm"], 2, "gcs: error:", f"{INSTANCE_RANGE} -1"),
    ("url-nonsense", ["--url", "nonsense", "status"], 2, "gcs: --url nonsense:", "neither udpin:/udp:/tcp:HOST:PORT"),
    ("param-nan", ["param", "set", "MPC_XY_P", "nan"], 2, "gcs param set: error:", "must be a finite number"),
    ("param-name-long", ["param", "get", "A_NAME_OF_17_CHAR"], 2, "gcs param get: error:", "1-16 ASCII characters"),
    ("mode-unknown", ["mode", "GUIDED"], 2, "gcs mode: error:", "unknown mode 'GUIDED'; known: MANUAL"),
    ("goto-lat", ["goto", "91", "8.5457", "10"], 2, "gcs goto: error:", "latitude must be -90..90, not 91"),
    ("goto-alt-nan", ["goto", "47.3979", "8.5457", "nan"], 2, "gcs goto: error:", "argument ALT: must be a finite"),
    ("watch-count", ["watch", "--count", "0"], 2, "gcs watch: error:", "must be an integer >= 1, not 0"),
    ("mission-file", ["mission", "upload", "missing.plan"], 1, "gcs: mission upload:", "cannot read missing.plan"),
    ("param-file", ["param", "load", "missing.params"], 1, "gcs: param load:", "cannot read parameter file"),
]


@pytest.mark.parametrize("args, code, start, fragment", [row[1:] for row in BAD], ids=[row[0] for row in BAD])
def test_bad_invocation_is_one_line_and_its_exit_code(args, code, start, fragment, tmp_path):
    p = call_gcs(args, tmp_path)
    assert p.returncode == code, p.stderr
    assert "Traceback" not in p.stderr and p.stdout == ""
    message = [line for line in p.stderr.splitlines() if not line.startswith(("usage:", " "))]  # argparse's usage
    assert len(message) == 1, p.stderr
    assert message[0].startswith(start) and fragment in message[0], message[0]


def test_no_vehicle_answering_is_exit_3_in_one_line(tmp_path):
    p = call_gcs(["--url", silent_url(), "--timeout", "0.5", "arm"], tmp_path)
    assert p.returncode == 3, p.stderr
    assert p.stderr.startswith("gcs: arm: no answer from the vehicle: timed out after 0.5 s waiting for a heartbeat")
    assert len(p.stderr.splitlines()) == 1 and p.stdout == ""


def test_version(tmp_path):
    p = run_gcs(["--version"], tmp_path)
    assert p.returncode == 0 and p.stdout == f"gcs {cli_args.version()}\n" and p.stderr == ""


def _parsers(parser: argparse.ArgumentParser, name: str = "gcs"):
    """``(name, parser)`` of ``gcs`` and of every sub-command at every depth."""
    yield name, parser
    for action in parser._actions:
        if isinstance(action, argparse._SubParsersAction):
            for sub, child in action.choices.items():
                yield from _parsers(child, f"{name} {sub}")


def test_every_help_ends_with_the_exit_codes():
    parsers = dict(_parsers(build_parser()))
    assert {"gcs goto", "gcs watch", "gcs param set", "gcs mission upload", "gcs ugv drive"} <= set(parsers)
    missing = [
        name for name, p in parsers.items() if cli_args.EXIT_CODES_EPILOG not in " ".join(p.format_help().split())
    ]
    assert missing == []  # (the help wraps the line: compared with its spaces and line breaks as one space)
