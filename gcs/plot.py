"""``gcs plot LOG``: PNG figures of a flight, setpoint against estimate (and ground truth).

Like [Q]'s tuning plots (errors in altitude, roll and pitch over time).  The
logs (the flight controller's ``*.ulg``, ``*.tlog``, a directory, and the simulator's ``*.truth.npy``)
are read into series by :mod:`gcs.flight_logs`; this module only draws them.

Figures written to ``--out`` (default ``<log dir>/<log name>_plots``): ``overview.png``
(all of it on one page), ``altitude.png``, ``attitude.png`` (roll, pitch, yaw),
``position.png`` (north, east, track), ``errors.png`` (setpoint - estimate, and
estimate - truth) and ``motors.png``.  Time is simulated seconds (the vehicle's
clock), positions metres in the estimator's frame, angles degrees.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from mavsim_core.cli_checks import positive_int

from .flight_logs import FlightData, FlightLogError, load, log_stem, resolve_log
from .plot_landing import fig_landing, has_landing

FIGURES = ("overview", "altitude", "attitude", "position", "errors", "motors")
MAX_GAP_S = 1.0  # samples further apart than this are not joined by a line
NEAR_SAMPLE_S = 0.25  # an error is shown only where the other series has a sample this close

COLORS = {"setpoint": "tab:red", "estimate": "tab:blue", "truth": "k"}
STYLES = {"setpoint": dict(lw=1.2, ls="--"), "estimate": dict(lw=1.0), "truth": dict(lw=0.8, alpha=0.7)}


# --------------------------------------------------------------------------- figures


def _wrap_deg(y: np.ndarray) -> np.ndarray:
    """Angles in (-180, 180] with NaN at the wrap-around, so lines do not jump across the plot."""
    y = (np.asarray(y, dtype=float) + 180.0) % 360.0 - 180.0
    jump = np.abs(np.diff(y)) > 180.0
    if jump.any():
        y = y.copy()
        y[1:][jump] = np.nan
    return y


def _sources(data: FlightData):
    for name in ("setpoint", "estimate", "truth"):
        s = getattr(data, name)
        if s is not None and s.t_s.size:
            yield name, s


def _line(t: np.ndarray, y: np.ndarray, wrap: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """The finite samples, with a break (NaN) wherever samples are more than MAX_GAP_S apart.

    Setpoints are NaN while the controllers are idle (a gap); in a tlog each message has its own times.
    """
    ok = np.isfinite(y)
    t, y = t[ok], y[ok]
    if wrap:
        y = _wrap_deg(y)
    gaps = np.flatnonzero(np.diff(t) > MAX_GAP_S) + 1
    if gaps.size:
        t = np.insert(t, gaps, np.nan)
        y = np.insert(y, gaps, np.nan)
    return t, y


def _plot_quantity(ax, data: FlightData, key: str, label: str, wrap: bool = False) -> None:
    for src, s in _sources(data):
        y = s.cols.get(key)
        if y is None or not np.isfinite(y).any():
            continue
        ax.plot(*_line(s.t_s, y, wrap), color=COLORS[src], label=src, **STYLES[src])
    ax.set_ylabel(label)
    ax.grid(True, alpha=0.3)


def _mark_modes(ax, data: FlightData, labels: bool) -> None:
    for t, name in data.modes:
        ax.axvline(t, color="0.6", lw=0.6, ls=":")
        if labels:
            ax.text(
                t,
                1.0,
                " " + name,
                transform=ax.get_xaxis_transform(),
                fontsize=7,
                rotation=90,
                va="top",
                ha="left",
                color="0.35",
            )


def _legend(ax) -> None:
    if ax.get_legend_handles_labels()[0]:
        ax.legend(loc="best", fontsize=8)


def _error(data: FlightData, key: str, a: str, b: str, wrap: bool = False) -> tuple[np.ndarray, np.ndarray] | None:
    """(t, a - b) at b's sample times, a interpolated (only where both exist)."""
    sa, sb = getattr(data, a), getattr(data, b)
    if sa is None or sb is None or key not in sa.cols or key not in sb.cols:
        return None
    ya, yb = sa.cols[key], sb.cols[key]
    ka, kb = np.isfinite(ya), np.isfinite(yb)
    if ka.sum() < 2 or not kb.any():
        return None
    ta, ya = sa.t_s[ka], ya[ka]
    if wrap:
        ya = np.degrees(np.unwrap(np.radians(ya)))
    tb, yb = sb.t_s[kb], yb[kb]
    inside = (tb >= ta[0]) & (tb <= ta[-1])
    # Only where ``a`` exists nearby: setpoints are NaN while the controllers are idle.
    idx = np.clip(np.searchsorted(ta, tb), 1, len(ta) - 1)
    near = np.minimum(np.abs(ta[idx] - tb), np.abs(ta[idx - 1] - tb)) <= NEAR_SAMPLE_S
    sel = inside & near
    if not sel.any():
        return None
    err = np.interp(tb[sel], ta, ya) - yb[sel]
    if wrap:
        err = (err + 180.0) % 360.0 - 180.0
    return tb[sel], err


