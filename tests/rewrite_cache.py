"""Pytest's rewritten test files, made once by the run's controller before its workers collect them.

Pytest rewrites the ``assert`` statements of every test file it imports (an AST pass and a compile: about
5 CPU s for this suite's files, against 2 s for the rest of a collection) and keeps the result beside the
file (``tests/__pycache__/*.pytest-9.2.0.pyc``, checked by the source's hash) unless bytecode is not to be
written, as where ``PYTHONDONTWRITEBYTECODE`` is set (this machine's CI).  Each xdist worker collects every
file, so each worker rewrote them all, at the same time, before the first test ran: 11 wall s of a run's
start on two cores, 15 CPU s.  :func:`write_for_workers`, called by the controller before the workers
start, writes the cache once (two processes, half the files each); the workers only read it (pytest reads
a cached file whatever ``PYTHONDONTWRITEBYTECODE`` says).  A file changed since is rewritten by whoever
imports it, as before.

It uses pytest's own rewriting functions (private, so pytest is pinned in pyproject.toml); if they are not
there, or anything fails, it does nothing and the workers rewrite as they always did.
"""

from __future__ import annotations

import os
from pathlib import Path


def _write(config, files: list[Path]) -> None:
    from _pytest.assertion import rewrite
    from _pytest.assertion.rewrite import assertstate_key

    state = config.stash[assertstate_key]
    for fn in files:
        pyc = rewrite.get_cache_dir(fn) / (fn.name[:-3] + rewrite.PYC_TAIL)
        if rewrite._read_pyc(fn, pyc) is not None:
            continue  # cached from an earlier run, and the source has not changed
        source_hash, code = rewrite._rewrite_test(fn, config)
        if rewrite.try_makedirs(pyc.parent):
            rewrite._write_pyc(state, code, source_hash, pyc)


def _test_files(config) -> list[Path]:
    """The run's test files: those named on the command line, or every ``test_*.py`` under the directories
    named (``testpaths`` when none is), and this directory's ``conftest.py``."""
    here = Path(__file__).parent
    files = [here / "conftest.py"]
    for arg in config.args or [str(here)]:
        path = Path(config.invocation_params.dir, arg.split("::", 1)[0])
        if path.is_dir():
            files += sorted(path.rglob("test_*.py"))
        elif path.suffix == ".py" and path.is_file():
            files.append(path)
    return files


def write_for_workers(config) -> None:
    """Rewrite the run's test files (:func:`_test_files`) into pytest's cache: half in a forked child, half
    here.  Only for a run with xdist workers (a run without them rewrites each file once anyway); never raises.
    Call it before this process starts a thread (the child of a fork made beside a running thread can block for
    good on a lock that thread held)."""
    if getattr(config.option, "numprocesses", None) in (None, 0) or config.getoption("assertmode") != "rewrite":
        return
    try:
        files = _test_files(config)
        pid = os.fork()
        if pid == 0:  # the child: the second half, then out without pytest's exit handlers
            try:
                _write(config, files[1::2])
            finally:
                os._exit(0)
        _write(config, files[0::2])
        os.waitpid(pid, 0)
    except Exception:  # noqa: BLE001 - a speed-up only: the workers rewrite what is not cached
        pass
