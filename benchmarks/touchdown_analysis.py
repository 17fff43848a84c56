"""Benchmark: what happened in the last second of each landing of a campaign, from its kept logs.

Reads a landing campaign's results CSV and the logs it kept (``campaign run FILE --keep-logs DIR``: one
``DIR/<run id>/logs/`` per landing with the simulator's ``.truth.npy`` and the flight controller's ``.ulg``)
and prints, per landing, from the simulator's truth:

- ``contact``: the first foot's touch on the deck (the lowest foot within 5 mm of the deck's top; the feet from
  the vehicle file's legs at the truth attitude, ``gcs.launcher.deck_stance.feet_ned``): the vehicle's tilt
  (deg) and its descent speed (m/s) then;
- ``cut``: the motors' stop (the last armed sample): the feet's height above the deck measured at the
  vehicle's centre (cm; 0 when it stands on it), and where its centre was on the deck (``fwd`` / ``right``, cm
  in the UGV's frame);
- ``slide``: how far the centre moved on the deck from the cut to the end of the truth log (1 s later), cm;
- ``deck v err``: the flight controller's estimate of the deck's velocity against the UGV's truth, mean and max
  (m/s) over the tracking, approaching and docking phases of the last 4 s.

and one summary line per campaign cell: landings, successes, mean tilt at contact, mean |slide|, mean deck
velocity error.  Frames: NED from the multicopter's start point; the deck frame is the UGV's (x forward, y
right).  It reads only what ``sitl/truth_log.py`` and ``autopilot/ulog_topics.py`` write (the ULog through
``gcs.flight_logs``, pyulog: its precision_landing topic, at 50 Hz).

Usage: ``python benchmarks/touchdown_analysis.py RESULTS.csv LOGDIR``
"""

from __future__ import annotations

import csv
import math
import statistics
import sys
from pathlib import Path

import numpy as np

from gcs.flight_logs import load_ulog
from gcs.launcher.deck_stance import deck_frame, feet_ned
from mavsim_core import quaternion as quat
from params.vehicle import load_vehicle

from _cli import parser

CONTACT_M = 0.005  # the lowest foot this close to the deck's top: touching
TRACK_PHASES = (2, 3, 4)  # precision_landing.phase in the ULog: tracking, approaching, docking
VEL_WINDOW_US = 4_000_000  # the deck velocity error is taken over the last 4 s before the cut


def _one(path: Path, suffix: str) -> np.ndarray | None:
    found = sorted(path.glob(f"*{suffix}"))
    return np.load(found[0]) if found else None


def _deck_frame(truth: np.ndarray, i: int) -> tuple[float, float]:
    pos, ugv = (truth["pos_n_m"][i], truth["pos_e_m"][i]), (truth["ugv_n_m"][i], truth["ugv_e_m"][i])
    return deck_frame(pos, ugv, float(truth["ugv_yaw_rad"][i]))


def _attitude(truth: np.ndarray, i: int) -> np.ndarray:
    return quat.from_euler(float(truth["roll_rad"][i]), float(truth["pitch_rad"][i]), float(truth["yaw_rad"][i]))


def _lowest_foot_m(truth: np.ndarray, i: int, legs: tuple) -> float:
    pos = np.array([truth["pos_n_m"][i], truth["pos_e_m"][i], truth["pos_d_m"][i]])
    feet = feet_ned(pos, _attitude(truth, i), legs[0], legs[1])
    return float(truth["ugv_d_m"][i] - feet[:, 2].max())


def _landing(ulog: Path) -> dict[str, np.ndarray]:
    """The precision landing's samples in the flight controller's ULog (none without a precision landing)."""
    landing = load_ulog(ulog).landing
    if landing is None:
        return {k: np.zeros(0) for k in ("time_us", "precland_phase", "tgt_vn_m_s", "tgt_ve_m_s")}
    return dict(landing.cols, time_us=np.round(landing.t_s * 1e6).astype(np.int64))


