"""One run of a campaign, in the worker process: lease an instance, fly, classify, retry, return a flat row.

A run is its own simulator + flight controller (:class:`gcs.launcher.Stack`, ``--speed max``) on an
instance leased from :mod:`gcs.launcher.instance_pool` (so it never collides with the tests, another
campaign or a person's stack), flown by its kind (:meth:`~campaign.kinds.Kind.fly`).

Status of a run:

- ``ok``: the flight succeeded;
- ``flight_failed``: the flight failed (refused, target lost, missed the deck, the time limit hit
  after arming): a result, never retried;
- ``infra_failed``: the machinery failed every attempt (a process died or would not start, a port was
  taken, no free instance, a timeout before the vehicle armed): re-run up to ``retries`` times.

The time limit is wall seconds per attempt, a safety net checked on every receive cycle of the
client (the stack is stopped when it hits).
"""

from __future__ import annotations

import math
import socket
import tempfile
import time
from dataclasses import dataclass, field
from functools import partial
from pathlib import Path
from typing import Any

from gcs.client import VehicleClient
from gcs.errors import CommandRefused, GcsError
from gcs.launcher import Stack, StackError
from gcs.launcher.instance_pool import lease
from gcs.launcher.multi_stack import MultiStack

from .kinds import get_kind
from .plan import Run

OK, FLIGHT_FAILED, INFRA_FAILED = "ok", "flight_failed", "infra_failed"
RETRY_PAUSE_S = 1.0


class TimeLimit(Exception):
    """The run's wall-clock limit passed."""


class InfraError(Exception):
    """Raised by a kind for trouble of the machinery, not of the flight (retried)."""


@dataclass(frozen=True)
class Settings:
    """What every run of a campaign shares (picklable: it travels to pool workers and Ray tasks)."""

    kind: str
    campaign: str  # name:digest, written in every row
    time_limit_s: float = 600.0
    retries: int = 2
    record: tuple[str, ...] = ()
    fc_params: dict[str, float] = field(default_factory=dict)
    sim_params: dict[str, float] = field(default_factory=dict)
    instances: tuple[int, int] = (30, 99)  # leased from low..high inclusive
    log_dir: str | None = None  # keep each run's logs in log_dir/<run_id>; None: none kept


@dataclass
class RunContext:
    """One attempt: its instance, its deadline, whether the flight started (the vehicle armed)."""

    settings: Settings
    instance: int
    deadline: float  # time.monotonic() seconds
    work_dir: Path
    started: bool = False
    stack_: Stack | None = None
    client_: VehicleClient | None = None

    def stack(self, vehicle: str, seed: int, sitl_args: list[str], count: int = 1) -> Stack:
        """The run's stack (not started): max speed, the campaign's flight-controller parameters; ``count`` > 1:
        that many vehicles in one world (:class:`~gcs.launcher.multi_stack.MultiStack`, instances from the run's
        on: the kind holds the others)."""
        fc = []
        if self.settings.fc_params:  # MAVProxy's "NAME VALUE" format, read by autopilot --params
            path = self.work_dir / "fc.params"
            path.write_text("".join(f"{k} {v:g}\n" for k, v in self.settings.fc_params.items()))
            fc = ["--params", str(path)]
        keep = self.settings.log_dir is not None
        make = Stack if count == 1 else partial(MultiStack, count=count)
        self.stack_ = make(
            instance=self.instance,
            speed="max",
            vehicle=vehicle,
            seed=seed,
            extra_sitl_args=sitl_args,
            extra_autopilot_args=fc,
            log_dir=self.work_dir / "logs",
            flight_logs=keep,
        )
        return self.stack_

    def client(self, timeout_s: float = 120.0) -> VehicleClient:
        """A client on the started stack whose waits end when a child dies or the time limit passes."""
        assert self.stack_ is not None, "stack() first"
        self.client_ = VehicleClient(self.stack_.api_url, timeout_s=timeout_s, idle=self._idle)
        return self.client_

    def client_of(self, k: int, timeout_s: float = 120.0) -> VehicleClient:
        """A client of vehicle ``k`` of a started MultiStack (the caller closes it), waits as :meth:`client`'s."""
        assert isinstance(self.stack_, MultiStack), "stack(count=N) first"
        return VehicleClient(self.stack_.api_url_of(k), timeout_s=timeout_s, idle=self._idle)

    def _idle(self) -> None:
        assert self.stack_ is not None
        self.stack_.check_alive()
        if not self.started and self.client_ is not None and self.client_.armed():
            self.started = True
        if time.monotonic() > self.deadline:
            raise TimeLimit(f"time limit of {self.settings.time_limit_s:g} s")


