"""``flight-demo --count N``: N vehicles in one simulated world take off, hold and land on their own pads.

:class:`~.multi_stack.MultiStack` starts ``sitl --count N`` and N flight controllers (instances I..I+N-1);
one :class:`~gcs.client.VehicleClient` per vehicle listens on its API link (UDP 14540+I+k).  When all are
ready to arm, each is armed and takes off to its own height (``--alt`` - 1 m for the first, each next one
1 m higher: they never meet), they hold ``--hold`` simulated seconds together, then land one after another,
each back on its own start spot (its pad: the vehicles start 3 m apart along East).  Each vehicle's
landing error is measured on the simulator's ground truth (UDP 14740+I+k: NED from its own start spot).
Durations are simulated seconds (one world, one clock); timeouts are wall seconds.
"""

from __future__ import annotations

import argparse
import math
import time
from dataclasses import dataclass, field, replace
from functools import partial
from typing import Callable

from ..client import VehicleClient
from ..errors import GcsTimeout
from ..sim_client import SimClient
from .multi_stack import MultiStack


@dataclass
class VehicleRun:
    """One vehicle of the demo: its client, its truth and what was measured."""

    k: int
    sysid: int
    client: VehicleClient
    truth: SimClient
    alt_m: float
    reached_m: float | None = None
    hold_drift_m: float = 0.0
    landing_error_m: float | None = None
    landed_at_s: float | None = None
    notes: list[str] = field(default_factory=list)


def altitudes_m(base_m: float, count: int) -> list[float]:
    """Each vehicle's take-off height: ``base_m`` - 1 m (at least 1 m) for the first, 1 m more for each next."""
    low = max(1.0, base_m - 1.0)
    return [low + k for k in range(count)]


