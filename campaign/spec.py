"""The campaign file (TOML): read, checked key by key, and frozen into a :class:`Campaign`.

Example (benchmarks/campaigns/landing.toml has every key with its meaning)::

    kind = "landing"          # what each run flies (campaign/kinds.py)
    runs = 10                 # runs per cell of the grid
    base_seed = 1             # run i of cell c draws from numpy default_rng((base_seed, c, i))
    time_limit_s = 600        # wall seconds per run: a safety net, not a score
    retries = 2               # re-runs of a run that failed for an infrastructure reason
    cpus = 1                  # CPUs one run needs (its Ray task's num_cpus)
    record = ["touchdown_error_m", "time_to_land_s"]   # figures kept (default: all of the kind's)

    [grid]                    # a list per axis; the cells are every combination
    vehicle = ["quad_x"]
    ugv_speed_m_s = [0, 1]

    [random]                  # [low, high] per randomised quantity
    ugv_heading_deg = [-180, 180]

    [fc_params]               # flight-controller parameters for every run
    PLD_PREDICTOR = 1

A broken file raises :class:`SpecError` naming the key (``key grid.wind: 'gale' is not one of ...``).
"""

from __future__ import annotations

import hashlib
import json
import math
import re
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from .kinds import KINDS, PLANNED, Kind, get_kind

TOP_KEYS = {"name", "kind", "runs", "base_seed", "time_limit_s", "retries", "cpus", "record"}
TABLES = {"grid", "random", "fc_params", "sim_params"}
PARAM_NAME = re.compile(r"^[A-Z][A-Z0-9_]{0,15}$")  # MAVLink parameter ids: 16 characters at most


class SpecError(ValueError):
    """A campaign file that cannot be run: ``key`` is the dotted key at fault."""

    def __init__(self, key: str, message: str) -> None:
        super().__init__(f"key {key}: {message}")
        self.key = key


@dataclass(frozen=True)
class Campaign:
    """A checked campaign file.  ``grid``: axis -> values; ``random``: quantity -> (low, high)."""

    kind: str
    name: str = "campaign"
    runs: int = 10
    base_seed: int = 1
    time_limit_s: float = 600.0
    retries: int = 2
    cpus: float = 1.0
    record: tuple[str, ...] = ()
    grid: dict[str, tuple] = field(default_factory=dict)
    random: dict[str, tuple[float, float]] = field(default_factory=dict)
    fc_params: dict[str, float] = field(default_factory=dict)
    sim_params: dict[str, float] = field(default_factory=dict)

    def digest(self) -> str:
        """12 hex digits that change when anything that shapes the runs or their results changes."""
        data = {k: v for k, v in self.__dict__.items() if k not in ("name", "time_limit_s", "retries", "cpus")}
        return hashlib.sha256(json.dumps(data, sort_keys=True, default=list).encode()).hexdigest()[:12]

    def kind_(self) -> Kind:
        return get_kind(self.kind)


def load(path: str | Path) -> Campaign:
    """Read and check a campaign file; OSError if it cannot be read, SpecError if it is not valid."""
    path = Path(path)
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as exc:
        raise SpecError("(file)", f"not valid TOML: {exc}") from None
    except UnicodeDecodeError:
        raise SpecError("(file)", "not a text file") from None
    return from_dict(data, default_name=path.stem)


def from_dict(data: dict[str, Any], default_name: str = "campaign") -> Campaign:
    """A :class:`Campaign` from a parsed file (or a dict a script builds); SpecError names the first bad key."""
    for key in data:
        if key not in TOP_KEYS | TABLES:
            raise SpecError(key, f"unknown (known: {', '.join(sorted(TOP_KEYS | TABLES))})")
    kind_name = data.get("kind")
    if kind_name is None:
        raise SpecError("kind", f"missing (one of: {', '.join(KINDS)})")
    if kind_name in PLANNED:
        raise SpecError("kind", f"{kind_name!r} is not a campaign kind yet (its benchmark: {PLANNED[kind_name]})")
    if kind_name not in KINDS:
        raise SpecError("kind", f"{kind_name!r} is not one of: {', '.join(KINDS)}")
    kind = get_kind(kind_name)
    record = data.get("record", list(kind.figures))
    if not isinstance(record, list) or not record:
        raise SpecError("record", "must be a non-empty list of figure names")
    for name in record:
        if name not in kind.figures:
            raise SpecError("record", f"{name!r} is not a figure of kind {kind_name!r} ({', '.join(kind.figures)})")
    return Campaign(
        kind=kind_name,
        name=_string(data, "name", default_name),
        runs=int(_number(data, "runs", 10, 1, 1_000_000, integer=True)),
        base_seed=int(_number(data, "base_seed", 1, 0, 2**63 - 1, integer=True)),
        time_limit_s=_number(data, "time_limit_s", 600.0, 1.0, 86400.0),
        retries=int(_number(data, "retries", 2, 0, 10, integer=True)),
        cpus=_number(data, "cpus", 1.0, 0.01, 1024.0),
        record=tuple(record),
        grid=_grid(_table(data, "grid"), kind),
        random=_random(_table(data, "random"), kind),
        fc_params=_params(_table(data, "fc_params"), "fc_params"),
        sim_params=_sim_params(_table(data, "sim_params"), kind),
    )