def classify(exc: BaseException, started: bool) -> str:
    """The status of an attempt that raised ``exc`` (see the module docstring)."""
    if isinstance(exc, CommandRefused):
        return FLIGHT_FAILED
    if isinstance(exc, (TimeLimit, GcsError)):
        return FLIGHT_FAILED if started else INFRA_FAILED
    return INFRA_FAILED  # StackError, OSError, InfraError, no free instance, anything unforeseen


def attempt(run: Run, settings: Settings) -> dict[str, Any]:
    """Fly ``run`` once: the kind's figures plus ``status``, ``reason`` and ``instance``."""
    kind = get_kind(settings.kind)
    out: dict[str, Any] = {"instance": -1}
    ctx: RunContext | None = None
    try:
        with tempfile.TemporaryDirectory(prefix=f"campaign-{run.run_id}-") as tmp:
            work = Path(settings.log_dir) / run.run_id if settings.log_dir else Path(tmp)
            work.mkdir(parents=True, exist_ok=True)
            with lease(range(settings.instances[0], settings.instances[1] + 1)) as held:
                ctx = RunContext(settings, held.number, time.monotonic() + settings.time_limit_s, work)
                out["instance"] = held.number
                try:
                    figures = kind.fly(run, ctx)
                finally:
                    if ctx.client_ is not None:
                        ctx.client_.close()
                    if ctx.stack_ is not None:
                        ctx.stack_.stop()
    except Exception as exc:  # noqa: BLE001 - the run's outcome, recorded
        status = classify(exc, ctx is not None and ctx.started)
        first = str(exc).strip().splitlines()[0] if str(exc).strip() else ""
        out.update(status=status, reason=f"{type(exc).__name__}: {first}"[:200])
        return out
    out.update(figures)
    out.setdefault("status", OK)
    out.setdefault("reason", "")
    return out


def execute(run: Run, settings: Settings) -> dict[str, Any]:
    """Fly ``run`` with up to ``settings.retries`` re-runs after infrastructure failures; its flat row."""
    for n in range(1, settings.retries + 2):
        result = attempt(run, settings)
        if result["status"] != INFRA_FAILED:
            break
        if n <= settings.retries:
            time.sleep(RETRY_PAUSE_S)
    return row(run, settings, result, n)


def row(run: Run, settings: Settings, result: dict[str, Any], attempts: int) -> dict[str, Any]:
    """The results row of ``run`` (the columns of :func:`campaign.results.columns`)."""
    out: dict[str, Any] = {"run_id": run.run_id, "cell": run.cell, "index": run.index, "label": run.label}
    out.update(run.axes)
    out.update(run.draws)
    out.update(status=result["status"], reason=result["reason"], attempts=attempts)
    out.update({k: result.get(k, math.nan) for k in settings.record})
    out.update(instance=result.get("instance", -1), host=result.get("host", socket.gethostname()))
    out["campaign"] = settings.campaign
    return out


def lost_row(run: Run, settings: Settings, exc: BaseException) -> dict[str, Any]:
    """The row of a run whose worker itself failed (a crashed pool process, a lost Ray node)."""
    first = (str(exc).strip().splitlines() or [""])[0]
    return row(run, settings, {"status": INFRA_FAILED, "reason": f"{type(exc).__name__}: {first}"[:200]}, 0)


__all__ = ["FLIGHT_FAILED", "INFRA_FAILED", "OK", "RunContext", "Settings", "StackError", "execute", "lost_row"]