def _fig_altitude(plt, data: FlightData):
    fig, (ax, ax_err) = plt.subplots(2, 1, figsize=(10, 6), sharex=True, height_ratios=(2, 1))
    _plot_quantity(ax, data, "alt_m", "altitude, m")
    _mark_modes(ax, data, labels=True)
    _legend(ax)
    ax.set_title("Altitude: setpoint, estimate" + (", truth" if data.truth is not None else ""))
    _error_panel(ax_err, data, "alt_m", "altitude error, m")
    ax_err.set_xlabel("simulated time, s")
    return fig


def _error_panel(ax, data: FlightData, key: str, label: str, wrap: bool = False) -> None:
    e = _error(data, key, "setpoint", "estimate", wrap)
    if e is not None:
        ax.plot(*e, color="tab:purple", lw=0.9, label="setpoint - estimate")
    e = _error(data, key, "estimate", "truth", wrap)
    if e is not None:
        ax.plot(*e, color="tab:green", lw=0.8, label="estimate - truth")
    ax.axhline(0.0, color="0.5", lw=0.6)
    ax.set_ylabel(label)
    ax.grid(True, alpha=0.3)
    _legend(ax)


def _fig_attitude(plt, data: FlightData):
    fig, axes = plt.subplots(3, 1, figsize=(10, 8), sharex=True)
    for ax, (key, label) in zip(
        axes, (("roll_deg", "roll, deg"), ("pitch_deg", "pitch, deg"), ("yaw_deg", "yaw, deg"))
    ):
        _plot_quantity(ax, data, key, label, wrap=key == "yaw_deg")
        _mark_modes(ax, data, labels=ax is axes[0])
    _legend(axes[0])
    axes[0].set_title("Attitude: setpoint, estimate" + (", truth" if data.truth is not None else ""))
    axes[-1].set_xlabel("simulated time, s")
    return fig


def _fig_position(plt, data: FlightData):
    fig = plt.figure(figsize=(12, 6))
    gs = fig.add_gridspec(2, 2, width_ratios=(2, 1))
    ax_n = fig.add_subplot(gs[0, 0])
    ax_e = fig.add_subplot(gs[1, 0], sharex=ax_n)
    ax_xy = fig.add_subplot(gs[:, 1])
    _plot_quantity(ax_n, data, "n_m", "north, m")
    _plot_quantity(ax_e, data, "e_m", "east, m")
    _mark_modes(ax_n, data, labels=True)
    _legend(ax_n)
    ax_n.set_title("Position: setpoint, estimate" + (", truth" if data.truth is not None else ""))
    ax_e.set_xlabel("simulated time, s")
    for src, s in _sources(data):
        n, e = s.cols.get("n_m"), s.cols.get("e_m")
        if n is None or e is None:
            continue
        ok = np.isfinite(n) & np.isfinite(e)
        if ok.any():
            ax_xy.plot(e[ok], n[ok], color=COLORS[src], label=src, **STYLES[src])
    ax_xy.set_xlabel("east, m")
    ax_xy.set_ylabel("north, m")
    ax_xy.set_aspect("equal", adjustable="datalim")
    ax_xy.grid(True, alpha=0.3)
    ax_xy.set_title("Track")
    return fig


def _fig_errors(plt, data: FlightData):
    fig, axes = plt.subplots(5, 1, figsize=(10, 10), sharex=True)
    rows = (
        ("alt_m", "altitude, m", False),
        ("roll_deg", "roll, deg", False),
        ("pitch_deg", "pitch, deg", False),
        ("yaw_deg", "yaw, deg", True),
        ("n_m", "north, m", False),
    )
    for ax, (key, label, wrap) in zip(axes, rows):
        _error_panel(ax, data, key, label + " error", wrap)
        _mark_modes(ax, data, labels=False)
    axes[0].set_title(
        "Errors (as in [Q 3.5]): setpoint - estimate" + (", estimate - truth" if data.truth is not None else "")
    )
    axes[-1].set_xlabel("simulated time, s")
    return fig


