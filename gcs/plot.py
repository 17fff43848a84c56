"""``gcs plot LOG``: PNG figures of a flight, setpoint against estimate (and ground truth).

Like seed 000's tuning plots (errors in altitude, roll and pitch over time), from
either log of a flight:

* the flight controller's control-rate log (``*.fc.npy``, :mod:`autopilot.flight_log`):
  setpoints, estimates and motor commands at 250 Hz;
* a telemetry log (``*.tlog``, any ground station's or the flight controller's own):
  ATTITUDE against ATTITUDE_TARGET, LOCAL_POSITION_NED against
  POSITION_TARGET_LOCAL_NED, SERVO_OUTPUT_RAW or ACTUATOR_OUTPUT_STATUS for the motors;
* a directory: its newest ``*.fc.npy`` (else ``*.tlog``).

Ground truth comes from the simulator's log of the same flight (``sitl --log-dir``,
``*.truth.npy``): given with ``--truth``, or found beside the log (same name, or the
same instance, a name time within two minutes and an overlapping time range).

Figures written to ``--out`` (default ``<log dir>/<log name>_plots``): ``overview.png``
(all of it on one page), ``altitude.png``, ``attitude.png`` (roll, pitch, yaw),
``position.png`` (north, east, track), ``errors.png`` (setpoint - estimate, and
estimate - truth) and ``motors.png``.  Time is simulated seconds (the vehicle's
clock).  Positions are metres in the estimator's frame (origin: the first GPS fix);
the truth's origin is the start point on the ground (horizontally a few centimetres
away; its altitude is shown above its value at arming, as the estimator's is).
"""

from __future__ import annotations

import argparse
import re
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

FIGURES = ("overview", "altitude", "attitude", "position", "errors", "motors")
FC_SUFFIX, TRUTH_SUFFIX, TLOG_SUFFIX = ".fc.npy", ".truth.npy", ".tlog"
VEHICLE_SYSID, VEHICLE_COMPID = 1, 1
MAX_GAP_S = 1.0  # samples further apart than this are not joined by a line
TRUTH_MATCH_S = 120.0  # a truth log's name time within this of the log's (wall clock at arming)

COLORS = {"setpoint": "tab:red", "estimate": "tab:blue", "truth": "k"}
STYLES = {"setpoint": dict(lw=1.2, ls="--"), "estimate": dict(lw=1.0), "truth": dict(lw=0.8, alpha=0.7)}


class PlotError(Exception):
    """The log cannot be read or plotted (the message says why)."""


# --------------------------------------------------------------------------- data


@dataclass
class Series:
    """One source of one group of quantities, sampled at ``t_s`` (simulated seconds)."""

    t_s: np.ndarray
    cols: dict[str, np.ndarray]


@dataclass
class FlightData:
    """What the figures show; any source may be missing."""

    name: str
    setpoint: Series | None = None  # alt_m, n_m, e_m, roll_deg, pitch_deg, yaw_deg (NaN where none)
    estimate: Series | None = None
    truth: Series | None = None
    motors: Series | None = None  # motor_0 ... (0..1)
    modes: list[tuple[float, str]] = field(default_factory=list)  # (time, mode name) at each change
    source: str = ""
    truth_source: str = ""


