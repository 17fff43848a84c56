"""``gcs plot``'s landing figure: a precision landing on the UGV, from the flight controller's log
and the simulator's truth.

Top view (north up, east right, metres from the multicopter's start) of both tracks with the
touchdown marked; below, against simulated time, the horizontal distance from the multicopter to
the marker (the truth, and the flight controller's own estimate from its camera fixes) and the
precision landing's phase.  Drawn only when the flight had a precision landing (the
``precland_phase`` column) and the truth log holds the UGV (``ugv_*`` columns).
"""

from __future__ import annotations

import numpy as np

from .flight_logs import FlightData

PHASES = ("none", "preparation", "tracking", "approaching", "docking", "search", "fallback", "done")


def has_landing(data: FlightData) -> bool:
    return data.landing is not None and data.truth is not None and "ugv_n_m" in data.truth.cols


def fig_landing(plt, data: FlightData):
    """The landing figure (see the module docstring); call only when :func:`has_landing`."""
    assert data.landing is not None and data.truth is not None
    tr, ld = data.truth, data.landing
    fig = plt.figure(figsize=(13, 8))
    gs = fig.add_gridspec(2, 2, width_ratios=(1.1, 1.4))
    top = fig.add_subplot(gs[:, 0])
    err_ax = fig.add_subplot(gs[0, 1])
    ph_ax = fig.add_subplot(gs[1, 1], sharex=err_ax)
    t0, t1 = float(ld.t_s[0]), float(ld.t_s[-1])
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
    ph_ax.set_xlabel("simulated time, s")
    ph_ax.grid(alpha=0.3)
    fig.suptitle(f"{data.name}: precision landing on the UGV", fontsize=10)
    return fig
