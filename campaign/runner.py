"""``campaign run``: expand the campaign, skip what the results file has done, execute the rest.

Each row goes to the results file (:mod:`.results`) the moment its run ends; one tqdm bar on stderr
counts the runs done (those of an earlier, resumed part too), the failures and the time left.
"""

from __future__ import annotations

import os
import sys
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable

from tqdm import tqdm

from gcs.launcher.instance_pool import POOL

from . import executors, plan
from .results import ResultsFile, tag
from .runs import FLIGHT_FAILED, INFRA_FAILED, Settings
from .spec import Campaign


@dataclass
class Options:
    """How to run a campaign (the ``campaign run`` options)."""

    out: Path
    resume: bool = False
    jobs: int = os.cpu_count() or 1
    ray: str | None = None  # "auto" or a cluster address; None: the local pool
    instances: tuple[int, int] = (POOL.start, POOL.stop - 1)
    log_dir: Path | None = None
    on_row: Callable[[dict[str, Any]], None] | None = None  # also told of each row (a benchmark's own line)


@dataclass
class Outcome:
    """What a ``campaign run`` did: runs in the campaign, skipped as done, and this time's statuses."""

    total: int
    skipped: int
    statuses: Counter = field(default_factory=Counter)


def settings_of(campaign: Campaign, options: Options) -> Settings:
    return Settings(
        kind=campaign.kind,
        campaign=tag(campaign),
        time_limit_s=campaign.time_limit_s,
        retries=campaign.retries,
        record=campaign.record,
        fc_params=dict(campaign.fc_params),
        sim_params=dict(campaign.sim_params),
        instances=options.instances,
        log_dir=str(options.log_dir.resolve()) if options.log_dir else None,
    )


def run(campaign: Campaign, options: Options) -> Outcome:
    """Execute the campaign's runs not yet in ``options.out``; ResultsError if that file is another's."""
    runs = plan.expand(campaign)
    results, done = ResultsFile.open(options.out, campaign, runs, options.resume)
    todo = [r for r in runs if r.run_id not in done]
    outcome = Outcome(len(runs), len(runs) - len(todo))
    bar = tqdm(total=len(runs), initial=outcome.skipped, unit="run", desc=campaign.name, file=sys.stderr)
    bar.set_postfix_str("failures 0", refresh=False)

    def on_row(row: dict[str, Any]) -> None:
        results.append(row)
        outcome.statuses[row["status"]] += 1
        bar.set_postfix_str(
            f"failures {outcome.statuses[FLIGHT_FAILED]} flight, {outcome.statuses[INFRA_FAILED]} infra", refresh=False
        )
        bar.update(1)
        if options.on_row is not None:
            options.on_row(row)

    settings = settings_of(campaign, options)
    try:
        if not todo:
            pass
        elif options.ray is not None:
            executors.ray_cluster(todo, settings, options.ray, campaign.cpus, on_row)
        else:
            executors.local_pool(todo, settings, max(1, min(options.jobs, len(todo))), on_row)
    finally:
        bar.close()
        results.close()
    return outcome
