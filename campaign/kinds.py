"""What a campaign can fly: each *kind* declares its grid axes, its randomised ranges and its figures.

A kind is one module with a :class:`Kind` (``landing``: :mod:`.landing`; ``multi_landing``: :mod:`.multi_landing_kind`,
several vehicles of one world each on its own UGV; ``hover_step``: :mod:`.hover_step`,
the hover / step flight of benchmarks/vehicle_benchmark.py; ``mission``: :mod:`.mission_kind`, the
square mission of benchmarks/mission_benchmark.py).  The campaign file names it
(``kind = "landing"``); :mod:`.spec` checks the file against its axes and ranges, :mod:`.plan` expands
the grid into cells with :meth:`Kind.cells`, and :mod:`.runs` calls :meth:`Kind.fly` once per run, in
the worker process, on a stack of its own.  A new kind is a module with its axes, ranges and a ``fly``
that returns its figures, added to :data:`KINDS`; :mod:`.report` finds a results file's kind by its
axis columns (:func:`kind_of_columns`).
"""

from __future__ import annotations

import importlib
import itertools
from dataclasses import dataclass
from typing import Any, Callable, Protocol

Check = Callable[[Any], "str | None"]  # an axis value -> None if valid, else what is wrong with it


@dataclass(frozen=True)
class Axis:
    """One grid axis: its key under ``[grid]``, its default values and the check of one value.

    ``required_in_results``: False for an axis added after results files were written, so that a file
    without its column is still recognised as its kind's (:func:`kind_of_columns`).
    """

    name: str
    default: tuple
    check: Check
    help: str
    required_in_results: bool = True


@dataclass(frozen=True)
class Range:
    """One randomised quantity: its key under ``[random]`` and its default ``[low, high]`` (inclusive).

    Integers are drawn with ``rng.integers(low, high + 1)``, floats with ``rng.uniform(low, high)``;
    ``limits`` bound what a campaign file may ask for.
    """

    name: str
    default: tuple[float, float]
    integer: bool
    limits: tuple[float, float]
    help: str


class Kind(Protocol):
    """A kind of run (see the module docstring)."""

    name: str
    axes: tuple[Axis, ...]
    ranges: tuple[Range, ...]
    figures: tuple[str, ...]  # what a run can record (``record = [...]`` picks among these)
    error_figure: str  # the report's error column (metres)
    time_figure: str  # the report's time column (simulated seconds); its header: ``time_header`` if any

    def cells(self, grid: dict[str, tuple]) -> list[dict[str, Any]]:
        """The grid's cells, in a fixed order (the cell index is the position here)."""
        ...

    def label(self, cell: dict[str, Any]) -> str:
        """A cell as a person reads it in the report."""
        ...

    def fly(self, run: Any, ctx: Any) -> dict[str, Any]:
        """Fly ``run`` (:class:`.plan.Run`) on a stack of its own (``ctx``: :class:`.runs.RunContext`)."""
        ...


# name -> module holding its KIND (imported when asked: a kind's module may import MuJoCo's models)
KINDS = {
    "landing": "campaign.landing",
    "hover_step": "campaign.hover_step",
    "mission": "campaign.mission_kind",
    "multi_landing": "campaign.multi_landing_kind",
}
PLANNED: dict[str, str] = {}  # kind name -> the benchmark it will come from (none left)


def get_kind(name: str) -> Kind:
    """The kind called ``name``; KeyError with the known names if there is none."""
    if name not in KINDS:
        raise KeyError(name)
    return importlib.import_module(KINDS[name]).KIND


def kind_of_columns(columns: list[str] | tuple[str, ...]) -> Kind | None:
    """The kind whose grid axes and random draws are all among ``columns`` (a results file's), or None."""
    have = set(columns)
    best, best_n = None, -1
    for name in KINDS:  # the kind needing the most of them (multi_landing's results hold every landing column too)
        kind = get_kind(name)
        needs = {a.name for a in kind.axes if a.required_in_results} | {r.name for r in kind.ranges}
        if needs <= have and len(needs) > best_n:
            best, best_n = kind, len(needs)
    return best


def one_of(*allowed: Any) -> Check:
    """An axis check: the value is one of ``allowed``."""
    return lambda v: None if v in allowed else f"{v!r} is not one of {', '.join(map(repr, allowed))}"


def number_in(low: float, high: float) -> Check:
    """An axis check: a number in [low, high]."""

    def check(v: Any) -> str | None:
        if isinstance(v, bool) or not isinstance(v, (int, float)):
            return f"{v!r} is not a number"
        return None if low <= v <= high else f"{v!r} is not in [{low:g}, {high:g}]"

    return check


def grid_cells(grid: dict[str, tuple], names: tuple[str, ...]) -> list[dict[str, Any]]:
    """Every combination of the ``names`` axes of ``grid``, the first axis varying slowest."""
    return [dict(zip(names, values)) for values in itertools.product(*(grid[n] for n in names))]


def vehicle_name(v: Any) -> str | None:
    """An axis check: a vehicle file name (params/vehicles/) or path."""
    from params.vehicle import VehicleFileError, vehicle_path

    if not isinstance(v, str) or not v:
        return f"{v!r} is not a vehicle name"
    try:
        vehicle_path(v)
    except VehicleFileError as exc:
        return str(exc)
    return None


def text(v: Any) -> str | None:
    """An axis check: a non-empty string."""
    return None if isinstance(v, str) and v else f"{v!r} is not a non-empty string"
