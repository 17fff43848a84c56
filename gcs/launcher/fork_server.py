"""A fork server for the stack's processes: ``python -m sitl`` and ``python -m autopilot`` without starting Python.

Every stack starts two Python processes, and each spends its first 0.4 CPU s importing (NumPy, pymavlink, MuJoCo,
its own modules); a precision landing's flight controller spends 0.6 s more in the middle of the landing, importing
filterpy and with it scipy.stats.  A landing campaign starts a stack per landing, the test suite sixty.  So one
process per client (the server, :func:`gcs.launcher.fork_serve.serve`) imports all of that once (``PRELOAD``)
and forks a child for each process a stack asks for; the child runs the module as ``python -m`` would
(``runpy``), with the stack's working directory, environment and log file, in a session of its own.  What a child
computes does not depend on how it started: it is the same code on the same inputs.

Opt-in: ``MAVSIM_FORK_SERVER=1`` in a process's environment, or :func:`use_here` in it, makes its
:class:`~gcs.launcher.stack.Stack` (and :class:`~gcs.launcher.multi_stack.MultiStack`) start their children
through one server, started with the first stack and ended with the process (the campaign's pool workers and the
test suite's workers call :func:`use_here`).  It pays where a process starts many stacks: the server's own start
costs about three stacks' imports.  Only the plain
``[sys.executable, "-m", "sitl" | "autopilot", ...]`` command lines are forked; any other (another interpreter, a
module with leading arguments) starts as a process of its own, as without the server.

The protocol, on a Unix stream socket: the client sends one JSON line (``argv``: the module and its arguments,
``cwd``, ``env``, ``log``: the file that takes stdout and stderr); the server answers ``pid N`` and, when the child
has ended, ``exit CODE`` (as ``subprocess.Popen.returncode``: the exit status, or minus the signal that ended it),
then closes that connection.  :class:`ForkedChild` is the client's end, with the part of ``Popen``'s interface the
stack uses.  Cleanup: the server ends (its children first) when the process that started it has ended, whichever of its
threads started it, and every child gets SIGTERM when the server ends (Linux's parent-death signal).
"""

from __future__ import annotations

import json
import os
import select
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
from pathlib import Path
from typing import Mapping, Sequence

ENV = "MAVSIM_FORK_SERVER"
MODULES = ("sitl", "autopilot")  # what the server runs; anything else starts as its own process
# Imported once by the server: what the two processes import before and during a flight (a module that is not
# here is imported by the child, as it would be anyway).  Not the GL context: the camera's renderer makes its own.
# (Not the two ``__main__`` modules: ``runpy`` runs those afresh in the child, and warns if they were imported.)
PRELOAD = (
    "numpy",
    "pymavlink.dialects.v20.common",
    "mavsim_core.cli_args",
    "mavsim_core.cli_checks",
    "params.vehicle_arg",
    "params.vehicle",
    "sitl.scenario",
    "sitl.sim_params",
    "sitl.sim_settings",
    "sitl.multicopter",
    "sitl.world_lockstep",
    "sitl.lockstep",
    "sitl.simulation",
    "sitl.companion",
    "sitl.camera_setup",
    "sitl.deck_render",
    "vision.detector",
    "autopilot.param_storage",
    "autopilot.plan_storage",
    "autopilot.system_id",
    "autopilot.flight_recorder",
    "autopilot.flight_controller",
    "autopilot.lockstep_loop",
    "autopilot.link_setup",
    "autopilot.mavlink.link",
    "autopilot.mavlink.sim_link",
    "autopilot.mavlink.vehicle_interface",
    "autopilot.param_catalogue",
    "autopilot.mavlink.component_metadata",
    "autopilot.mavlink.file_services",
    "autopilot.mavlink.follow_target_input",
    "autopilot.mavlink.gimbal_manager",
    "autopilot.mavlink.log_service",
    "autopilot.mavlink.payload_link",
    "autopilot.mavlink.signing",
    "autopilot.signing_storage",
    "sitl.ugv_broadcast",
    "pygeomag",  # (both: the magnetic field model)
    "filterpy.kalman",
)
START_TIMEOUT_S = 120.0


_here = False  # :func:`use_here`


def use_here() -> None:
    """This process's stacks use the fork server, whatever its environment says (and its child processes are not
    told to: a command line that starts one stack would pay a server's imports for one fork)."""
    global _here
    _here = True


def enabled(environ: Mapping[str, str] = os.environ) -> bool:
    """True if ``MAVSIM_FORK_SERVER`` asks for it (``1``, ``yes``, ``true``, ``on``), or :func:`use_here` was called
    and the variable does not refuse it (``0``, ``no``, ``false``, ``off``: every stack starts its own processes)."""
    value = environ.get(ENV, "").strip().lower()
    return value in ("1", "yes", "true", "on") or (_here and value not in ("0", "no", "false", "off"))