def quat_to_euler_deg(w, x, y, z) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Roll, pitch, yaw in degrees (ZYX) of quaternion arrays (w, x, y, z), NaN stays NaN."""
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1.0, 1.0))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.degrees(roll), np.degrees(pitch), np.degrees(yaw)


def _mode_changes(t_s: np.ndarray, main: np.ndarray, sub: np.ndarray) -> list[tuple[float, str]]:
    from mavsim_core.px4_modes import custom_mode_to_name, encode_custom_mode

    out: list[tuple[float, str]] = []
    last = None
    for t, m, s in zip(t_s, main.astype(int), sub.astype(int)):
        if (m, s) != last:
            last = (m, s)
            out.append((float(t), custom_mode_to_name(encode_custom_mode(int(m), int(s)))))
    return out


def load_fc_log(path: Path) -> FlightData:
    from mavsim_core.npy_log import read_npy_log

    a = read_npy_log(path)
    if a.size == 0:
        raise PlotError(f"{path}: the log holds no rows")
    t = a["time_us"] / 1e6
    f = lambda name: a[name].astype(float)  # noqa: E731
    roll_sp, pitch_sp, yaw_sp = quat_to_euler_deg(f("q_sp_w"), f("q_sp_x"), f("q_sp_y"), f("q_sp_z"))
    roll, pitch, yaw = quat_to_euler_deg(f("q_w"), f("q_x"), f("q_y"), f("q_z"))
    motors = sorted((n for n in a.dtype.names if n.startswith("motor_")), key=lambda n: int(n.split("_")[1]))
    return FlightData(
        name=path.name,
        setpoint=Series(t, dict(alt_m=-f("pos_sp_d_m"), n_m=f("pos_sp_n_m"), e_m=f("pos_sp_e_m"),
                                roll_deg=roll_sp, pitch_deg=pitch_sp, yaw_deg=yaw_sp)),
        estimate=Series(t, dict(alt_m=-f("pos_d_m"), n_m=f("pos_n_m"), e_m=f("pos_e_m"),
                                roll_deg=roll, pitch_deg=pitch, yaw_deg=yaw)),
        motors=Series(t, {n: f(n) for n in motors}) if motors else None,
        modes=_mode_changes(t, a["main_mode"], a["sub_mode"]),
        source="flight controller log (250 Hz)",
    )


def load_truth_log(path: Path) -> Series:
    """The simulator's truth; altitude above its first sample (the vehicle on the ground at arming).

    The simulator's height is that of the centre of mass above the ground plane; the
    estimator's origin is the vehicle as it stood at the first GPS fix, so both start at 0.
    """
    from mavsim_core.npy_log import read_npy_log

    a = read_npy_log(path)
    if a.size == 0:
        raise PlotError(f"{path}: the truth log holds no rows")
    f = lambda name: a[name].astype(float)  # noqa: E731
    alt = -f("pos_d_m")
    return Series(a["time_us"] / 1e6, dict(alt_m=alt - alt[0], n_m=f("pos_n_m"), e_m=f("pos_e_m"),
                                           roll_deg=np.degrees(f("roll_rad")), pitch_deg=np.degrees(f("pitch_rad")),
                                           yaw_deg=np.degrees(f("yaw_rad"))))


class _Rows:
    """Rows of one message type from a tlog, de-duplicated by vehicle time."""

    def __init__(self) -> None:
        self.t: list[float] = []
        self.rows: list[tuple[float, ...]] = []
        self._seen: set[int] = set()

    def add(self, key: int, t_s: float, row: tuple[float, ...]) -> None:
        if key in self._seen:  # the same message on both UDP endpoints
            return
        self._seen.add(key)
        self.t.append(t_s)
        self.rows.append(row)

    def arrays(self) -> tuple[np.ndarray, np.ndarray] | None:
        if not self.t:
            return None
        order = np.argsort(self.t, kind="stable")
        return np.asarray(self.t)[order], np.asarray(self.rows, dtype=float)[order]


def load_tlog(path: Path) -> FlightData:
    from pymavlink import mavutil

    kinds = ("ATTITUDE", "ATTITUDE_TARGET", "LOCAL_POSITION_NED", "POSITION_TARGET_LOCAL_NED",
             "SERVO_OUTPUT_RAW", "ACTUATOR_OUTPUT_STATUS", "HEARTBEAT")
    rows = {k: _Rows() for k in kinds}
    last_boot_s = None
    try:
        conn = mavutil.mavlink_connection(str(path), robust_parsing=True)
    except Exception as exc:
        raise PlotError(f"{path}: cannot open as a tlog: {exc}") from exc
    n_motors = 0
    try:
        while True:
            m = conn.recv_match(type=list(kinds))
            if m is None:
                break
            if m.get_srcSystem() != VEHICLE_SYSID or m.get_srcComponent() != VEHICLE_COMPID:
                continue
            k = m.get_type()
            if k == "ATTITUDE":
                t = m.time_boot_ms / 1e3
                rows[k].add(m.time_boot_ms, t, (m.roll, m.pitch, m.yaw))
            elif k == "ATTITUDE_TARGET":
                t = m.time_boot_ms / 1e3
                rows[k].add(m.time_boot_ms, t, tuple(m.q))
            elif k == "LOCAL_POSITION_NED":
                t = m.time_boot_ms / 1e3
                rows[k].add(m.time_boot_ms, t, (m.x, m.y, m.z))
            elif k == "POSITION_TARGET_LOCAL_NED":
                t = m.time_boot_ms / 1e3
                mask = m.type_mask
                xyz = tuple(np.nan if mask & bit else v for v, bit in ((m.x, 1), (m.y, 2), (m.z, 4)))
                rows[k].add(m.time_boot_ms, t, xyz)
            elif k == "SERVO_OUTPUT_RAW":
                t = m.time_usec / 1e6
                raw = [getattr(m, f"servo{i}_raw", 0) for i in range(1, 17)]
                used = [r for r in raw if r > 0]
                n_motors = max(n_motors, len(used))
                rows[k].add(m.time_usec, t, tuple(raw))
            elif k == "ACTUATOR_OUTPUT_STATUS":
                t = m.time_usec / 1e6
                n_motors = max(n_motors, bin(m.active).count("1"))
                rows[k].add(m.time_usec, t, tuple(m.actuator[:16]))
            elif k == "HEARTBEAT":
                if last_boot_s is not None:
                    rows[k].add(int(last_boot_s * 1e3), last_boot_s, (m.custom_mode,))
            if k != "HEARTBEAT":
                last_boot_s = t
    finally:
        conn.close()

    data = FlightData(name=path.name, source="telemetry log")
    att, att_sp = rows["ATTITUDE"].arrays(), rows["ATTITUDE_TARGET"].arrays()
    pos, pos_sp = rows["LOCAL_POSITION_NED"].arrays(), rows["POSITION_TARGET_LOCAL_NED"].arrays()
    if att is None and pos is None:
        raise PlotError(f"{path}: no ATTITUDE or LOCAL_POSITION_NED from system {VEHICLE_SYSID} in this tlog")
    data.estimate = _merge(att, pos, euler=True)
    if att_sp is not None:
        q = att_sp[1]
        att_sp = (att_sp[0], np.column_stack(quat_to_euler_deg(q[:, 0], q[:, 1], q[:, 2], q[:, 3])))
    data.setpoint = _merge(att_sp, pos_sp, euler=False)
    servo, act = rows["SERVO_OUTPUT_RAW"].arrays(), rows["ACTUATOR_OUTPUT_STATUS"].arrays()
    if servo is not None and n_motors:
        values = np.clip((servo[1][:, :n_motors] - 1000.0) / 1000.0, 0.0, 1.0)
        data.motors = Series(servo[0], {f"motor_{i}": values[:, i] for i in range(n_motors)})
    elif act is not None and n_motors:
        data.motors = Series(act[0], {f"motor_{i}": act[1][:, i] for i in range(n_motors)})
    hb = rows["HEARTBEAT"].arrays()
    if hb is not None:
        cm = hb[1][:, 0].astype(np.int64)
        data.modes = _mode_changes(hb[0], (cm >> 16) & 0xFF, (cm >> 24) & 0xFF)
    return data


def _merge(att, pos, euler: bool) -> Series | None:
    """Attitude rows (radians, or degrees already) and position rows on one time base (union, NaN gaps)."""
    if att is None and pos is None:
        return None
    t = np.union1d(att[0] if att is not None else [], pos[0] if pos is not None else [])
    cols = {}

    def place(src, values):
        out = np.full(t.shape, np.nan)
        out[np.searchsorted(t, src)] = values
        return out

    if att is not None:
        vals = np.degrees(att[1]) if euler else att[1]
        for i, name in enumerate(("roll_deg", "pitch_deg", "yaw_deg")):
            cols[name] = place(att[0], vals[:, i])
    if pos is not None:
        cols["n_m"] = place(pos[0], pos[1][:, 0])
        cols["e_m"] = place(pos[0], pos[1][:, 1])
        cols["alt_m"] = place(pos[0], -pos[1][:, 2])
    return Series(t, cols)


# --------------------------------------------------------------------------- finding logs

_STEM = re.compile(r"^(\d{4}-\d{2}-\d{2}_\d{2}-\d{2}-\d{2})(?:_i(\d+))?(?:_\d+)?$")


def _stem(path: Path) -> str:
    name = path.name
    for sfx in (FC_SUFFIX, TRUTH_SUFFIX, TLOG_SUFFIX):
        if name.endswith(sfx):
            return name[: -len(sfx)]
    return path.stem


def _stem_time_instance(stem: str) -> tuple[float, int] | None:
    m = _STEM.match(stem)
    if not m:
        return None
    return time.mktime(time.strptime(m.group(1), "%Y-%m-%d_%H-%M-%S")), int(m.group(2) or 0)


def find_truth(log: Path, t_range_s: tuple[float, float]) -> Path | None:
    """The simulator's log of the same flight beside ``log``, or None."""
    same = log.parent / (_stem(log) + TRUTH_SUFFIX)
    if same.exists():
        return same
    me = _stem_time_instance(_stem(log))
    if me is None:
        return None
    from mavsim_core.npy_log import read_npy_log

    best: tuple[float, Path] | None = None
    for cand in log.parent.glob("*" + TRUTH_SUFFIX):
        other = _stem_time_instance(_stem(cand))
        if other is None or other[1] != me[1] or abs(other[0] - me[0]) > TRUTH_MATCH_S:
            continue
        try:
            t = read_npy_log(cand)["time_us"]
        except Exception:
            continue
        if t.size == 0 or t[-1] / 1e6 < t_range_s[0] or t[0] / 1e6 > t_range_s[1]:
            continue
        score = abs(other[0] - me[0])
        if best is None or score < best[0]:
            best = (score, cand)
    return best[1] if best else None