class MultiDemo:
    """The scripted flight of every vehicle of a started :class:`MultiStack`; each step prints a progress line.

    :meth:`fly` opens a client and a truth listener per vehicle, flies, prints the summary; :meth:`close`
    closes them (always).  ``step`` names what it is doing (the demo's failure line).
    """

    def __init__(self, stack: MultiStack, args: argparse.Namespace, on_statustext=None) -> None:
        self.stack, self.args, self.on_statustext = stack, args, on_statustext
        self.runs: list[VehicleRun] = []
        self._truths: list[SimClient] = []
        self.step = "connect"

    def open(self) -> None:
        """A truth listener and a client per vehicle (waits for each one's HEARTBEAT)."""
        a, stack = self.args, self.stack
        for k, alt_m in enumerate(altitudes_m(a.alt, stack.count)):
            self._truths.append(SimClient(stack.truth_port_of(k)))
            said = partial(self._statustext, k)
            url = stack.api_url_of(k)
            client = VehicleClient(url, timeout_s=a.ready_timeout, idle=stack.check_alive, on_statustext=said)
            self.runs.append(VehicleRun(k, stack.sysid_of(k), client, self._truths[-1], alt_m))

    def _statustext(self, k: int, st) -> None:
        """A vehicle's STATUSTEXT, stamped with vehicle time and saying which vehicle (the demo's callback)."""
        if self.on_statustext is not None:
            self.on_statustext(replace(st, text=f"[vehicle {k}] {st.text}"))

    def close(self) -> None:
        for r in self.runs:
            r.client.close()
        for truth in self._truths:
            truth.close()

    def fly(self, wall_start: float) -> None:
        """Clients, the flight, the summary (raises GcsError, StackError as the single demo)."""
        self.open()
        first = self.runs[0].client
        self.wait_all(lambda: first.sim_time_s() is not None, self.args.step_timeout, "vehicle time")
        wall0, sim0 = time.monotonic(), first.sim_time_s()
        self.say(f"connected to {len(self.runs)} vehicles (system ids {', '.join(str(r.sysid) for r in self.runs)})")
        self.run()
        wall_flight, sim_flight = time.monotonic() - wall0, first.sim_time_s() - sim0
        print(self.summary(time.monotonic() - wall_start, wall_flight, sim_flight))

    def say(self, text: str, run: VehicleRun | None = None) -> None:
        t = self.runs[0].client.sim_time_s()
        stamp = f"{t:8.2f}" if t is not None else "       ?"
        who = f"vehicle {run.k} (sysid {run.sysid}): " if run is not None else ""
        print(f"[sim {stamp} s] {who}{text}", flush=True)

    def wait_all(self, predicate: Callable[[], object], timeout_s: float, what: str) -> None:
        """Pump every client until ``predicate()`` holds; GcsTimeout after ``timeout_s`` wall seconds."""
        deadline = time.monotonic() + timeout_s
        while not predicate():
            self.stack.check_alive()
            if time.monotonic() > deadline:
                raise GcsTimeout(f"timed out after {timeout_s:g} s waiting for {what}")
            for run in self.runs:
                run.client.pump(0.01)

    def run(self) -> None:
        a, runs = self.args, self.runs
        self.step = "wait until every vehicle is ready to arm"
        self.say(f"waiting for the pre-arm checks of {len(runs)} vehicles")
        self.wait_all(lambda: all(r.client.prearm_ok() and r.client.home() for r in runs), a.ready_timeout, "ready")
        self.step = "arm and take off"
        for r in runs:
            c = r.client
            c.arm(timeout_s=10).check()
            c.takeoff(c.wait_home(a.step_timeout).alt_amsl_m + r.alt_m, timeout_s=10).check()
            self.say(f"armed; taking off to {r.alt_m:g} m", r)
        self.wait_all(lambda: all(r.client.takeoff_done(r.alt_m) for r in runs), a.step_timeout, "every take-off")
        for r in runs:
            r.reached_m = r.client.relative_alt_m()
            self.say(f"at {r.reached_m:.2f} m (mode {r.client.mode_name()})", r)
        self.step = "hold"
        self._hold()
        for r in runs:
            self.step = f"land vehicle {r.k}"
            self._land(r)

    def _hold(self) -> None:
        runs, hold_s = self.runs, self.args.hold
        spots = {r.k: r.client.position_ned()[:2] for r in runs}
        end = self.runs[0].client.sim_time_s() + hold_s

        def held() -> bool:
            for r in runs:
                n, e, _ = r.client.position_ned()
                r.hold_drift_m = max(r.hold_drift_m, math.hypot(n - spots[r.k][0], e - spots[r.k][1]))
            return runs[0].client.sim_time_s() >= end

        self.wait_all(held, self.args.step_timeout, f"{hold_s:g} s of hover")
        self.say(f"held {hold_s:g} s; max drift " + ", ".join(f"{r.hold_drift_m:.2f} m" for r in runs))

    def _land(self, r: VehicleRun) -> None:
        r.client.land(timeout_s=10).check()
        self.say("landing on its pad (its start spot)", r)
        self.wait_all(r.client.landed_and_disarmed, self.args.step_timeout, f"vehicle {r.k} landed and disarmed")
        sample = r.truth.latest()
        if sample is not None:
            r.landing_error_m = math.hypot(sample.pos_ned_m[0], sample.pos_ned_m[1])
        r.landed_at_s = r.client.sim_time_s()
        err = f"{r.landing_error_m:.2f} m" if r.landing_error_m is not None else "?"
        self.say(f"landed and disarmed, {err} from its pad (truth)", r)

    def summary(self, wall_total_s: float, wall_flight_s: float, sim_flight_s: float) -> str:
        lines = ["", f"=== flight summary: {len(self.runs)} vehicles in one world ==="]
        for r in self.runs:
            reached = f"{r.reached_m:.2f} m" if r.reached_m is not None else "?"
            err = f"{r.landing_error_m:.2f} m" if r.landing_error_m is not None else "?"
            lines.append(
                f"vehicle {r.k} (sysid {r.sysid}): take-off {r.alt_m:g} m (reached {reached}), "
                f"hold drift {r.hold_drift_m:.2f} m, landing error {err} from its pad"
            )
        rtf = sim_flight_s / wall_flight_s if wall_flight_s > 0 else math.nan
        lines.append(f"wall time          {wall_total_s:.1f} s total, {wall_flight_s:.1f} s of flight")
        lines.append(f"real-time factor   {rtf:.2f} ({sim_flight_s:.1f} simulated s / {wall_flight_s:.1f} wall s)")
        return "\n".join(lines)
