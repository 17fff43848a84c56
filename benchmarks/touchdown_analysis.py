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
  (m/s) over the tracking, approaching and docking phases of the last 4 s;
- ``offset``: where the centre's offset from the deck's centre came from, the mean over the last OFFSET_WINDOW_S
  before the cut (cm, forward and right in the UGV's frame), in three parts that add up to the truth's offset
  (vehicle minus deck): ``aim``, the flight controller's setpoint off its target estimate (the cut's lead,
  ``PLD_CUT_LEAD``, on purpose); ``track``, its vehicle estimate off that setpoint (the position loop's error);
  ``est``, its estimate of the target relative to the vehicle against the truth's (the vision and the target
  model; a shift of the estimator's whole frame cancels out).

and one summary line per campaign cell: landings, successes, mean tilt at contact, mean |slide|, mean deck
velocity error, the mean offset's three parts.  Frames: NED from the multicopter's start point; the deck frame
is the UGV's (x forward, y right).  It reads only what ``sitl/truth_log.py`` and ``autopilot/ulog_topics.py``
write (the ULog through ``gcs.flight_logs``, pyulog: its precision_landing, landing_target_pose,
trajectory_setpoint and vehicle_local_position topics, at 50 Hz).

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
OFFSET_WINDOW_S = 1.5  # the offset's parts are averaged over this long before the cut (about the docking)
OFFSET_STEP_S = 0.05


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


def _landing(flight) -> dict[str, np.ndarray]:
    """The precision landing's samples of the flight controller's ULog (none without a precision landing)."""
    landing = flight.landing
    if landing is None:
        return {k: np.zeros(0) for k in ("time_us", "precland_phase", "tgt_vn_m_s", "tgt_ve_m_s")}
    return dict(landing.cols, time_us=np.round(landing.t_s * 1e6).astype(np.int64))


def _at(series, col: str, t_s: np.ndarray) -> np.ndarray:
    """A column of a log's series at the times ``t_s`` (linear between its samples that are numbers)."""
    ok = np.isfinite(series.cols[col])
    return np.interp(t_s, series.t_s[ok], series.cols[col][ok]) if ok.any() else np.full(t_s.shape, np.nan)


def offset_parts(flight, truth: np.ndarray, cut: int) -> dict[str, float]:
    """The truth's offset (vehicle minus deck) over the last OFFSET_WINDOW_S before the cut as aim + track + est
    (see the module docstring), each the mean of its forward and right parts in the UGV's frame, cm."""
    out = {f"{p}_{a}_cm": math.nan for p in ("aim", "track", "est") for a in ("fwd", "right")}
    sp, est, land = flight.setpoint, flight.estimate, flight.landing
    if sp is None or est is None or land is None or "n_m" not in sp.cols or "n_m" not in est.cols:
        return out
    t_cut = float(truth["time_us"][cut]) * 1e-6
    t_s = np.arange(t_cut - OFFSET_WINDOW_S, t_cut + 1e-9, OFFSET_STEP_S)
    idx = np.minimum(np.searchsorted(truth["time_us"] * 1e-6, t_s), len(truth) - 1)
    veh = np.column_stack([_at(est, "n_m", t_s), _at(est, "e_m", t_s)])
    set_ = np.column_stack([_at(sp, "n_m", t_s), _at(sp, "e_m", t_s)])
    rel = np.column_stack([_at(land, "tgt_n_m", t_s), _at(land, "tgt_e_m", t_s)])  # target minus vehicle, estimated
    true_rel = np.column_stack(
        [truth["ugv_n_m"][idx] - truth["pos_n_m"][idx], truth["ugv_e_m"][idx] - truth["pos_e_m"][idx]]
    )
    yaw = truth["ugv_yaw_rad"][idx]
    c, s = np.cos(yaw), np.sin(yaw)
    for name, v in (("aim", set_ - (veh + rel)), ("track", veh - set_), ("est", rel - true_rel)):
        fwd, right = c * v[:, 0] + s * v[:, 1], -s * v[:, 0] + c * v[:, 1]
        ok = np.isfinite(fwd) & np.isfinite(right)
        if ok.any():
            out[f"{name}_fwd_cm"], out[f"{name}_right_cm"] = 100.0 * fwd[ok].mean(), 100.0 * right[ok].mean()
    return out


def analyse(run_dir: Path, legs: tuple) -> dict | None:
    """One landing's figures (see the module docstring); None without its logs or a cut."""
    truth, ulogs = _one(run_dir, ".truth.npy"), sorted(run_dir.glob("*.ulg"))
    if truth is None or not ulogs or "ugv_n_m" not in (truth.dtype.names or ()):
        return None
    flight = load_ulog(ulogs[0])
    fc = _landing(flight)
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
        **offset_parts(flight, truth, cut),
    }


def _parts(a: dict) -> str:
    return "  ".join(f"({a[f'{p}_fwd_cm']:+5.1f}, {a[f'{p}_right_cm']:+5.1f})" for p in ("aim", "track", "est"))


def main(argv: list[str] | None = None) -> int:
    ap = parser(__doc__, progress=False)
    ap.add_argument("results", type=Path, help="the campaign's results CSV")
    ap.add_argument("logdir", type=Path, help="the directory given to campaign run --keep-logs")
    args = ap.parse_args(argv)
    rows = list(csv.DictReader(args.results.open()))
    cells: dict[str, list[tuple[dict, dict]]] = {}
    legs_of: dict[str, tuple] = {}
    print(
        "run            ok  tilt  descent  cut: height  fwd  right  slide (fwd, right)  deck v err mean/max"
        "  offset (fwd, right): aim  track  est  reason"
    )
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
            f"   {a['vel_err_mean']:.3f} / {a['vel_err_max']:.3f}   {_parts(a)}   {row['reason'][:50]}"
        )
    for label, items in cells.items():
        ok = sum(r["success"] == "True" for r, _ in items)
        mean = lambda key: statistics.fmean(a[key] for _, a in items if math.isfinite(a[key]))  # noqa: E731
        print(
            f"{label}: {ok}/{len(items)} landed; at the first contact {mean('tilt_deg'):.1f} deg of tilt, "
            f"{mean('descent_m_s'):.2f} m/s down; motors cut {mean('cut_height_cm'):.1f} cm above the rest height; "
            f"slide after the cut {mean('slide_cm'):.1f} cm; deck velocity error {mean('vel_err_mean'):.3f} m/s; "
            f"offset (fwd, right) aim ({mean('aim_fwd_cm'):+.1f}, {mean('aim_right_cm'):+.1f}), "
            f"track ({mean('track_fwd_cm'):+.1f}, {mean('track_right_cm'):+.1f}), "
            f"est ({mean('est_fwd_cm'):+.1f}, {mean('est_right_cm'):+.1f}) cm"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
