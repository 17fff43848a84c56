"""What a failed end-to-end test prints, so a failure in CI can be read without re-running it.

:func:`install` (called once per test process by ``tests/conftest.py``) records every :class:`gcs.launcher.Stack`
started and every :class:`gcs.connection.Connection` opened in the process, each link keeping its last
:data:`LAST_MESSAGES` messages from the vehicle with the wall time they arrived.  When an e2e test fails (in its
set-up, its call or its tear-down), :func:`sections` gives the report's extra sections: for each stack of the
test module, the tail of each child's log (``sitl.log``, ``autopilot.log``: what the simulator and the flight
controller printed, their tracebacks), and for each link the last messages it received, newest last.

Nothing here changes what a test does: the stacks and links are the real ones, only watched.
"""

from __future__ import annotations

import os
import time
import weakref
from collections import deque

LOG_LINES = 40  # lines of each child's log
LAST_MESSAGES = 25  # messages of each link
_QUIET_TYPES = ("HEARTBEAT", "SYSTEM_TIME", "TIMESYNC")  # listed once each (the latest), not in the tail

_stacks: list[weakref.ref] = []
_links: list[weakref.ref] = []
_installed = False
_module: str | None = None  # the test module running now (:func:`enter_module`)


def install() -> None:
    """Wrap ``Stack.start`` and ``Connection.__init__`` (in this test process) to record what they make."""
    global _installed
    if _installed:
        return
    _installed = True
    from gcs.connection import Connection
    from gcs.launcher.stack import Stack

    start, init = Stack.start, Connection.__init__

    def recording_start(self, *args, **kwargs):
        _stacks.append(weakref.ref(self))
        return start(self, *args, **kwargs)

    def recording_init(self, *args, **kwargs):
        self._diag_last = deque(maxlen=LAST_MESSAGES)
        self._diag_quiet = {}
        init(self, *args, **kwargs)
        _links.append(weakref.ref(self))
        self.add_listener(lambda msg, link=weakref.ref(self): _keep(link, msg))

    Stack.start = recording_start  # type: ignore[method-assign]
    Connection.__init__ = recording_init  # type: ignore[method-assign]


def _keep(link: weakref.ref, msg) -> None:
    conn = link()
    if conn is None:
        return
    if msg.get_type() in _QUIET_TYPES:
        conn._diag_quiet[msg.get_type()] = (time.monotonic(), msg)
    else:
        conn._diag_last.append((time.monotonic(), msg))


def enter_module(name: str) -> None:
    """A test of module ``name`` starts: what earlier modules made is forgotten (their fixtures are torn down)."""
    global _module
    if name != _module:
        _module = name
        _stacks.clear()
        _links.clear()


def keep(nodeid: str, when: str, sections: list[tuple[str, str]]) -> None:
    """Append a failed test's sections to the file ``E2E_DIAGNOSTICS`` names, if set (benchmarks/flake_hunt.py
    sets one per run: its JUnit files hold only the assertion, not these sections)."""
    path = os.environ.get("E2E_DIAGNOSTICS")
    if not path:
        return
    with open(path, "a", encoding="utf-8") as f:
        f.write(f"===== {nodeid} ({when})\n")
        for title, text in sections:
            f.write(f"----- {title}\n{text}\n")


def sections() -> list[tuple[str, str]]:
    """(title, text) sections for a failed test's report: the log tails and the last messages."""
    from gcs.launcher.stack import tail

    out: list[tuple[str, str]] = []
    for ref in _stacks:
        stack = ref()
        if stack is None or stack.log_dir is None:
            continue
        for name, proc in stack.procs.items():
            state = "running" if proc.poll() is None else f"exited {proc.returncode}"
            path = stack.log_dir / f"{name}.log"
            out.append((f"instance {stack.instance} {name} ({state}): last lines of {path}", tail(path, LOG_LINES)))
    now = time.monotonic()
    for ref in _links:
        conn = ref()
        if conn is None or not hasattr(conn, "_diag_last"):
            continue
        lines = [f"{now - t:6.2f} s ago  {msg}" for t, msg in sorted(conn._diag_quiet.values(), key=lambda x: x[0])]
        lines += [f"{now - t:6.2f} s ago  {msg}" for t, msg in conn._diag_last]
        if lines:
            sim = conn.sim_time_s()
            title = f"link {conn.url} (vehicle time {sim if sim is None else f'{sim:.2f} s'}): last messages"
            out.append((title, "\n".join(lines)))
    return out