def _sim_params(table: dict, kind) -> dict[str, float]:
    """``[sim_params]``, refusing one the kind sets from a grid key or a random draw (``kind.owned_sim_params``:
    parameter -> that key): it would override the key silently, and the results would say what was not flown."""
    params = _params(table, "sim_params")
    for name in params:
        owner = getattr(kind, "owned_sim_params", {}).get(name)
        if owner is not None:
            raise SpecError(f"sim_params.{name}", f"is set by the {kind.name} campaign's {owner}: use that key instead")
    return params


def _table(data: dict, key: str) -> dict:
    value = data.get(key, {})
    if not isinstance(value, dict):
        raise SpecError(key, f"must be a table ([{key}]), not {type(value).__name__}")
    return value


def _string(data: dict, key: str, default: str) -> str:
    value = data.get(key, default)
    if not isinstance(value, str) or not value:
        raise SpecError(key, f"must be a non-empty string, not {value!r}")
    return value


def _number(data: dict, key: str, default: float, low: float, high: float, integer: bool = False) -> float:
    value = data.get(key, default)
    if isinstance(value, bool) or not isinstance(value, (int, float)) or (integer and not isinstance(value, int)):
        raise SpecError(key, f"must be {'an integer' if integer else 'a number'}, not {value!r}")
    if not (math.isfinite(value) and low <= value <= high):
        raise SpecError(key, f"must be {low:g} to {high:g}, not {value!r}")
    return value


def _grid(table: dict, kind: Kind) -> dict[str, tuple]:
    axes = {a.name: a for a in kind.axes}
    for key in table:
        if key not in axes:
            raise SpecError(f"grid.{key}", f"not an axis of kind {kind.name!r} (axes: {', '.join(axes)})")
    grid: dict[str, tuple] = {}
    for name, axis in axes.items():
        values = table.get(name, list(axis.default))
        if not isinstance(values, list) or not values:
            raise SpecError(f"grid.{name}", f"must be a non-empty list, not {values!r}")
        for v in values:
            if (problem := axis.check(v)) is not None:
                raise SpecError(f"grid.{name}", problem)
        if len(set(map(repr, values))) != len(values):
            raise SpecError(f"grid.{name}", f"lists a value twice: {values!r}")
        grid[name] = tuple(values)
    return grid


def _random(table: dict, kind: Kind) -> dict[str, tuple[float, float]]:
    ranges = {r.name: r for r in kind.ranges}
    for key in table:
        if key not in ranges:
            raise SpecError(f"random.{key}", f"not randomised by kind {kind.name!r} (ranges: {', '.join(ranges)})")
    out: dict[str, tuple[float, float]] = {}
    for name, r in ranges.items():
        value = table.get(name, list(r.default))
        key = f"random.{name}"
        if not (isinstance(value, list) and len(value) == 2):
            raise SpecError(key, f"must be [low, high], not {value!r}")
        for v in value:
            if isinstance(v, bool) or not isinstance(v, (int, float)) or (r.integer and not isinstance(v, int)):
                raise SpecError(key, f"must be [low, high] of {'integers' if r.integer else 'numbers'}, not {value!r}")
        low, high = value
        if not (r.limits[0] <= low <= high <= r.limits[1]):
            raise SpecError(key, f"must have {r.limits[0]:g} <= low <= high <= {r.limits[1]:g}, not {value!r}")
        out[name] = (low, high)
    return out


def _params(table: dict, key: str) -> dict[str, float]:
    for name, value in table.items():
        if not PARAM_NAME.match(name):
            raise SpecError(f"{key}.{name}", "not a parameter name (capitals, digits and _, 16 at most)")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
            raise SpecError(f"{key}.{name}", f"must be a finite number, not {value!r}")
    return dict(table)
