"""A campaign expanded into its runs: the grid's cells, and for each run its seeds and random draws.

Deterministic and independent of execution order: run ``i`` of cell ``c`` draws from
``numpy.random.default_rng((base_seed, c, i))``, the ranges in the kind's declared order, so any
worker, in any order, on any machine, flies the same run the same way, and a resumed campaign
re-creates exactly the runs it had not finished.  Cell indices are positions in the kind's
:meth:`~campaign.kinds.Kind.cells` list (fixed axis order, file order of the values).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from .spec import Campaign


@dataclass(frozen=True)
class Run:
    """One run: ``run_id`` (``c<cell>-r<index>``), its cell, the cell's axis values and its draws."""

    run_id: str
    cell: int
    index: int
    label: str
    axes: dict[str, Any]
    draws: dict[str, float]


def run_id(cell: int, index: int) -> str:
    return f"c{cell:03d}-r{index:04d}"


def draws(campaign: Campaign, cell: int, index: int) -> dict[str, float]:
    """The random draws of run ``index`` of cell ``cell`` (see the module docstring)."""
    rng = np.random.default_rng((campaign.base_seed, cell, index))
    kind = campaign.kind_()
    out: dict[str, float] = {}
    for r in kind.ranges:
        low, high = campaign.random[r.name]
        out[r.name] = int(rng.integers(low, high + 1)) if r.integer else float(rng.uniform(low, high))
    return out


def expand(campaign: Campaign) -> list[Run]:
    """Every run of the campaign: cell by cell, ``runs`` per cell."""
    kind = campaign.kind_()
    out = []
    for c, cell in enumerate(kind.cells(campaign.grid)):
        label = kind.label(cell)
        for i in range(campaign.runs):
            out.append(Run(run_id(c, i), c, i, label, dict(cell), draws(campaign, c, i)))
    return out