def resolve_log(path: Path) -> Path:
    """A log file: ``path`` itself, or the newest flight log in the directory ``path``."""
    if path.is_dir():
        for pattern in ("*" + FC_SUFFIX, "*" + TLOG_SUFFIX):
            found = sorted(path.glob(pattern), key=lambda p: p.stat().st_mtime)
            if found:
                return found[-1]
        raise PlotError(f"{path}: no *{FC_SUFFIX} or *{TLOG_SUFFIX} flight log in this directory")
    if not path.exists():
        raise PlotError(f"{path}: no such file")
    return path


def load(log: Path, truth: Path | None = None, find: bool = True) -> FlightData:
    """Read a flight controller log or a tlog, and the ground truth if given or found."""
    if log.name.endswith(FC_SUFFIX):
        data = load_fc_log(log)
    elif log.name.endswith(TRUTH_SUFFIX):
        raise PlotError(f"{log}: this is the simulator's truth log; give the flight's .fc.npy or .tlog "
                        "(the truth log is found beside it, or pass --truth)")
    else:
        data = load_tlog(log)
    series = [s for s in (data.estimate, data.setpoint) if s is not None and s.t_s.size]
    if truth is None and find and series:
        t_range = (min(float(s.t_s[0]) for s in series), max(float(s.t_s[-1]) for s in series))
        truth = find_truth(log, t_range)
    if truth is not None:
        data.truth = load_truth_log(truth)
        data.truth_source = truth.name
        if series:  # only the flight's time span
            lo, hi = min(float(s.t_s[0]) for s in series), max(float(s.t_s[-1]) for s in series)
            keep = (data.truth.t_s >= lo) & (data.truth.t_s <= hi)
            data.truth = Series(data.truth.t_s[keep], {k: v[keep] for k, v in data.truth.cols.items()})
    return data


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
            ax.text(t, 1.0, " " + name, transform=ax.get_xaxis_transform(), fontsize=7, rotation=90,
                    va="top", ha="left", color="0.35")


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
    near = np.minimum(np.abs(ta[idx] - tb), np.abs(ta[idx - 1] - tb)) <= 0.25
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
    for ax, (key, label) in zip(axes, (("roll_deg", "roll, deg"), ("pitch_deg", "pitch, deg"),
                                       ("yaw_deg", "yaw, deg"))):
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
    rows = (("alt_m", "altitude, m", False), ("roll_deg", "roll, deg", False), ("pitch_deg", "pitch, deg", False),
            ("yaw_deg", "yaw, deg", True), ("n_m", "north, m", False))
    for ax, (key, label, wrap) in zip(axes, rows):
        _error_panel(ax, data, key, label + " error", wrap)
        _mark_modes(ax, data, labels=False)
    axes[0].set_title("Errors (seed 000 style): setpoint - estimate" +
                      (", estimate - truth" if data.truth is not None else ""))
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
    rows = (("alt_m", "altitude, m", False), ("roll_deg", "roll, deg", False), ("pitch_deg", "pitch, deg", False),
            ("n_m", "north, m", False), ("e_m", "east, m", False), ("yaw_deg", "yaw, deg", True))
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


