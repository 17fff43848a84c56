"""Start and stop the simulator + flight-controller pair ("the stack").

Used by ``flight-demo``, the end-to-end tests and the benchmarks::

    with Stack(instance=3, speed="max") as stack:
        client = VehicleClient(stack.api_url, timeout_s=30, idle=stack.check_alive)
        ...

The simulator and the flight controller start together (the flight controller retries its connection
until the simulator listens); the stack is started once the simulator listens on its TCP port (4560 +
instance, :mod:`mavsim_core.ports`), checked through ``/proc/net/tcp``: a probe connection would hold its
accept up to the handshake timeout.  With ``MAVSIM_FORK_SERVER=1`` (or :func:`.fork_server.use_here`) both
are forked from a process that has imported them already (:mod:`.fork_server`).  Each
child's stdout and stderr go to ``<log_dir>/sitl.log`` and
``<log_dir>/autopilot.log`` (``log_dir`` is a fresh temp dir unless given); the
flight logs go there too (``--log-dir``: each flight's ``.tlog`` and ``.ulg`` from
the flight controller, ``.truth.npy`` from the simulator), unless ``flight_logs`` is False.
Children run in their own session so a Ctrl-C in the terminal reaches only
us; :meth:`Stack.stop` ends them (SIGTERM, then SIGKILL), always: on leaving
the ``with`` block, at interpreter exit, and (Linux) when this process dies.
"""

from __future__ import annotations

import atexit
import os
import signal
import subprocess
import sys
import tempfile
import time
from collections import deque
from pathlib import Path
from typing import Sequence

from mavsim_core import ports
from mavsim_core.cli_checks import in_use_hint

from . import fork_server, stack_args
from .parent_death import die_with_parent

PROJECT_ROOT = Path(__file__).resolve().parents[2]  # the checkout: gcs/launcher/stack.py -> ../../..


class StackError(RuntimeError):
    """A child process failed to start or died; the message carries its log tail."""


def _tcp_listening(port: int) -> bool | None:
    """True if some socket listens on TCP ``port`` (Linux /proc); None if it cannot be told."""
    found_table = False
    for table in ("/proc/net/tcp", "/proc/net/tcp6"):
        try:
            with open(table) as f:
                lines = f.readlines()[1:]
        except OSError:
            continue
        found_table = True
        for line in lines:
            fields = line.split()
            if len(fields) > 3 and fields[3] == "0A" and int(fields[1].rsplit(":", 1)[1], 16) == port:
                return True
    return False if found_table else None


def tail(path: Path, lines: int = 30) -> str:
    """The last ``lines`` lines of a text file ('' if it does not exist)."""
    try:
        with open(path, errors="replace") as f:
            return "".join(deque(f, maxlen=lines))
    except OSError:
        return ""


