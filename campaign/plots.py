"""The report's plots (PNG): the error distribution of every cell, success against UGV speed and
against wind, each success rate with its 95 % Wilson interval as an error bar.  A plot whose axis the
results do not have (no UGV speed in a hover/step campaign) is left out, and the report says so.  The
landing's camera and pad axes, where the results have them, split the series (gimbal and fixed camera
apart), never pooled into one rate."""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from .report import CellStats, wilson


def _plt():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _rate(rows: list[dict[str, Any]]) -> tuple[float, float, float] | None:
    """(success %, % below, % above: the 95 % Wilson interval) of the runs that flew; None if none flew."""
    flown = [r for r in rows if r["status"] != "infra_failed"]
    if not flown:
        return None
    ok = sum(r["status"] == "ok" for r in flown)
    lo, hi = wilson(ok, len(flown))
    p = ok / len(flown)
    # Rounding can put the interval a hair inside p (10 of 10: hi = 0.99999...), which matplotlib refuses.
    return 100 * p, 100 * max(p - lo, 0.0), 100 * max(hi - p, 0.0)


def errors_plot(stats: list[CellStats], error_key: str, path: Path) -> None:
    plt = _plt()
    fig, ax = plt.subplots(figsize=(10, 0.45 * len(stats) + 1.8))
    for i, s in enumerate(stats):
        for r in s.rows:
            e = r.get(error_key)
            if isinstance(e, (int, float)) and math.isfinite(e):
                ax.scatter(100 * e, i, s=14, color="C2" if r["status"] == "ok" else "C3")
    ax.set_yticks(range(len(stats)), [s.label for s in stats], fontsize=8)
    ax.invert_yaxis()
    ax.grid(alpha=0.3)
    ax.set_xlabel(f"{error_key} (cm; green: ok, red: flight failed)")
    ax.set_title("Error distribution per cell")
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


def against_plot(rows: list[dict[str, Any]], axis: str, groups: tuple[str, ...], path: Path, xlabel: str) -> None:
    """Success rate against ``axis``, one series per group (numeric axis: joined by a line), each point with its
    95 % Wilson interval; the series are spread a little along x so that their intervals do not hide each other."""
    plt = _plt()
    fig, ax = plt.subplots(figsize=(8, 4.5))
    keys = sorted({tuple(str(r[g]) for g in groups) for r in rows})
    xs = list(dict.fromkeys(r[axis] for r in sorted(rows, key=lambda r: r["cell"])))
    numeric = all(isinstance(x, (int, float)) for x in xs)
    spread = (0.02 * (max(xs) - min(xs) or 1.0)) if numeric else 0.08
    for k, key in enumerate(keys):
        mine = [r for r in rows if tuple(str(r[g]) for g in groups) == key]
        points = []
        for j, x in enumerate(xs):
            rate = _rate([r for r in mine if r[axis] == x])
            if rate is not None:
                points.append(((float(x) if numeric else j) + spread * (k - (len(keys) - 1) / 2), *rate))
        if points:
            px, p, below, above = zip(*points)
            ax.errorbar(
                px,
                p,
                yerr=[below, above],
                capsize=3,
                fmt="o-" if numeric else "o",
                color=f"C{k % 10}",
                label=" ".join(key),
            )
    if not numeric:
        ax.set_xticks(range(len(xs)), [str(x) for x in xs])
    ax.set_ylim(-5, 105)
    ax.set_xlabel(xlabel)
    ax.set_ylabel("success (%, 95 % Wilson interval)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=100)
    plt.close(fig)


SERIES_SPLIT_BY = ("camera", "pad")  # axes that make series of their own in the success plots, where present


def _series(rows: list[dict[str, Any]], groups: tuple[str, ...]) -> tuple[str, ...]:
    """``groups`` and those of :data:`SERIES_SPLIT_BY` that the results have: the columns one series holds fixed."""
    return groups + tuple(g for g in SERIES_SPLIT_BY if rows and g in rows[0])


def write_plots(stats: list[CellStats], error_key: str | None, out: Path) -> tuple[list[Path], list[tuple[str, str]]]:
    """Every plot the results allow, into ``out``: their paths, and (name, why) of each plot left out."""
    out.mkdir(parents=True, exist_ok=True)
    rows = [r for s in stats for r in s.rows]
    written: list[Path] = []
    skipped: list[tuple[str, str]] = []
    if error_key is not None:
        written.append(out / "errors.png")
        errors_plot(stats, error_key, written[-1])
    else:
        skipped.append(("errors.png", "the results record no error figure of their kind"))
    if rows and "ugv_speed_m_s" in rows[0]:
        written.append(out / "success_vs_speed.png")
        groups = _series(rows, ("vehicle", "ugv_path", "wind"))
        against_plot(rows, "ugv_speed_m_s", groups, written[-1], "UGV speed (m/s)")
    else:
        skipped.append(("success_vs_speed.png", "the results have no UGV speed axis (ugv_speed_m_s)"))
    wind = next((k for k in ("wind", "wind_m_s") if rows and k in rows[0]), None)
    if wind is not None:
        written.append(out / "success_vs_wind.png")
        against_plot(rows, wind, _series(rows, ("vehicle",)), written[-1], "wind" if wind == "wind" else "wind (m/s)")
    else:
        skipped.append(("success_vs_wind.png", "the results have no wind axis"))
    return written, skipped