_BUILDERS = {"overview": _fig_overview, "altitude": _fig_altitude, "attitude": _fig_attitude,
             "position": _fig_position, "errors": _fig_errors, "motors": _fig_motors}


def write_figures(data: FlightData, out_dir: Path, dpi: int = 100) -> list[Path]:
    """Write every figure of :data:`FIGURES` as ``out_dir/<name>.png``; return the paths."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    out_dir.mkdir(parents=True, exist_ok=True)
    paths = []
    for name in FIGURES:
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
    p.add_argument("log", metavar="LOG", help="a .fc.npy or .tlog flight log, or a directory (its newest flight)")
    p.add_argument("--out", metavar="DIR", default=None, help="where to write the PNGs (default <log>_plots)")
    p.add_argument("--truth", metavar="FILE", default=None,
                   help="the simulator's .truth.npy of the flight (default: found beside the log)")
    p.add_argument("--no-truth", action="store_true", help="do not look for the simulator's log")
    p.add_argument("--dpi", type=int, default=100, help="resolution of the PNGs (default 100)")


def run(args: argparse.Namespace) -> int:
    """``gcs plot``: 0 on success, 1 if the log cannot be read."""
    try:
        log = resolve_log(Path(args.log))
        data = load(log, Path(args.truth) if args.truth else None, find=not args.no_truth)
        out = Path(args.out) if args.out else log.parent / (_stem(log) + "_plots")
        paths = write_figures(data, out, args.dpi)
    except PlotError as exc:
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
