"""Where the runs execute: a local process pool (default) or a Ray cluster.  Both call
:func:`campaign.runs.execute` once per run and hand each row to ``on_row`` in this process as the
run ends (in the order they end).  A run's simulator and flight controller start inside the worker
(a pool process here, a Ray task on whichever node Ray places it), so only the row comes back.

- :func:`local_pool`: ``jobs`` worker processes (started fresh: ``spawn``), one run at a time each.
- :func:`ray_cluster`: ``address`` ``"auto"`` joins the local Ray instance if one runs, else starts
  one (``ray.init()``); any other address joins that cluster (``ray.init(address=...)``).  Each run is
  a task with ``num_cpus`` = the campaign's ``cpus``.  Ray is imported only here, only when asked.
  Every node needs this project installed (the same environment), as the workers import it.

Ctrl-C: no new run starts; the runs going on are stopped and not recorded (a resume flies them again).
"""

from __future__ import annotations

import multiprocessing
import os
from concurrent.futures import FIRST_COMPLETED, Future, ProcessPoolExecutor, wait
from typing import Any, Callable

from gcs.launcher import fork_server
from gcs.launcher.parent_death import die_with_parent
from mavsim_core.spin_receiver import SPIN_ENV

from .plan import Run
from .runs import Settings, execute, lost_row

OnRow = Callable[[dict[str, Any]], None]


def local_pool(runs: list[Run], settings: Settings, jobs: int, on_row: OnRow) -> None:
    """Execute ``runs`` on ``jobs`` local worker processes."""
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=jobs, mp_context=context, initializer=_worker_start, initargs=(jobs,)) as pool:
        pending: dict[Future, Run] = {pool.submit(execute, run, settings): run for run in runs}
        try:
            while pending:
                finished, _ = wait(pending, return_when=FIRST_COMPLETED)
                for fut in finished:
                    run = pending.pop(fut)
                    exc = fut.exception()
                    on_row(lost_row(run, settings, exc) if exc is not None else fut.result())
        except KeyboardInterrupt:
            pool.shutdown(wait=True, cancel_futures=True)
            raise


def _worker_start(jobs: int) -> None:
    """Pool worker start: it ends with the campaign (and its own stacks in turn, gcs/launcher/stack.py); its stacks
    are forked from a fork server of its own, which has imported the simulator and the flight controller once (1.3 of
    a camera landing's 6 CPU s were start-up imports); and with more than one run at a time, its stacks' lockstep
    links do not spin (``MAVSIM_LOCKSTEP_SPIN_US`` 0, unless set): the spin is for one stack on an idle machine
    (mavsim_core/spin_receiver.py), and two camera landings on two cores ran 5 % faster without it (issue 38,
    benchmarks/README.md)."""
    die_with_parent()  # SIGTERM when the campaign process dies, even by SIGKILL: no runs started for nobody
    fork_server.use_here()  # its stacks forked from one server (gcs/launcher/fork_server.py)
    if jobs > 1:
        os.environ.setdefault(SPIN_ENV, "0")


def ray_cluster(runs: list[Run], settings: Settings, address: str, cpus: float, on_row: OnRow) -> None:
    """Execute ``runs`` as Ray tasks (see the module docstring)."""
    import ray  # slow to import: only when asked

    started_here = not ray.is_initialized()
    if started_here:
        ray.init(address=None if address == "auto" else address, log_to_driver=False, logging_level="warning")
    task = ray.remote(num_cpus=cpus, max_retries=0)(execute)
    pending = {task.remote(run, settings): run for run in runs}
    try:
        while pending:
            finished, _ = ray.wait(list(pending), num_returns=1)
            for ref in finished:
                run = pending.pop(ref)
                try:
                    on_row(ray.get(ref))
                except ray.exceptions.RayError as exc:
                    on_row(lost_row(run, settings, exc))
    except KeyboardInterrupt:
        for ref in pending:
            ray.cancel(ref, force=True)
        raise
    finally:
        if started_here:
            ray.shutdown()
