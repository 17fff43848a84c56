"""Other ground stations for tests/test_e2e_params.py: MAVSDK's Param plugin and MAVProxy through its stdin.

Both talk *to* the flight controller's own sockets (``udpout``), so they bind no fixed port.
Wall-clock values are only "give up waiting" timeouts.
"""

from __future__ import annotations

import queue
import re
import subprocess
import threading
import time
from pathlib import Path

from mavproxy_env import mavproxy_command  # tests/mavproxy_env.py: MAVProxy in a virtual environment of its own

ROOT = Path(__file__).resolve().parent.parent
WAIT_S = 30.0  # wall seconds before giving up on one exchange (a busy 2-core machine)


async def mavsdk_params(port: int) -> dict:
    from mavsdk.asyncio.plugins.param import ParamAsync
    from mavsdk_session import ground_station

    seen = {}
    async with ground_station() as sdk:  # tests/mavsdk_session.py: plugins released first
        await sdk.add_any_connection(f"udpout://127.0.0.1:{port}")
        system = await sdk.first_autopilot(timeout_s=WAIT_S)
        assert system is not None, "MAVSDK found no autopilot"
        param = ParamAsync(system)
        seen["int_before"] = await param.get_param_int("SYS_AUTOSTART")
        await param.set_param_int("SYS_AUTOSTART", 4005)
        seen["int_after"] = await param.get_param_int("SYS_AUTOSTART")
        seen["float_before"] = before = await param.get_param_float("MPC_XY_P")
        await param.set_param_float("MPC_XY_P", 1.15)
        seen["float_after"] = await param.get_param_float("MPC_XY_P")
        await param.set_param_int("SYS_AUTOSTART", 4001)
        await param.set_param_float("MPC_XY_P", before)
    return seen


class MavproxySession:
    """MAVProxy driven through its stdin, its output read line by line (``modules``: its --default-modules,
    None for MAVProxy's own default set; ``started``: time.monotonic() when the process was started)."""

    def __init__(self, master: str, modules: str | None = "param") -> None:
        command = [*mavproxy_command(), "--master", master, "--no-state"]
        self.started = time.monotonic()
        self.proc = subprocess.Popen(
            command + ([f"--default-modules={modules}"] if modules is not None else []),
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.STDOUT,
            text=True,
            bufsize=1,
            cwd=ROOT,
        )
        self.lines: queue.Queue[str] = queue.Queue()
        self.seen: list[str] = []
        threading.Thread(target=self._read, daemon=True).start()

    def _read(self) -> None:
        for line in self.proc.stdout:
            self.lines.put(line)

    def send(self, command: str) -> None:
        self.proc.stdin.write(command + "\n")
        self.proc.stdin.flush()

    def expect(self, pattern: str, timeout_s: float = WAIT_S) -> re.Match:
        deadline = time.monotonic() + timeout_s
        while True:
            try:
                line = self.lines.get(timeout=max(deadline - time.monotonic(), 0.01))
            except queue.Empty:
                raise AssertionError(f"MAVProxy never printed {pattern!r}; output:\n{''.join(self.seen)}") from None
            self.seen.append(line)
            match = re.search(pattern, line)
            if match:
                return match

    def close(self) -> None:
        """End MAVProxy (its own "exit" takes seconds; it keeps no state with --no-state)."""
        self.proc.terminate()
        try:
            self.proc.wait(timeout=5)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        self.proc.stdin.close()
