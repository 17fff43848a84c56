"""The fork server's own process (:mod:`gcs.launcher.fork_server` starts it and has the protocol): import the
programs once, fork a child per request, report each child's end.

Signals: SIGTERM and SIGCHLD are held across each fork, so a child takes neither before it has its own handlers (a
SIGTERM that reached it earlier ran the server's and was lost); the server's SIGTERM ends its children first
(SIGTERM, then SIGKILL after STOP_TIMEOUT_S) and reports their ends as ever; so does the end of the process that
started it (looked for every PARENT_CHECK_S: the parent-death signal would follow the thread that started it).
"""

from __future__ import annotations

import json
import os
import select
import signal
import socket
import sys
import time
from typing import Any

from .fork_server import PRELOAD
from .parent_death import die_with_parent

HELD_SIGNALS = {signal.SIGTERM, signal.SIGCHLD}
PARENT_CHECK_S = 0.5  # how often the server looks for its client's process
STOP_TIMEOUT_S = 5.0  # the server's SIGTERM: its children's time to end on theirs, then SIGKILL


def serve(path: str) -> None:
    """Import PRELOAD, listen on ``path``, fork a child per request, report each child's end."""
    import importlib

    for name in PRELOAD:
        importlib.import_module(name)
    listener = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
    listener.bind(path)
    listener.listen(16)
    wake_r, wake_w = socket.socketpair()
    wake_w.setblocking(False)
    signal.set_wakeup_fd(wake_w.fileno())
    signal.signal(signal.SIGCHLD, lambda *_: None)  # (the wake-up fd does the work)
    conns: dict[int, socket.socket] = {}  # child pid -> its client's connection
    stopping = []
    parent = os.getppid()  # the client's process: when it has ended (this one is given to another), so does this
    signal.signal(signal.SIGTERM, lambda *_: stopping.append(True))
    sys.stdout.write("ready\n")
    sys.stdout.flush()
    while not stopping:
        try:
            readable = select.select([listener, wake_r], [], [], PARENT_CHECK_S)[0]
        except InterruptedError:
            readable = []
        if os.getppid() != parent:
            break
        if wake_r in readable:
            wake_r.recv(4096)
        _reap(conns)
        if listener in readable and not stopping:
            conn, _ = listener.accept()
            request = _read_request(conn)
            if request is None:
                conn.close()
                continue
            sys.stdout.flush()
            sys.stderr.flush()
            # SIGTERM and SIGCHLD held across the fork: one that reached the child before it had its own handlers
            # would run the server's (a SIGTERM ignored), so the child takes it only once they are the default.
            signal.pthread_sigmask(signal.SIG_BLOCK, HELD_SIGNALS)
            server_pid = os.getpid()
            pid = os.fork()
            if pid == 0:  # the child: never returns
                listener.close()
                wake_r.close()
                wake_w.close()
                for c in conns.values():
                    c.close()
                conn.close()
                _child(request, server_pid)
            signal.pthread_sigmask(signal.SIG_UNBLOCK, HELD_SIGNALS)
            conns[pid] = conn
            conn.sendall(f"pid {pid}\n".encode())
    for pid in conns:  # SIGTERM: the children first, each one's end reported as ever
        try:
            os.kill(pid, signal.SIGTERM)
        except ProcessLookupError:
            pass
    deadline = time.monotonic() + STOP_TIMEOUT_S
    while conns and time.monotonic() < deadline:
        _reap(conns)
        time.sleep(0.02)
    for pid in conns:
        os.kill(pid, signal.SIGKILL)
    _reap(conns, block=True)
    listener.close()


def _read_request(conn: socket.socket) -> dict[str, Any] | None:
    buf = b""
    while b"\n" not in buf:
        data = conn.recv(65536)
        if not data:
            return None
        buf += data
    try:
        return json.loads(buf.split(b"\n", 1)[0])
    except ValueError:
        return None


def _reap(conns: dict[int, socket.socket], block: bool = False) -> None:
    while conns:
        try:
            pid, status = os.waitpid(-1, 0 if block else os.WNOHANG)
        except ChildProcessError:
            return
        if pid == 0:
            return
        conn = conns.pop(pid, None)
        if conn is not None:
            code = -os.WTERMSIG(status) if os.WIFSIGNALED(status) else os.WEXITSTATUS(status)
            try:
                conn.sendall(f"exit {code}\n".encode())
            except OSError:
                pass
            conn.close()


def _child(request: dict[str, Any], server_pid: int) -> None:
    """In the forked child: become ``python -m MODULE ARGS`` with the request's directory, environment and log."""
    code: Any = 1
    try:
        for sig in (signal.SIGCHLD, signal.SIGTERM, signal.SIGINT):
            signal.signal(sig, signal.SIG_DFL)
        signal.set_wakeup_fd(-1)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, HELD_SIGNALS)  # (a SIGTERM sent meanwhile ends it here)
        os.setsid()
        die_with_parent()  # SIGTERM when the server ends
        if os.getppid() != server_pid:  # it ended before that was set
            os.kill(os.getpid(), signal.SIGTERM)
        os.chdir(request["cwd"])
        os.environ.clear()
        os.environ.update(request["env"])
        log = os.open(request["log"], os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
        null = os.open(os.devnull, os.O_RDONLY)
        os.dup2(null, 0)
        os.dup2(log, 1)
        os.dup2(log, 2)
        os.close(log)
        os.close(null)
        sys.stdout = open(1, "w", buffering=1, closefd=False)  # line-buffered, as PYTHONUNBUFFERED's stack logs
        sys.stderr = open(2, "w", buffering=1, closefd=False)
        module, *args = request["argv"]
        sys.argv = [module, *args]
        import runpy

        runpy.run_module(module, run_name="__main__", alter_sys=True)
        code = 0
    except SystemExit as exc:
        code = exc.code
    except BaseException:
        import traceback

        traceback.print_exc()
        code = 1
    finally:
        if code is None:
            code = 0
        elif not isinstance(code, int):
            print(code, file=sys.stderr)
            code = 1
        try:
            import atexit

            atexit._run_exitfuncs()
            sys.stdout.flush()
            sys.stderr.flush()
        finally:
            os._exit(code)
