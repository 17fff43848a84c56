"""Flight logs read into time series: what ``gcs plot`` (:mod:`gcs.plot`) draws.

Either log of a flight:

* the flight controller's ULog (``*.ulg``, :mod:`autopilot.ulog_topics`), read with pyulog:
  setpoints, estimates, motor commands, modes and the precision landing at the rates PX4's
  topics are logged (attitude 83 Hz, position and motors 50 Hz);
* a telemetry log (``*.tlog``, any ground station's or the flight controller's own):
  ATTITUDE against ATTITUDE_TARGET, LOCAL_POSITION_NED against
  POSITION_TARGET_LOCAL_NED, SERVO_OUTPUT_RAW or ACTUATOR_OUTPUT_STATUS for the motors;
* a directory: its newest ``*.ulg`` (else ``*.tlog``).

Ground truth comes from the simulator's log of the same flight (``sitl --log-dir``,
``*.truth.npy``): given explicitly, or found beside the log (same name, or the
same instance, a name time within two minutes and an overlapping time range).

Every series is on simulated seconds (the vehicle's clock).  Positions are metres
in the estimator's frame (origin: the first GPS fix), altitude up; angles degrees.
The truth's origin is the start point on the ground (horizontally a few centimetres
away; its altitude is taken above its value at arming, as the estimator's is).
Files are read with pyulog (ULogs), pymavlink (tlogs) and the shared core's
:mod:`mavsim_core.npy_log` (the truth); nothing here draws.
"""

from __future__ import annotations

import re
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterable

import numpy as np
from pymavlink import mavutil
from pyulog import ULog

from mavsim_core.npy_log import read_npy_log
from mavsim_core.px4_modes import custom_mode_to_name, decode_custom_mode, encode_custom_mode

from .frame_log import frames_beside

FC_SUFFIX, TRUTH_SUFFIX, TLOG_SUFFIX = ".ulg", ".truth.npy", ".tlog"  # FC: the flight controller's ULog
VEHICLE_COMPID = 1  # the autopilot; its system id (1 + instance) is that of the first such message
TRUTH_MATCH_S = 120.0  # a truth log's name time within this of the log's (wall clock at arming)
TLOG_KINDS = (
    "ATTITUDE",
    "ATTITUDE_TARGET",
    "LOCAL_POSITION_NED",
    "POSITION_TARGET_LOCAL_NED",
    "SERVO_OUTPUT_RAW",
    "ACTUATOR_OUTPUT_STATUS",
    "HEARTBEAT",
)
SERVO_CHANNELS = 16
PWM_MIN_US, PWM_RANGE_US = 1000.0, 1000.0  # SERVO_OUTPUT_RAW: 1000..2000 us is motor 0..1


class FlightLogError(Exception):
    """The log cannot be read (the message says why)."""


@dataclass
class Series:
    """One source of one group of quantities, sampled at ``t_s`` (simulated seconds)."""

    t_s: np.ndarray
    cols: dict[str, np.ndarray]


@dataclass
class FlightData:
    """What one flight's logs hold; any source may be missing."""

    name: str
    setpoint: Series | None = None  # alt_m, n_m, e_m, roll_deg, pitch_deg, yaw_deg (NaN where none)
    estimate: Series | None = None
    truth: Series | None = None
    motors: Series | None = None  # motor_0 ... (0..1)
    modes: list[tuple[float, str]] = field(default_factory=list)  # (time, mode name) at each change
    landing: Series | None = None  # precision landing: tgt_n_m, tgt_e_m (target - vehicle), phase (code)
    frames: Series | None = None  # camera frames beside the truth (gcs/frame_log.py): gimbal angles, markers used
    source: str = ""
    truth_source: str = ""