def analyse(run_dir: Path, legs: tuple) -> dict | None:
    """One landing's figures (see the module docstring); None without its logs or a cut."""
    truth, ulogs = _one(run_dir, ".truth.npy"), sorted(run_dir.glob("*.ulg"))
    if truth is None or not ulogs or "ugv_n_m" not in (truth.dtype.names or ()):
        return None
    fc = _landing(ulogs[0])
    armed = np.flatnonzero(truth["armed"] > 0)
    if armed.size == 0 or armed[-1] >= len(truth) - 1:
        return None
    cut = int(armed[-1])
    rest_dz = float(-(truth["pos_d_m"][-1] - truth["ugv_d_m"][-1]))  # centre above the deck 1 s after the cut
    contact = next((i for i in range(max(0, cut - 500), cut + 1) if _lowest_foot_m(truth, i, legs) <= CONTACT_M), cut)
    r = _attitude(truth, contact)
    tilt = math.degrees(math.acos(max(-1.0, min(1.0, float(quat.to_matrix(r)[2, 2])))))
    f0, r0 = _deck_frame(truth, cut)
    f1, r1 = _deck_frame(truth, len(truth) - 1)
    t_cut = int(truth["time_us"][cut])
    win = (
        (fc["time_us"] >= t_cut - VEL_WINDOW_US) & (fc["time_us"] < t_cut) & np.isin(fc["precland_phase"], TRACK_PHASES)
    )
    errs = []
    for k in np.flatnonzero(win):
        j = min(int(np.searchsorted(truth["time_us"], fc["time_us"][k])), len(truth) - 1)
        errs.append(
            math.hypot(fc["tgt_vn_m_s"][k] - truth["ugv_vn_m_s"][j], fc["tgt_ve_m_s"][k] - truth["ugv_ve_m_s"][j])
        )
    errs = [e for e in errs if math.isfinite(e)]
    return {
        "tilt_deg": tilt,
        "descent_m_s": float(truth["vel_d_m_s"][contact]),
        "cut_height_cm": 100.0 * (float(-(truth["pos_d_m"][cut] - truth["ugv_d_m"][cut])) - rest_dz),
        "cut_fwd_cm": 100.0 * f0,
        "cut_right_cm": 100.0 * r0,
        "slide_cm": 100.0 * math.hypot(f1 - f0, r1 - r0),
        "slide_fwd_cm": 100.0 * (f1 - f0),
        "slide_right_cm": 100.0 * (r1 - r0),
        "vel_err_mean": statistics.fmean(errs) if errs else math.nan,
        "vel_err_max": max(errs) if errs else math.nan,
    }


def main(argv: list[str] | None = None) -> int:
    ap = parser(__doc__, progress=False)
    ap.add_argument("results", type=Path, help="the campaign's results CSV")
    ap.add_argument("logdir", type=Path, help="the directory given to campaign run --keep-logs")
    args = ap.parse_args(argv)
    rows = list(csv.DictReader(args.results.open()))
    cells: dict[str, list[tuple[dict, dict]]] = {}
    legs_of: dict[str, tuple] = {}
    print("run            ok  tilt  descent  cut: height  fwd  right  slide (fwd, right)  deck v err mean/max  reason")
    for row in rows:
        vehicle = row.get("vehicle", "quad_x")
        if vehicle not in legs_of:
            spec = load_vehicle(vehicle)
            legs_of[vehicle] = (spec.leg_positions_frd_m, spec.leg_size_m)
        a = analyse(args.logdir / row["run_id"] / "logs", legs_of[vehicle])
        if a is None:
            print(f"{row['run_id']:<14} {row['success'][:1]}   (no logs or no cut) {row['reason'][:50]}")
            continue
        cells.setdefault(row.get("label", row.get("cell", "")), []).append((row, a))
        print(
            f"{row['run_id']:<14} {row['success'][:1]}  {a['tilt_deg']:4.1f}  {a['descent_m_s']:+5.2f}"
            f"   {a['cut_height_cm']:5.1f}  {a['cut_fwd_cm']:+5.1f} {a['cut_right_cm']:+5.1f}"
            f"   {a['slide_cm']:4.1f} ({a['slide_fwd_cm']:+5.1f}, {a['slide_right_cm']:+5.1f})"
            f"   {a['vel_err_mean']:.3f} / {a['vel_err_max']:.3f}   {row['reason'][:50]}"
        )
    for label, items in cells.items():
        ok = sum(r["success"] == "True" for r, _ in items)
        mean = lambda key: statistics.fmean(a[key] for _, a in items if math.isfinite(a[key]))  # noqa: E731
        print(
            f"{label}: {ok}/{len(items)} landed; at the first contact {mean('tilt_deg'):.1f} deg of tilt, "
            f"{mean('descent_m_s'):.2f} m/s down; motors cut {mean('cut_height_cm'):.1f} cm above the rest height; "
            f"slide after the cut {mean('slide_cm'):.1f} cm; deck velocity error {mean('vel_err_mean'):.3f} m/s"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
