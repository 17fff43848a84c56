"""``campaign report RESULTS``: the table per cell of a results file, and its plots (:mod:`.plots`).

Per cell: runs (infra_failed runs are not flights: they are counted apart and left out of the
rate), successes, the success rate with its 95 % Wilson score interval, the error (metres: the
kind's error figure, e.g. the touchdown error) mean / p95 / max over the runs that have one, the
mean time (simulated seconds: e.g. NAV_LAND to the disarm) of the successful runs and the mean
real-time factor (simulated / wall seconds).  The error and time figures are the kind's
(:attr:`~campaign.kinds.Kind.error_figure`, ``time_figure``), the kind found by the file's axis columns.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from .kinds import kind_of_columns
from .results import read, value

Z95 = 1.959963984540054  # the standard normal's 97.5 % quantile


def wilson(successes: int, n: int, z: float = Z95) -> tuple[float, float]:
    """The Wilson score interval of a success rate (``successes`` of ``n``); (nan, nan) for n = 0."""
    if n == 0:
        return math.nan, math.nan
    p = successes / n
    d = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / d
    half = z / d * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n))
    return max(0.0, centre - half), min(1.0, centre + half)


@dataclass
class CellStats:
    """The figures of one cell (see the module docstring)."""

    label: str
    runs: int
    successes: int
    infra_failed: int
    ci95: tuple[float, float]
    err_mean_m: float
    err_p95_m: float
    err_max_m: float
    time_mean_s: float
    rtf_mean: float
    rows: list[dict[str, Any]]

    @property
    def rate(self) -> float:
        return self.successes / self.runs if self.runs else math.nan


def load(path: Path) -> list[dict[str, Any]]:
    """The rows of a results file, numbers as numbers."""
    return [{k: value(v) for k, v in r.items()} for r in read(path)]


def figure_columns(rows: list[dict[str, Any]]) -> tuple[str | None, str | None, str]:
    """The results' error and time columns (None: not recorded, or no known kind) and the time's header."""
    kind = kind_of_columns(tuple(rows[0])) if rows else None
    if kind is None:
        return None, None, "time"
    err = kind.error_figure if kind.error_figure in rows[0] else None
    t = kind.time_figure if kind.time_figure in rows[0] else None
    return err, t, getattr(kind, "time_header", "t land")


def _finite(rows: list[dict[str, Any]], key: str | None) -> np.ndarray:
    if key is None:
        return np.zeros(0)
    v = [r[key] for r in rows if isinstance(r.get(key), (int, float)) and math.isfinite(r[key])]
    return np.asarray(v, dtype=float)


def cells(rows: list[dict[str, Any]]) -> list[CellStats]:
    """The statistics of every cell, in cell order."""
    err_key, time_key, _ = figure_columns(rows)
    out = []
    for c in sorted({r["cell"] for r in rows}):
        rs = [r for r in rows if r["cell"] == c]
        flown = [r for r in rs if r["status"] != "infra_failed"]
        ok = [r for r in flown if r["status"] == "ok"]
        err = _finite(flown, err_key)
        t = _finite(ok, time_key)
        rtf = _finite(flown, "real_time_factor")
        out.append(
            CellStats(
                label=str(rs[0]["label"]),
                runs=len(flown),
                successes=len(ok),
                infra_failed=len(rs) - len(flown),
                ci95=wilson(len(ok), len(flown)),
                err_mean_m=float(err.mean()) if len(err) else math.nan,
                err_p95_m=float(np.percentile(err, 95)) if len(err) else math.nan,
                err_max_m=float(err.max()) if len(err) else math.nan,
                time_mean_s=float(t.mean()) if len(t) else math.nan,
                rtf_mean=float(rtf.mean()) if len(rtf) else math.nan,
                rows=rs,
            )
        )
    return out


def table(stats: list[CellStats], time_header: str = "t land") -> str:
    """The report's table, one line per cell (``time_header``: the time column's, 7 characters at most)."""
    width = max([len(s.label) for s in stats] + [4])
    lines = [
        f"{'cell':<{width}} {'runs':>4} {'success':>7} {'rate':>5} {'95% CI':>11} {'err mean':>8} "
        f"{'err p95':>8} {'err max':>8} {time_header:>7} {'RTF':>5} {'infra':>5}"
    ]
    for s in stats:
        lo, hi = s.ci95
        ci = f"{100 * lo:.0f}-{100 * hi:.0f}%" if s.runs else "-"
        rate = f"{100 * s.rate:.0f}%" if s.runs else "-"
        lines.append(
            f"{s.label:<{width}} {s.runs:>4} {s.successes:>3}/{s.runs:<3} {rate:>5} {ci:>11} "
            f"{_m(s.err_mean_m)} {_m(s.err_p95_m)} {_m(s.err_max_m)} {_s(s.time_mean_s)} "
            f"{s.rtf_mean:>5.1f} {s.infra_failed:>5}"
        )
    return "\n".join(lines)


def _m(v: float) -> str:
    return f"{v:>7.3f}m" if math.isfinite(v) else f"{'-':>8}"


def _s(v: float) -> str:
    return f"{v:>6.1f}s" if math.isfinite(v) else f"{'-':>7}"


def report(path: Path, plots_dir: Path | None = None) -> tuple[str, list[Path]]:
    """The table of a results file and, with ``plots_dir``, the plots written there (their paths)."""
    rows = load(path)
    if not rows:
        raise ValueError(f"{path}: no results in it")
    stats = cells(rows)
    err_key, _, time_header = figure_columns(rows)
    text = table(stats, time_header)
    written: list[Path] = []
    if plots_dir is not None:
        from .plots import write_plots  # matplotlib: only when plots are asked for

        written, skipped = write_plots(stats, err_key, plots_dir)
        text += "".join(f"\nno {name}: {why}" for name, why in skipped)
    return text, written