def quat_to_euler_deg(w, x, y, z) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Roll, pitch, yaw in degrees (ZYX) of quaternion arrays (w, x, y, z), NaN stays NaN."""
    roll = np.arctan2(2 * (w * x + y * z), 1 - 2 * (x * x + y * y))
    pitch = np.arcsin(np.clip(2 * (w * y - z * x), -1.0, 1.0))
    yaw = np.arctan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))
    return np.degrees(roll), np.degrees(pitch), np.degrees(yaw)


def _mode_changes(t_s: np.ndarray, custom_modes: Iterable[int]) -> list[tuple[float, str]]:
    """(time, mode name) at the first sample and at each change of PX4 custom_mode."""
    out: list[tuple[float, str]] = []
    last = None
    for t, cm in zip(t_s, custom_modes):
        if cm != last:
            last = cm
            out.append((float(t), custom_mode_to_name(cm)))
    return out


# --------------------------------------------------------------------------- the flight controller's ULog

ULOG_TOPICS = (
    "vehicle_attitude",
    "vehicle_attitude_setpoint",
    "vehicle_local_position",
    "vehicle_local_position_setpoint",
    "actuator_motors",
    "flight_mode",
    "landing_target_pose",
    "precision_landing",
)


def read_ulog_topics(path: Path, names: Iterable[str] = ULOG_TOPICS) -> dict[str, dict[str, np.ndarray]]:
    """The fields of each of ``names`` (instance 0) in a ULog, read with pyulog: {topic: {field: array}}; a topic
    the file does not hold is left out."""
    try:
        ulog = ULog(str(path), list(names))
    except Exception as exc:
        raise FlightLogError(f"{path}: cannot read as a ULog: {exc}") from exc
    return {d.name: d.data for d in ulog.data_list if d.multi_id == 0}


def _timed(topic: dict[str, np.ndarray] | None, fields: Iterable[str]) -> tuple[np.ndarray, np.ndarray] | None:
    """(times in s, rows of ``fields``) of a topic, or None."""
    if topic is None or topic["timestamp"].size == 0:
        return None
    return topic["timestamp"] / 1e6, np.column_stack([topic[f].astype(float) for f in fields])


def _euler_rows(rows: tuple[np.ndarray, np.ndarray] | None) -> tuple[np.ndarray, np.ndarray] | None:
    """Quaternion rows (w, x, y, z) as roll, pitch, yaw rows in degrees."""
    if rows is None:
        return None
    q = rows[1]
    return rows[0], np.column_stack(quat_to_euler_deg(q[:, 0], q[:, 1], q[:, 2], q[:, 3]))


def load_ulog(path: Path) -> FlightData:
    """The flight controller's ULog (:mod:`autopilot.ulog_topics`): setpoints, estimates, motors, modes and the
    precision landing, each topic at its logging rate."""
    t = read_ulog_topics(path)
    q4 = [f"q[{i}]" for i in range(4)]
    att, pos = _euler_rows(_timed(t.get("vehicle_attitude"), q4)), _timed(t.get("vehicle_local_position"), "xyz")
    if att is None and pos is None:
        raise FlightLogError(f"{path}: no vehicle_attitude or vehicle_local_position in this ULog")
    att_sp = _euler_rows(_timed(t.get("vehicle_attitude_setpoint"), [f"q_d[{i}]" for i in range(4)]))
    data = FlightData(
        name=path.name,
        estimate=_merge(att, pos, euler=False),
        setpoint=_merge(att_sp, _timed(t.get("vehicle_local_position_setpoint"), "xyz"), euler=False),
        source="flight controller ULog",
        landing=_ulog_landing(t),
    )
    motors = t.get("actuator_motors")
    if motors is not None and motors["timestamp"].size:
        cols = [k for k in motors if k.startswith("control[")]
        cols = [k for k in sorted(cols, key=lambda k: int(k[8:-1])) if not np.all(np.isnan(motors[k]))]
        data.motors = Series(
            motors["timestamp"] / 1e6, {f"motor_{i}": motors[k].astype(float) for i, k in enumerate(cols)}
        )
    mode = t.get("flight_mode")
    if mode is not None:
        custom = (encode_custom_mode(int(m), int(s)) for m, s in zip(mode["main_mode"], mode["sub_mode"]))
        data.modes = _mode_changes(mode["timestamp"] / 1e6, custom)
    return data


def _ulog_landing(t: dict[str, dict[str, np.ndarray]]) -> Series | None:
    """The precision landing (precision_landing, with landing_target_pose of the same instants), if the flight had
    one: tgt_n_m, tgt_e_m (target minus vehicle), tgt_vn_m_s, tgt_ve_m_s (over the ground), precland_phase."""
    pl = t.get("precision_landing")
    if pl is None or not np.any(pl["phase"] > 0):
        return None
    ts = pl["timestamp"]
    cols = {"tgt_n_m": np.full(ts.shape, np.nan), "tgt_e_m": np.full(ts.shape, np.nan)}
    pose = t.get("landing_target_pose")
    if pose is not None and pose["timestamp"].size:
        k = np.minimum(np.searchsorted(pose["timestamp"], ts), pose["timestamp"].size - 1)
        same = pose["timestamp"][k] == ts  # written in the same step as the landing's sample
        cols["tgt_n_m"][same] = pose["x_rel"][k[same]]
        cols["tgt_e_m"][same] = pose["y_rel"][k[same]]
    cols.update(
        tgt_vn_m_s=pl["target_vx"].astype(float),
        tgt_ve_m_s=pl["target_vy"].astype(float),
        precland_phase=pl["phase"].astype(float),
    )
    return Series(ts / 1e6, cols)


def load_truth_log(path: Path) -> Series:
    """The simulator's truth; altitude above its first sample (the vehicle on the ground at arming).

    The simulator's height is that of the centre of mass above the ground plane; the
    estimator's origin is the vehicle as it stood at the first GPS fix, so both start at 0.
    """
    a = read_npy_log(path)
    if a.size == 0:
        raise FlightLogError(f"{path}: the truth log holds no rows")
    f = lambda name: a[name].astype(float)  # noqa: E731
    alt = -f("pos_d_m")
    cols = dict(
        alt_m=alt - alt[0],
        n_m=f("pos_n_m"),
        e_m=f("pos_e_m"),
        roll_deg=np.degrees(f("roll_rad")),
        pitch_deg=np.degrees(f("pitch_rad")),
        yaw_deg=np.degrees(f("yaw_rad")),
    )
    if "ugv_n_m" in (a.dtype.names or ()):  # the ground vehicle's deck (sitl/truth_log.py)
        cols.update(ugv_n_m=f("ugv_n_m"), ugv_e_m=f("ugv_e_m"), armed=f("armed"))
    return Series(a["time_us"] / 1e6, cols)


# --------------------------------------------------------------------------- tlogs


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


def _read_tlog_rows(path: Path) -> tuple[dict[str, _Rows], int]:
    """The vehicle's rows of each of :data:`TLOG_KINDS` (times in s), and the number of motors seen.

    A HEARTBEAT has no time of its own: it gets the time of the message before it.
    """
    rows = {k: _Rows() for k in TLOG_KINDS}
    last_boot_s = None
    try:
        conn = mavutil.mavlink_connection(str(path), robust_parsing=True)
    except Exception as exc:
        raise FlightLogError(f"{path}: cannot open as a tlog: {exc}") from exc
    n_motors = 0
    vehicle = None
    try:
        while True:
            m = conn.recv_match(type=list(TLOG_KINDS))
            if m is None:
                break
            if vehicle is None and m.get_srcComponent() == VEHICLE_COMPID and m.get_type() != "BAD_DATA":
                vehicle = m.get_srcSystem()
            if m.get_srcSystem() != vehicle or m.get_srcComponent() != VEHICLE_COMPID:
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
                raw = [getattr(m, f"servo{i}_raw", 0) for i in range(1, SERVO_CHANNELS + 1)]
                used = [r for r in raw if r > 0]
                n_motors = max(n_motors, len(used))
                rows[k].add(m.time_usec, t, tuple(raw))
            elif k == "ACTUATOR_OUTPUT_STATUS":
                t = m.time_usec / 1e6
                n_motors = max(n_motors, bin(m.active).count("1"))
                rows[k].add(m.time_usec, t, tuple(m.actuator[:SERVO_CHANNELS]))
            elif k == "HEARTBEAT":
                if last_boot_s is not None:
                    rows[k].add(int(last_boot_s * 1e3), last_boot_s, (m.custom_mode,))
            if k != "HEARTBEAT":
                last_boot_s = t
    finally:
        conn.close()
    return rows, n_motors


def load_tlog(path: Path) -> FlightData:
    """A telemetry log: estimate, setpoint, motors and modes of system 1, component 1."""
    rows, n_motors = _read_tlog_rows(path)
    data = FlightData(name=path.name, source="telemetry log")
    att, att_sp = rows["ATTITUDE"].arrays(), rows["ATTITUDE_TARGET"].arrays()
    pos, pos_sp = rows["LOCAL_POSITION_NED"].arrays(), rows["POSITION_TARGET_LOCAL_NED"].arrays()
    if att is None and pos is None:
        raise FlightLogError(f"{path}: no ATTITUDE or LOCAL_POSITION_NED from the vehicle in this tlog")
    data.estimate = _merge(att, pos, euler=True)
    if att_sp is not None:
        q = att_sp[1]
        att_sp = (att_sp[0], np.column_stack(quat_to_euler_deg(q[:, 0], q[:, 1], q[:, 2], q[:, 3])))
    data.setpoint = _merge(att_sp, pos_sp, euler=False)
    servo, act = rows["SERVO_OUTPUT_RAW"].arrays(), rows["ACTUATOR_OUTPUT_STATUS"].arrays()
    if servo is not None and n_motors:
        values = np.clip((servo[1][:, :n_motors] - PWM_MIN_US) / PWM_RANGE_US, 0.0, 1.0)
        data.motors = Series(servo[0], {f"motor_{i}": values[:, i] for i in range(n_motors)})
    elif act is not None and n_motors:
        data.motors = Series(act[0], {f"motor_{i}": act[1][:, i] for i in range(n_motors)})
    hb = rows["HEARTBEAT"].arrays()
    if hb is not None:
        custom_modes = (encode_custom_mode(*decode_custom_mode(int(cm))) for cm in hb[1][:, 0])
        data.modes = _mode_changes(hb[0], custom_modes)
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


def log_stem(path: Path) -> str:
    """The flight's name: the file name without ``.ulg``, ``.truth.npy`` or ``.tlog``."""
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
    same = log.parent / (log_stem(log) + TRUTH_SUFFIX)
    if same.exists():
        return same
    me = _stem_time_instance(log_stem(log))
    if me is None:
        return None
    best: tuple[float, Path] | None = None
    for cand in log.parent.glob("*" + TRUTH_SUFFIX):
        other = _stem_time_instance(log_stem(cand))
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
        old = " (its .fc.npy is the control-rate log flights wrote before 2026-12-05, which nothing reads now)"
        hint = old if any(path.glob("*.fc.npy")) else ""
        raise FlightLogError(f"{path}: no *{FC_SUFFIX} or *{TLOG_SUFFIX} flight log in this directory{hint}")
    if not path.exists():
        raise FlightLogError(f"{path}: no such file")
    return path


