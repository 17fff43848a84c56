"""``gcs plot``'s landing figure: a precision landing on the UGV, from the flight controller's log
and the simulator's truth.

Top view (north up, east right, metres from the multicopter's start) of both tracks with the
touchdown marked; below, against simulated time, the horizontal distance from the multicopter to
the marker (the truth, and the flight controller's own estimate from its camera fixes) and the
precision landing's phase.  Drawn only when the flight had a precision landing (the
``precland_phase`` column) and the truth log holds the UGV (``ugv_*`` columns).  When the simulator
logged the camera's frames beside the truth (:mod:`gcs.frame_log`), two more panels on the same time
axis: the gimbal's joint angles (roll, pitch, yaw, degrees, at each frame's capture) and which of the
pad's markers the detector used (one row per marker id, a dot per frame; a grey row for the frames in
which it used none).  A flight logged without them is drawn as before.
"""

from __future__ import annotations

import numpy as np

from .flight_logs import FlightData, Series
from .frame_log import GIMBAL_COLUMNS, frames_using, marker_ids

PHASES = ("none", "preparation", "tracking", "approaching", "docking", "search", "fallback", "done", "touchdown")


def has_landing(data: FlightData) -> bool:
    return data.landing is not None and data.truth is not None and "ugv_n_m" in data.truth.cols


def fig_landing(plt, data: FlightData):
    """The landing figure (see the module docstring); call only when :func:`has_landing`."""
    assert data.landing is not None and data.truth is not None
    tr, ld = data.truth, data.landing
    t0, t1 = float(ld.t_s[0]), float(ld.t_s[-1])
    frames = _frames_in(data.frames, t0, t1 + 6.0)
    rows = 2 if frames is None else 4
    fig = plt.figure(figsize=(13, 8 if frames is None else 12))
    gs = fig.add_gridspec(rows, 2, width_ratios=(1.1, 1.4))
    top = fig.add_subplot(gs[:, 0])
    err_ax = fig.add_subplot(gs[0, 1])
    ph_ax = fig.add_subplot(gs[1, 1], sharex=err_ax)
    sel = (tr.t_s >= t0) & (tr.t_s <= t1 + 6.0)
    vn, ve = tr.cols["n_m"][sel], tr.cols["e_m"][sel]
    un, ue = tr.cols["ugv_n_m"][sel], tr.cols["ugv_e_m"][sel]
    top.plot(ue, un, color="C1", lw=2.5, alpha=0.7, label="UGV (marker centre)")
    top.plot(ve, vn, color="C0", lw=1.2, label="multicopter")
    armed = tr.cols["armed"][sel] > 0
    cut = np.flatnonzero(armed[:-1] & ~armed[1:])
    if cut.size:
        k = cut[0] + 1
        top.plot(ve[k], vn[k], "kx", ms=10, mew=2, label="motors cut (touchdown)")
        err_at = float(np.hypot(vn[k] - un[k], ve[k] - ue[k]))
        top.set_title(f"top view; {100 * err_at:.1f} cm from the marker when the motors were cut", fontsize=10)
    top.set_xlabel("east, m")
    top.set_ylabel("north, m")
    top.set_aspect("equal", adjustable="datalim")
    top.grid(alpha=0.3)
    top.legend(fontsize=8, loc="best")
    ts = tr.t_s[sel]
    err_ax.plot(ts, np.hypot(vn - un, ve - ue), color="k", lw=1.2, label="truth")
    err_ax.plot(ld.t_s, np.hypot(ld.cols["tgt_n_m"], ld.cols["tgt_e_m"]), color="C2", lw=1, label="flight controller")
    err_ax.set_ylabel("horizontal distance\nto the marker, m")
    err_ax.set_yscale("log")
    err_ax.grid(alpha=0.3, which="both")
    err_ax.legend(fontsize=8)
    ph_ax.step(ld.t_s, ld.cols["precland_phase"], where="post", color="C3")
    ph_ax.set_yticks(range(len(PHASES)), PHASES, fontsize=8)
    ph_ax.set_ylabel("phase")
    ph_ax.grid(alpha=0.3)
    last = ph_ax
    if frames is not None:
        _gimbal_panel(fig.add_subplot(gs[2, 1], sharex=err_ax), frames)
        last = fig.add_subplot(gs[3, 1], sharex=err_ax)
        _markers_panel(last, frames)
    last.set_xlabel("simulated time, s")
    fig.suptitle(f"{data.name}: precision landing on the UGV", fontsize=10)
    return fig


def _frames_in(frames: Series | None, lo: float, hi: float) -> Series | None:
    """The camera frames captured from ``lo`` to ``hi`` (s); None when there are none."""
    if frames is None:
        return None
    keep = (frames.t_s >= lo) & (frames.t_s <= hi)
    return Series(frames.t_s[keep], {k: v[keep] for k, v in frames.cols.items()}) if keep.any() else None


def _gimbal_panel(ax, frames: Series) -> None:
    """The gimbal's joint angles at each frame's capture (degrees); a note instead for a fixed camera."""
    ax.set_ylabel("gimbal joint\nangle, deg")
    ax.grid(alpha=0.3)
    if not any(np.isfinite(frames.cols[k]).any() for k in GIMBAL_COLUMNS):
        ax.text(0.5, 0.5, "fixed camera (no gimbal)", transform=ax.transAxes, ha="center", va="center")
        return
    for k, color in zip(GIMBAL_COLUMNS, ("C0", "C1", "C2")):
        ax.plot(frames.t_s, frames.cols[k], color=color, lw=1.0, label=k.split("_")[1])
    ax.legend(fontsize=8, loc="best")


def _markers_panel(ax, frames: Series) -> None:
    """Which markers the detector used in each frame: one row per marker id, a grey row for the frames with none
    (rendered: dots; not rendered, the pad wholly out of view: crosses)."""
    ids = marker_ids(frames.cols)
    for row, marker_id in enumerate(ids, start=1):
        used = frames_using(frames.cols, int(marker_id))
        ax.plot(frames.t_s[used], np.full(int(used.sum()), row), "|", color=f"C{row % 10}", ms=8)
    none = frames.cols["n_markers"] == 0
    rendered = frames.cols["rendered"] > 0
    ax.plot(frames.t_s[none & rendered], np.zeros(int((none & rendered).sum())), ".", color="0.6", ms=3)
    ax.plot(frames.t_s[none & ~rendered], np.zeros(int((none & ~rendered).sum())), "x", color="0.6", ms=3)
    ax.set_yticks(range(len(ids) + 1), ["none", *(f"id {i}" for i in ids)], fontsize=8)
    ax.set_ylim(-0.6, len(ids) + 0.6)
    ax.set_ylabel("markers used")
    ax.grid(alpha=0.3, axis="x")
