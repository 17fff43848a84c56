"""A console script's ``main(argv)`` run in the test's own process, as the script would run it: its stdout, its
stderr and its exit status, like ``subprocess.run(..., capture_output=True, text=True)``.

The CLI error tests check dozens of bad invocations that all end before anything starts.  A process each cost the
suite about 0.3 CPU s apiece (Python's start and the imports, issue 33); here each is a call.  What the
console script adds around ``main`` (its entry point, the interpreter's own handling of an uncaught exception) is
still run for real by one subprocess per script in each test file (``--version``).

The call sees ``sys.argv[0]`` = the script's name (argparse's ``prog``), runs in ``cwd``, and gets back what it
may change in the process: the signal handlers, the root logger's handlers and level, ``os.environ``.  An
uncaught exception becomes what the interpreter would print, a ``Traceback`` on stderr and exit status 1.

``python tests/cli_in_process.py CWD '[["SCRIPT.py", "ARG", ...], ...]'`` runs Python scripts (a benchmark's
``--help``) one after the other in one fresh interpreter, each as ``python SCRIPT.py ARG...`` would (``__main__``,
its directory first on ``sys.path``), and prints their results as one JSON list (:func:`run_scripts`).
"""

from __future__ import annotations

import contextlib
import io
import json
import logging
import os
import runpy
import signal
import subprocess
import sys
import traceback
from pathlib import Path
from typing import Callable

SIGNALS = (signal.SIGINT, signal.SIGTERM, signal.SIGHUP)


def call_main(
    main: Callable[[list[str]], int | None], prog: str, argv: list[str], cwd: Path | str
) -> subprocess.CompletedProcess:
    """``main(argv)`` with ``prog`` as ``sys.argv[0]``, in ``cwd``: a ``subprocess.CompletedProcess`` of it."""
    return _call(lambda: main(argv), [prog, *argv], cwd)


def _call(run: Callable[[], int | None], argv: list[str], cwd: Path | str) -> subprocess.CompletedProcess:
    out, err = io.StringIO(), io.StringIO()
    handlers = {s: signal.getsignal(s) for s in SIGNALS}
    root = logging.getLogger()
    log_state = (list(root.handlers), root.level)
    environ, saved_argv, saved_path = dict(os.environ), sys.argv, list(sys.path)
    sys.argv = list(argv)
    try:
        with contextlib.chdir(cwd), contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
            try:
                code = run()
            except SystemExit as exc:
                code = exc.code
            except Exception:  # noqa: BLE001 - what the interpreter prints for an uncaught exception
                traceback.print_exc()
                code = 1
    finally:
        sys.argv, sys.path[:] = saved_argv, saved_path
        os.environ.clear()
        os.environ.update(environ)
        root.handlers[:], root.level = log_state
        for s, h in handlers.items():
            signal.signal(s, h)
    if code is None:
        code = 0
    elif not isinstance(code, int):  # sys.exit("message"): printed, status 1
        print(code, file=err)
        code = 1
    return subprocess.CompletedProcess(argv, code, out.getvalue(), err.getvalue())


def run_scripts(
    commands: list[list[str]], cwd: Path | str, timeout_s: float = 300
) -> list[subprocess.CompletedProcess]:
    """Each ``[script.py, arg...]`` of ``commands`` run in one fresh interpreter (see the module docstring)."""
    done = subprocess.run(
        [sys.executable, __file__, str(cwd), json.dumps(commands)],
        cwd=cwd,
        capture_output=True,
        text=True,
        timeout=timeout_s,
    )
    if done.returncode != 0:
        raise RuntimeError(f"the script runner failed (exit {done.returncode}):\n{done.stderr[-3000:]}")
    return [
        subprocess.CompletedProcess(c, r["returncode"], r["stdout"], r["stderr"])
        for c, r in zip(commands, json.loads(done.stdout))
    ]


def _run_script(command: list[str], cwd: str) -> dict:
    script = command[0]

    def run() -> None:
        sys.path.insert(0, str(Path(script).resolve().parent))
        runpy.run_path(script, run_name="__main__")

    done = _call(run, command, cwd)
    return {"returncode": done.returncode, "stdout": done.stdout, "stderr": done.stderr}


if __name__ == "__main__":
    results = [_run_script(command, sys.argv[1]) for command in json.loads(sys.argv[2])]
    sys.stdout.write(json.dumps(results))