def load(log: Path, truth: Path | None = None, find: bool = True) -> FlightData:
    """Read a flight controller's ULog or a tlog, and the ground truth if given or found."""
    if log.name.endswith(FC_SUFFIX):
        data = load_ulog(log)
    elif log.name.endswith(TRUTH_SUFFIX):
        raise FlightLogError(
            f"{log}: this is the simulator's truth log; give the flight's .ulg or .tlog "
            "(the truth log is found beside it, or pass --truth)"
        )
    else:
        data = load_tlog(log)
    series = [s for s in (data.estimate, data.setpoint) if s is not None and s.t_s.size]
    if truth is None and find and series:
        t_range = (min(float(s.t_s[0]) for s in series), max(float(s.t_s[-1]) for s in series))
        truth = find_truth(log, t_range)
    if truth is not None:
        data.truth, data.truth_source = load_truth_log(truth), truth.name
        data.frames = Series(*frames) if (frames := frames_beside(truth)) else None
        if series:  # only the flight's time span
            lo, hi = min(float(s.t_s[0]) for s in series), max(float(s.t_s[-1]) for s in series)
            data.truth, data.frames = (_span(s, lo, hi) for s in (data.truth, data.frames))
    return data


def _span(s: Series | None, lo: float, hi: float) -> Series | None:
    """The samples of ``s`` from ``lo`` to ``hi`` (s)."""
    keep = None if s is None else (s.t_s >= lo) & (s.t_s <= hi)
    return None if s is None else Series(s.t_s[keep], {k: v[keep] for k, v in s.cols.items()})
