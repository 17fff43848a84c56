"""``python -m _trace_wrap OUT_PREFIX NAME MODULE [ARGS...]``: run MODULE as ``python -m MODULE ARGS`` does, stamping
the lockstep's per-period events with ``time.perf_counter`` (CLOCK_MONOTONIC: one clock for every process of the
machine) from SIGUSR1 to SIGUSR2, and write them to ``OUT_PREFIX.NAME.npy`` at SIGUSR2 (rows: event code, seconds).

NAME ``sitl``: the simulator's events (:data:`SITL_EVENTS`), and its vision companion's frames (the process it forks,
``sitl/companion_workers.py``: each frame's start and end, written to ``OUT_PREFIX.camera.npy`` when it ends).  NAME
``autopilot``: the flight controller's (:data:`FC_EVENTS`).  Not a benchmark itself (the leading underscore):
``benchmarks/lockstep_trace.py`` runs a stack's processes through it.
"""

from __future__ import annotations

import runpy
import signal
import sys
import time

import numpy as np

SITL_EVENTS = {"actuators in": 1, "sensors out": 3, "post done": 4}
FC_EVENTS = {"sensors in": 12, "actuators out": 13, "after step done": 14}


def _stamp(cls: type, attr: str, code: int, rows: list, on: list, at_start: bool = False) -> None:
    """Wrap ``cls.attr`` to append ``(code, now)`` at its start or end while ``on[0]``."""
    original = getattr(cls, attr)
    clock = time.perf_counter

    def stamped(*args, **kwargs):
        if not on[0]:
            return original(*args, **kwargs)
        if at_start:
            rows.append((code, clock()))
            return original(*args, **kwargs)
        result = original(*args, **kwargs)
        rows.append((code, clock()))
        return result

    setattr(cls, attr, stamped)


def _sitl(prefix: str, rows: list, on: list) -> None:
    from sitl.companion import LockstepCompanion
    from sitl.lockstep import LockstepServer
    from sitl.simulation import World

    _stamp(LockstepServer, "_wait_actuators", 1, rows, on)
    _stamp(LockstepServer, "_send_sensors", 4, rows, on)
    # The sensors leave just before the truth port's work and the next step's preparation (sitl/lockstep.py): the
    # first of those after a period's start is when its HIL_SENSOR went out.
    _stamp(LockstepServer, "_every_truth_period", 3, rows, on, at_start=True)
    _stamp(World, "prepare_step", 3, rows, on, at_start=True)
    frames: list = []  # the companion's frames (its own process: stamped from its start to its end)
    process_frame = LockstepCompanion.process_frame

    def timed_frame(*args, **kwargs):
        t0 = time.perf_counter()
        answer = process_frame(*args, **kwargs)
        frames.append((t0, time.perf_counter()))
        return answer

    LockstepCompanion.process_frame = timed_frame
    import sitl.companion_workers as workers

    serve = workers._serve

    def traced_serve(*args, **kwargs):
        try:
            serve(*args, **kwargs)
        finally:
            np.save(prefix + ".camera.npy", np.array(frames, dtype=float).reshape(-1, 2))

    workers._serve = traced_serve


def _autopilot(rows: list, on: list) -> None:
    from autopilot.flight_controller import FlightController
    from autopilot.mavlink.sim_link import SimLink

    _stamp(FlightController, "step", 12, rows, on, at_start=True)
    _stamp(SimLink, "send_actuators", 13, rows, on)
    _stamp(FlightController, "after_step", 14, rows, on)


def main() -> None:
    prefix, name, module = sys.argv[1], sys.argv[2], sys.argv[3]
    sys.argv = [module, *sys.argv[4:]]
    rows: list = []
    on = [False]
    if name == "sitl":
        _sitl(prefix, rows, on)
    else:
        _autopilot(rows, on)

    def start(*_) -> None:
        rows.clear()
        on[0] = True

    def stop(*_) -> None:
        on[0] = False
        np.save(f"{prefix}.{name}.npy", np.array(rows, dtype=float).reshape(-1, 2))

    signal.signal(signal.SIGUSR1, start)
    signal.signal(signal.SIGUSR2, stop)
    runpy.run_module(module, run_name="__main__", alter_sys=True)


if __name__ == "__main__":
    main()