class ForkedChild:
    """A child of the fork server, as much of ``subprocess.Popen`` as the stack uses: ``pid``, ``returncode``,
    ``poll``, ``wait``, ``send_signal``, ``terminate``, ``kill``."""

    def __init__(self, conn: socket.socket, pid: int, args: Sequence[str]) -> None:
        self._conn, self.pid, self.args = conn, pid, list(args)
        self.returncode: int | None = None
        self._buf = b""

    def _read(self, timeout_s: float | None) -> None:
        """Read the server's "exit CODE" line if it comes within ``timeout_s`` (None: wait for it)."""
        deadline = None if timeout_s is None else time.monotonic() + timeout_s
        while self.returncode is None:
            left = None if deadline is None else max(0.0, deadline - time.monotonic())
            if not select.select([self._conn], [], [], left)[0]:
                return
            data = self._conn.recv(4096)
            self._buf += data
            if b"\n" in self._buf:
                line = self._buf.split(b"\n", 1)[0].decode()
                self.returncode = int(line.split()[1]) if line.startswith("exit ") else -signal.SIGKILL
            elif not data:  # the server went away without a word: the child went with it (its parent-death signal)
                self.returncode = -signal.SIGTERM
        self._conn.close()

    def poll(self) -> int | None:
        self._read(0.0)
        return self.returncode

    def wait(self, timeout: float | None = None) -> int:
        self._read(timeout)
        if self.returncode is None:
            raise subprocess.TimeoutExpired(self.args, timeout or 0.0)
        return self.returncode

    def send_signal(self, sig: int) -> None:
        if self.poll() is None:
            try:
                os.kill(self.pid, sig)
            except ProcessLookupError:
                pass

    def terminate(self) -> None:
        self.send_signal(signal.SIGTERM)

    def kill(self) -> None:
        self.send_signal(signal.SIGKILL)


class ForkServer:
    """The client's handle on a running server (:func:`shared` gives the process's one)."""

    def __init__(self, python: str = sys.executable, root: Path | None = None) -> None:
        self.python = python
        self._dir = tempfile.mkdtemp(prefix="mavsim-fork-")
        self.path = os.path.join(self._dir, "server.sock")
        env = dict(os.environ)
        if root is not None:
            env["PYTHONPATH"] = os.pathsep.join(p for p in (str(root), env.get("PYTHONPATH")) if p)
        self.proc = subprocess.Popen(
            [python, "-c", "import sys; from gcs.launcher.fork_serve import serve; serve(sys.argv[1])", self.path],
            # (no parent-death signal: Linux sends it when the *thread* that started the server ends, and a test
            # flies stacks from threads; the server watches its parent process instead, gcs/launcher/fork_serve.py)
            cwd=root,
            env=env,
            stdin=subprocess.DEVNULL,
            stdout=subprocess.PIPE,
            start_new_session=True,
        )
        assert self.proc.stdout is not None
        ready = select.select([self.proc.stdout], [], [], START_TIMEOUT_S)[0]
        line = self.proc.stdout.readline() if ready else b""
        if line.strip() != b"ready":
            self.close()
            raise RuntimeError(f"the fork server did not start (exit {self.proc.poll()}): {line!r}")

    def spawn(self, cmd: Sequence[str], cwd: str | Path, env: Mapping[str, str], log: str | Path) -> ForkedChild | None:
        """A child running ``cmd`` (``[python, "-m", MODULE, args...]``), or None if the server cannot run it."""
        if len(cmd) < 3 or cmd[0] != self.python or cmd[1] != "-m" or cmd[2] not in MODULES:
            return None
        if self.proc.poll() is not None:
            return None
        conn = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        conn.connect(self.path)
        request = {"argv": list(cmd[2:]), "cwd": str(cwd), "env": dict(env), "log": str(log)}
        conn.sendall(json.dumps(request).encode() + b"\n")
        buf = b""
        while b"\n" not in buf:
            data = conn.recv(4096)
            if not data:
                conn.close()
                return None
            buf += data
        line, rest = buf.split(b"\n", 1)
        child = ForkedChild(conn, int(line.split()[1]), cmd)
        child._buf = rest
        return child

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.terminate()
            try:
                self.proc.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        if self.proc.stdout is not None:
            self.proc.stdout.close()
        for p in (self.path, self._dir):
            try:
                os.unlink(p) if p == self.path else os.rmdir(p)
            except OSError:
                pass


_shared: ForkServer | None = None
_shared_lock = threading.Lock()


def current() -> ForkServer | None:
    """This process's server, if one has been started (:func:`shared`)."""
    return _shared


def shared(root: Path) -> ForkServer:
    """This process's server (started on first use, closed at exit)."""
    global _shared
    with _shared_lock:
        if _shared is None or _shared.proc.poll() is not None:
            import atexit

            _shared = ForkServer(root=root)
            atexit.register(_shared.close)
        return _shared
