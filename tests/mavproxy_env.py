"""MAVProxy for the end-to-end tests, in a virtual environment of its own.

MAVProxy 1.8.75 requires opencv-python (with vtk and matplotlib) on Linux, and the project needs
opencv-python-headless: both install the same ``cv2`` package, so in one environment whichever is
installed last wins (pip sees two names, no conflict) and the GUI build, which needs libGL, can
replace the headless one.  MAVProxy is therefore not in the test extras: the test command makes a
virtual environment with ``pip install --no-deps`` of the packages MAVProxy really imports
(tests/mavproxy-requirements.txt, 10-20 s), once per machine, user and requirements: it lives in the user's
cache (``~/.cache/mavsim/mavproxy-<python>-<hash of the requirements>``, ``XDG_CACHE_HOME`` respected), so a
fresh clone reuses it.  ``tests/conftest.py`` starts making it in the background as the run starts
(:func:`prepare_in_background`), beside the unit tests; a test that needs it waits for it (a file lock,
which parallel test workers and concurrent runs share).
"""

from __future__ import annotations

import fcntl
import functools
import shutil
import subprocess
import sys
from pathlib import Path

REQUIREMENTS = Path(__file__).with_name("mavproxy-requirements.txt")
INSTALL_TIMEOUT_S = 900.0  # wall seconds for pip (a slow mirror); a safety net only


def venv_dir() -> Path:
    """Where the MAVProxy environment lives (see the module docstring)."""
    import hashlib
    import os

    cache = Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache")
    key = hashlib.sha256(REQUIREMENTS.read_bytes()).hexdigest()[:12]
    return cache / "mavsim" / f"mavproxy-py{sys.version_info[0]}.{sys.version_info[1]}-{key}"


def prepare_in_background() -> None:
    """Make the environment (if it is not there yet) in a background thread: the first test that needs it then
    finds it made, or waits for the rest.  A failure is left for that test to report."""
    import threading

    def make() -> None:
        try:
            mavproxy_command()
        except Exception:  # noqa: BLE001 - mavproxy_command raises it again in the test that needs it
            mavproxy_command.cache_clear()

    threading.Thread(target=make, name="mavproxy-venv", daemon=True).start()


def _make(root: Path) -> None:
    shutil.rmtree(root, ignore_errors=True)
    subprocess.run([sys.executable, "-m", "venv", str(root)], check=True, capture_output=True)
    pip = [str(root / "bin" / "python"), "-m", "pip", "install", "--disable-pip-version-check", "--no-deps"]
    done = subprocess.run([*pip, "-r", str(REQUIREMENTS)], capture_output=True, text=True, timeout=INSTALL_TIMEOUT_S)
    if done.returncode != 0:
        raise RuntimeError(f"could not install MAVProxy in {root}:\n{done.stdout}\n{done.stderr}")


@functools.cache
def mavproxy_command() -> tuple[str, ...]:
    """``(python, mavproxy.py)`` of the MAVProxy environment, made first if needed (RuntimeError if pip fails)."""
    root = venv_dir()
    root.parent.mkdir(parents=True, exist_ok=True)
    wanted = REQUIREMENTS.read_text()
    stamp = root / "requirements.txt"  # what was installed, written last
    with open(root.parent / f"{root.name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not (stamp.is_file() and stamp.read_text() == wanted):
            _make(root)
            stamp.write_text(wanted)
    return str(root / "bin" / "python"), str(root / "bin" / "mavproxy.py")
