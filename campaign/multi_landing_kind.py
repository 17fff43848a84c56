"""Campaign kind ``multi_landing``: N multicopters in one world, each landing on its own moving UGV
(gcs/launcher/multi_landing.py), each scored from its own truth.

Grid axes: those of ``landing`` (:mod:`.landing`: vehicle, wind, UGV speed and path, radius, camera, pad; every
vehicle of the world flies the same cell) and ``vehicles``, how many fly in the world (2-5; ``sitl --count``: each
its own UGV, camera, companion and deck marker ids, the vehicles 10 m apart).  Randomised per run as ``landing``:
the UGV's start pose and the meeting point's offset (each vehicle's from its own start point) and the simulator's
seed (one world, one seed; vehicle k's sensors, camera and UGV draw from its own stream of it).

A run succeeds when every vehicle stands on its own deck; its figures (:func:`multi_figures`): how many did, the
worst and the mean touchdown error (the report's error column is the worst), each vehicle's error and verdict in
order, the longest time to land, the real-time factor of the whole world.  A run needs ``vehicles`` consecutive
instances: the one leased for it and the next ones, each leased too (a run whose next instances are taken is an
infrastructure failure, retried).
"""

from __future__ import annotations

import math
from contextlib import ExitStack
from typing import Any, Sequence

from gcs.launcher.instance_pool import lease
from gcs.launcher.landing_run import LandingResult
from gcs.launcher.multi_landing import fly_multi_landing
from gcs.sim_client import SimClient

from .kinds import Axis
from .landing import FLIGHT_TIMEOUT_S, LandingKind, setup_for
from .plan import Run
from .runs import InfraError

MAX_VEHICLES = 5


def _count(v: Any) -> str | None:
    ok = isinstance(v, int) and not isinstance(v, bool) and 2 <= v <= MAX_VEHICLES
    return None if ok else f"{v!r} is not a whole number of vehicles in 2-{MAX_VEHICLES}"


def multi_figures(results: Sequence[LandingResult]) -> dict[str, Any]:
    """One run's figures from each vehicle's result (vehicle k at position k): see the module docstring."""
    errors = [r.touchdown_error_m for r in results]
    known = [e for e in errors if math.isfinite(e)]
    times = [r.time_to_land_s for r in results if math.isfinite(r.time_to_land_s)]
    on_deck = sum(r.success for r in results)
    first = results[0] if results else LandingResult()
    failed = [f"vehicle {k}: {r.reason}" for k, r in enumerate(results) if not r.success]
    return {
        "success": bool(results) and on_deck == len(results),
        "on_deck": on_deck,
        "touchdown_error_m": max(known) if len(known) == len(errors) and known else math.nan,
        "touchdown_error_mean_m": sum(known) / len(known) if known else math.nan,
        "touchdown_errors_m": " ".join(f"{e:.3f}" for e in errors),
        "on_deck_each": " ".join(str(int(r.success)) for r in results),
        "time_to_land_s": max(times) if times else math.nan,
        "sim_s": first.sim_s,
        "wall_s": first.wall_s,
        "real_time_factor": first.real_time_factor,
        "status": "ok" if results and on_deck == len(results) else "flight_failed",
        "reason": "; ".join(failed)[:200],
    }


class MultiLandingKind(LandingKind):
    """See the module docstring."""

    name = "multi_landing"
    axes = (
        Axis("vehicles", (3,), _count, f"multicopters in the world, each on its own UGV (2-{MAX_VEHICLES})"),
        *LandingKind.axes,
    )
    figures = (
        "success",
        "on_deck",
        "touchdown_error_m",
        "touchdown_error_mean_m",
        "touchdown_errors_m",
        "on_deck_each",
        "time_to_land_s",
        "sim_s",
        "wall_s",
        "real_time_factor",
    )
    error_figure = "touchdown_error_m"  # the worst vehicle's
    time_figure = "time_to_land_s"  # the last vehicle's

    def cells(self, grid: dict[str, tuple]) -> list[dict[str, Any]]:
        landing = super().cells(grid)
        return [{"vehicles": n, **c} for n in grid["vehicles"] for c in landing]

    def label(self, cell: dict[str, Any]) -> str:
        """e.g. ``3 x quad_x circle 1 m/s calm gimbal camera nested pad``."""
        return f"{cell['vehicles']} x {super().label(cell)}"

    def fly(self, run: Run, ctx) -> dict[str, Any]:
        """The run's world (``vehicles`` multicopters from the run's instance on) and its landings."""
        count = int(run.axes["vehicles"])
        setup = setup_for(run.axes, run.draws, ctx.settings.sim_params, ctx.settings.fc_params)
        with ExitStack() as held:
            for k in range(1, count):  # the next instances, held as the run's own is
                try:
                    held.enter_context(lease([ctx.instance + k]))
                except RuntimeError as exc:
                    raise InfraError(f"instance {ctx.instance + k} for vehicle {k}: {exc}") from exc
            stack = ctx.stack(setup.vehicle, setup.seed, setup.sim_args(), count=count)
            stack.start()
            clients = [ctx.client()] + [ctx.client_of(k) for k in range(1, count)]
            truths = [held.enter_context(SimClient(stack.truth_port_of(k))) for k in range(count)]
            try:
                timeout_s = min(FLIGHT_TIMEOUT_S, ctx.settings.time_limit_s)
                results = fly_multi_landing(clients, truths, setup, timeout_s=timeout_s)
            finally:
                for c in clients[1:]:
                    c.close()
            stack.stop()
        return multi_figures(results)


KIND = MultiLandingKind()