def _plot_motors(ax, data: FlightData) -> None:
    if data.motors is None:
        ax.text(0.5, 0.5, "no motor outputs in this log", transform=ax.transAxes, ha="center", va="center")
    else:
        for name, y in data.motors.cols.items():
            ax.plot(data.motors.t_s, y, lw=0.7, label=name.replace("_", " "))
        ax.set_ylim(-0.02, 1.02)
        _legend(ax)
    ax.set_ylabel("motor command, 0..1")
    ax.grid(True, alpha=0.3)


def _fig_motors(plt, data: FlightData):
    fig, ax = plt.subplots(1, 1, figsize=(10, 4))
    _plot_motors(ax, data)
    _mark_modes(ax, data, labels=True)
    ax.set_title("Motor outputs")
    ax.set_xlabel("simulated time, s")
    return fig


def _fig_overview(plt, data: FlightData):
    fig = plt.figure(figsize=(14, 11))
    gs = fig.add_gridspec(4, 2)
    first = fig.add_subplot(gs[0, 0])
    axes = [first] + [fig.add_subplot(gs[r, c], sharex=first) for r, c in ((1, 0), (2, 0), (0, 1), (1, 1), (2, 1))]
    ax_motors = fig.add_subplot(gs[3, :], sharex=first)
    rows = (
        ("alt_m", "altitude, m", False),
        ("roll_deg", "roll, deg", False),
        ("pitch_deg", "pitch, deg", False),
        ("n_m", "north, m", False),
        ("e_m", "east, m", False),
        ("yaw_deg", "yaw, deg", True),
    )
    for ax, (key, label, wrap) in zip(axes, rows):
        _plot_quantity(ax, data, key, label, wrap)
        _mark_modes(ax, data, labels=ax is first)
    _plot_motors(ax_motors, data)
    _mark_modes(ax_motors, data, labels=False)
    _legend(first)
    ax_motors.set_xlabel("simulated time, s")
    truth = f"; truth: {data.truth_source}" if data.truth is not None else ""
    fig.suptitle(f"{data.name}: setpoint vs estimate ({data.source}{truth})", fontsize=10)
    return fig


_BUILDERS = {
    "overview": _fig_overview,
    "altitude": _fig_altitude,
    "attitude": _fig_attitude,
    "position": _fig_position,
    "errors": _fig_errors,
    "motors": _fig_motors,
    "landing": fig_landing,  # only for a flight with a precision landing on the UGV
}


def write_figures(data: FlightData, out_dir: Path, dpi: int = 100) -> list[Path]:
    """Write every figure of :data:`FIGURES` (and ``landing`` after a precision landing on the UGV) as
    ``out_dir/<name>.png``; return the paths."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    names = FIGURES + (("landing",) if has_landing(data) else ())
    for name in names:
        fig = _BUILDERS[name](plt, data)
        try:
            fig.tight_layout()
            path = out_dir / f"{name}.png"
            fig.savefig(path, dpi=dpi)
            paths.append(path)
        finally:
            plt.close(fig)
    return paths


# --------------------------------------------------------------------------- command


def add_arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("log", metavar="LOG", help="a .ulg or .tlog flight log, or a directory (its newest flight)")
    p.add_argument("--out", metavar="DIR", default=None, help="where to write the PNGs (default <log>_plots)")
    p.add_argument(
        "--truth",
        metavar="FILE",
        default=None,
        help="the simulator's .truth.npy of the flight (default: found beside the log)",
    )
    p.add_argument("--no-truth", action="store_true", help="do not look for the simulator's log")
    p.add_argument("--dpi", type=positive_int, default=100, help="resolution of the PNGs (default 100)")


def run(args: argparse.Namespace) -> int:
    """``gcs plot``: 0 on success, 1 if the log cannot be read."""
    try:
        log = resolve_log(Path(args.log))
        data = load(log, Path(args.truth) if args.truth else None, find=not args.no_truth)
        out = Path(args.out) if args.out else log.parent / (log_stem(log) + "_plots")
        paths = write_figures(data, out, args.dpi)
    except FlightLogError as exc:
        print(f"gcs plot: {exc}", file=sys.stderr)
        return 1
    except (OSError, KeyError, ValueError) as exc:
        print(f"gcs plot: cannot read {args.log}: {exc!r}", file=sys.stderr)
        return 1
    truth = f", ground truth from {data.truth_source}" if data.truth is not None else ", no ground truth"
    print(f"{log.name}: {data.source}{truth}")
    for p in paths:
        print(f"wrote {p}")
    return 0