class Stack:
    """The ``sitl`` and ``autopilot`` processes of one instance, as a context manager.

    Parameters
    ----------
    instance: PX4's ``-i`` (:mod:`mavsim_core.ports`): system id 1+I, TCP 4560+I, API link to UDP
        14540+I, ground-station link to UDP 14550 (shared by every instance).
    gcs_port: where the flight controller sends its ground-station link; default
        ``ports.own_gcs_port(I)`` (14840+I), so stacks side by side (tests, benchmarks) each have their
        own; ``ports.GCS_PORT`` (14550) for QGroundControl, as ``flight-demo`` does.
    speed: simulation speed, ``"max"`` (or None) or a real-time factor (1 = real time).
    vehicle: vehicle name (``quad_x``) or a .toml file.
    extra_sitl_args, extra_autopilot_args: appended to each command line.
    Paths (``vehicle``, ``log_dir``, the path options in the extra arguments: :mod:`.stack_args`) are
    relative to the working directory when the Stack is made; the children get them absolute.
    home: ``"LAT,LON,ALT"`` for the simulator, or None for its default.
    seed: simulator random seed, or None for its default.
    log_dir: where the child logs and the flight logs go; a new temp dir if None (kept after stop).
    flight_logs: pass ``--log-dir log_dir`` to both children (tlog, ULog and truth logs);
        False: no flight logs at all (``autopilot --no-log``).
    start_timeout_s: wall seconds for the simulator to start listening.
    python: the interpreter for the children.
    sitl_module, autopilot_module: what ``python -m`` runs; may carry leading
        arguments, e.g. a module that does not exist to test start-up failures.
    """

    def __init__(
        self,
        instance: int = 0,
        speed: str | float | None = "max",
        vehicle: str = "quad_x",
        extra_sitl_args: Sequence[str] = (),
        extra_autopilot_args: Sequence[str] = (),
        *,
        home: str | None = None,
        seed: int | None = None,
        log_dir: str | Path | None = None,
        start_timeout_s: float = 60.0,
        python: str = sys.executable,
        sitl_module: str = "sitl",
        autopilot_module: str = "autopilot",
        flight_logs: bool = True,
        gcs_port: int | None = None,
    ) -> None:
        self.instance = int(instance)
        self._gcs_port = gcs_port
        self.speed = "max" if speed is None else str(speed)
        self.vehicle = stack_args.path_value("--vehicle", vehicle)  # the caller's working directory's
        self.extra_sitl_args = stack_args.absolute_paths(extra_sitl_args, stack_args.SITL_PATH_OPTIONS)
        self.extra_autopilot_args = stack_args.absolute_paths(extra_autopilot_args, stack_args.AUTOPILOT_PATH_OPTIONS)
        self.home = home
        self.seed = seed
        self.start_timeout_s = start_timeout_s
        self.python = python
        self.sitl_module = sitl_module.split()
        self.autopilot_module = autopilot_module.split()
        self.flight_logs = flight_logs
        self._log_dir_arg = Path(log_dir).resolve() if log_dir is not None else None  # the caller's cwd's
        self.log_dir: Path | None = None
        self.procs: dict[str, subprocess.Popen] = {}
        self._log_files: dict[str, object] = {}
        self.started_wall_s: float | None = None

    # ----------------------------------------------------------------- ports and urls

    @property
    def sitl_port(self) -> int:
        """TCP port the simulator listens on for the flight controller."""
        return ports.sim_tcp_port(self.instance)

    @property
    def gcs_port(self) -> int:
        """UDP port the flight controller sends ground-station telemetry to (QGroundControl)."""
        return self._gcs_port if self._gcs_port is not None else ports.own_gcs_port(self.instance)

    @property
    def api_port(self) -> int:
        """UDP port the flight controller sends API telemetry to (MAVSDK, this package's demo)."""
        return ports.api_port(self.instance)

    @property
    def sysid(self) -> int:
        """MAVLink system id of the flight controller (and of the simulator's component)."""
        return ports.system_id(self.instance)

    @property
    def gcs_url(self) -> str:
        return f"udpin:0.0.0.0:{self.gcs_port}"

    @property
    def api_url(self) -> str:
        return f"udpin:0.0.0.0:{self.api_port}"

    def log_path(self, name: str) -> Path:
        """Log file of a child (``"sitl"`` or ``"autopilot"``)."""
        if self.log_dir is None:
            raise StackError("stack not started")
        return self.log_dir / f"{name}.log"

    # ----------------------------------------------------------------- commands

    def sitl_command(self) -> list[str]:
        """The simulator's command line (:func:`.stack_args.sitl_command`)."""
        return stack_args.sitl_command(self)

    def autopilot_command(self) -> list[str]:
        """The flight controller's command line (:func:`.stack_args.autopilot_command`)."""
        return stack_args.autopilot_command(self)

    # ----------------------------------------------------------------- start / stop

    def __enter__(self) -> "Stack":
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    def start(self) -> "Stack":
        """Start the simulator and the flight controller together, and wait for the simulator's TCP port.

        The flight controller retries its connection until the simulator listens (``autopilot/mavlink/sim_link.py``),
        so its start-up (imports, parameters: about 0.4 CPU s) runs beside the simulator's instead of after it."""
        if self.procs:
            raise StackError("stack already started")
        for port, instance in self._sitl_ports():
            if _tcp_listening(port):
                raise StackError(f"TCP {port} is already in use: {in_use_hint(instance)}")
        if self._log_dir_arg is not None:
            try:
                self._log_dir_arg.mkdir(parents=True, exist_ok=True)
            except OSError as exc:
                reason = exc.strerror or exc
                raise StackError(f"cannot create the log directory {self._log_dir_arg}: {reason}") from None
            self.log_dir = self._log_dir_arg
        else:
            self.log_dir = Path(tempfile.mkdtemp(prefix=f"flight-stack-{self.instance}-"))
        self.started_wall_s = time.monotonic()
        atexit.register(self.stop)
        try:
            self._spawn("sitl", self.sitl_command())
            self._spawn_flight_controllers()
            self._wait_sitl_listening()
        except BaseException:
            self.stop()
            raise
        return self

    def _sitl_ports(self) -> list[tuple[int, int]]:
        """The simulator's TCP ports, each with its instance (a :class:`~.multi_stack.MultiStack` has several)."""
        return [(self.sitl_port, self.instance)]

    def _spawn_flight_controllers(self) -> None:
        self._spawn("autopilot", self.autopilot_command())

    def _spawn(self, name: str, cmd: list[str], log_mode: str = "w") -> None:
        env = dict(os.environ)
        env["PYTHONUNBUFFERED"] = "1"
        env["PYTHONPATH"] = os.pathsep.join(p for p in (str(PROJECT_ROOT), env.get("PYTHONPATH")) if p)
        log = open(self.log_path(name), log_mode)
        log.write("$ " + " ".join(cmd) + "\n")
        log.flush()
        self._log_files[name] = log
        if fork_server.enabled():  # MAVSIM_FORK_SERVER: forked from a process that has imported it all
            child = fork_server.shared(PROJECT_ROOT).spawn(cmd, PROJECT_ROOT, env, self.log_path(name))
            if child is not None:
                self.procs[name] = child  # type: ignore[assignment]  # (Popen's interface, as far as used here)
                return
        self.procs[name] = subprocess.Popen(
            cmd,
            cwd=PROJECT_ROOT,
            env=env,
            stdin=subprocess.DEVNULL,
            stdout=log,
            stderr=subprocess.STDOUT,
            start_new_session=True,
            preexec_fn=die_with_parent if sys.platform == "linux" else None,
        )

    def _wait_sitl_listening(self) -> None:
        proc = self.procs["sitl"]
        deadline = time.monotonic() + self.start_timeout_s
        while True:
            self.check_alive()
            states = [_tcp_listening(port) for port, _ in self._sitl_ports()]
            if None in states:  # no /proc: give the simulator a moment and hope the FC retries
                time.sleep(1.0)
                return
            if all(states):
                return
            if time.monotonic() > deadline:
                raise StackError(
                    f"the simulator did not listen on TCP {self.sitl_port} within "
                    f"{self.start_timeout_s:g} s\n{self._tail_block('sitl')}"
                )
            try:
                proc.wait(timeout=0.05)
            except subprocess.TimeoutExpired:
                pass

    def _terminate(self, proc: subprocess.Popen, timeout_s: float) -> None:
        """SIGTERM a running child, SIGKILL it if it has not ended within timeout_s."""
        self._terminate_all([proc], timeout_s)

    def _terminate_all(self, procs: list[subprocess.Popen], timeout_s: float) -> None:
        """SIGTERM every running child of ``procs`` at once, then SIGKILL each that has not ended within timeout_s."""
        running = [p for p in procs if p.poll() is None]
        for proc in running:
            self._signal(proc, signal.SIGTERM)
        for proc in running:
            try:
                proc.wait(timeout=timeout_s)
            except subprocess.TimeoutExpired:
                self._signal(proc, signal.SIGKILL)
                proc.wait(timeout=timeout_s)

    def stop(self, timeout_s: float = 5.0) -> dict[str, int | None]:
        """End the children (the flight controllers first, together); return their exit codes. Idempotent."""
        fcs = {name: p for name, p in self.procs.items() if name != "sitl"}
        self._terminate_all(list(fcs.values()), timeout_s)
        if "sitl" in self.procs:
            self._terminate(self.procs["sitl"], timeout_s)
        codes: dict[str, int | None] = {name: p.returncode for name, p in {**fcs, **self.procs}.items()}
        for log in self._log_files.values():
            log.close()
        self._log_files.clear()
        atexit.unregister(self.stop)
        return codes

    @staticmethod
    def _signal(proc: subprocess.Popen, sig: int) -> None:
        """Signal the child's own process group (it was started in a new session), else the child."""
        try:
            os.killpg(proc.pid, sig)
        except (ProcessLookupError, PermissionError, OSError):
            try:
                proc.send_signal(sig)
            except ProcessLookupError:
                pass

    # ----------------------------------------------------------------- health

    def exited(self) -> dict[str, int]:
        """Children that have exited, with their exit codes."""
        return {name: p.returncode for name, p in self.procs.items() if p.poll() is not None}

    def check_alive(self) -> None:
        """Raise :class:`StackError` with the log tail if a child has exited (usable as a client idle hook)."""
        dead = self.exited()
        if dead:
            name, code = next(iter(dead.items()))
            raise StackError(f"{name} exited early with code {code}\n{self._tail_block(name)}")

    def tail(self, name: str, lines: int = 30) -> str:
        """The last lines of a child's log."""
        return tail(self.log_path(name), lines)

    def _tail_block(self, name: str, lines: int = 30) -> str:
        path = self.log_path(name)
        return f"--- last lines of {path} ---\n{tail(path, lines).rstrip()}\n--- end of {name} log ---"

    def wait(self, poll_s: float = 0.5) -> None:
        """Block until a child exits (then raise StackError), or until KeyboardInterrupt."""
        while True:
            self.check_alive()
            for proc in self.procs.values():
                try:
                    proc.wait(timeout=poll_s / max(len(self.procs), 1))
                except subprocess.TimeoutExpired:
                    pass

    def restart_autopilot(self, timeout_s: float = 5.0) -> int | None:
        """Stop the flight controller (SIGTERM: it saves its state) and start it again; its old exit code.

        The simulator keeps running and waits for the new flight controller, as it
        would for a rebooting board.  The log goes on in the same file.
        """
        proc = self.procs.get("autopilot")
        if proc is None:
            raise StackError("stack not started")
        self._terminate(proc, timeout_s)
        self._log_files.pop("autopilot").close()
        self._spawn("autopilot", self.autopilot_command(), log_mode="a")
        return proc.returncode

    def kill_sitl(self, sig: int = signal.SIGKILL, timeout_s: float = 5.0) -> int | None:
        """Signal the simulator (default SIGKILL: a crash) and wait for it; its exit code.  The flight controller
        runs on and reconnects once :meth:`start_sitl` has started it again."""
        return self._kill("sitl", sig, timeout_s)

    def start_sitl(self) -> None:
        """Start the simulator again (after :meth:`kill_sitl`), same command line, same log; wait until it listens."""
        self._start_again("sitl", self.sitl_command())
        self._wait_sitl_listening()

    def kill_autopilot(self, sig: int = signal.SIGKILL, timeout_s: float = 5.0) -> int | None:
        """Signal the flight controller (default SIGKILL: a crash, nothing saved at exit) and wait; its exit code."""
        return self._kill("autopilot", sig, timeout_s)

    def start_autopilot(self) -> None:
        """Start the flight controller again (after :meth:`kill_autopilot`), same command line, same log."""
        self._start_again("autopilot", self.autopilot_command())

    def _kill(self, name: str, sig: int, timeout_s: float) -> int | None:
        if (proc := self.procs.get(name)) is None:
            raise StackError("stack not started")
        self._signal(proc, sig)
        proc.wait(timeout=timeout_s)
        log = self._log_files.pop(name, None)
        if log is not None:
            log.close()
        return proc.returncode

    def _start_again(self, name: str, cmd: list[str]) -> None:
        if (proc := self.procs.get(name)) is not None and proc.poll() is None:
            raise StackError(f"{name} is still running")
        self._spawn(name, cmd, log_mode="a")
