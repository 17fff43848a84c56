"""The simulator's ground-truth log: one ``.truth.npy`` per arming (``sitl --log-dir DIR``).

Written from the simulator's lockstep loop every period (250 Hz of simulated time)
from the same plain-float truth the sensor models read, while the flight controller
reports itself armed (the HIL_ACTUATOR_CONTROLS mode flag) and ``POST_DISARM_S``
after.  An append-only ``.npy`` of records (:mod:`mavsim_core.npy_log`), so
``np.load(path)["pos_d_m"]`` works and a killed simulator leaves a readable file.
Times are the same simulated microseconds as the flight controller's log, so
``gcs plot`` pairs the two by time.  Columns (NED from the start point on the
ground, FRD body, radians):

time_us, armed, pos_{n,e,d}_m, vel_{n,e,d}_m_s, roll_rad, pitch_rad, yaw_rad,
rate_{p,q,r}_rad_s, motor_0 ... motor_{N-1} (the commands the simulator applied, 0..1);
with the ground vehicle (``SIM_UGV_EN=1``) also ugv_{n,e,d}_m (the marker's centre on its deck),
ugv_v{n,e}_m_s and ugv_yaw_rad.

Beside it, with the vision companion (a world with the UGV), ``<same stem>.frames.npy``: one record per camera
frame captured while the truth log is open (:class:`CameraFrame`, written when the companion releases the frame's
result, in capture order).  Columns: time_us (the capture's simulated time), gimbal_{roll,pitch,yaw}_deg (the
gimbal's joint angles at capture as its encoders read them, degrees; NaN for a fixed camera), rendered (0: the
frame was not rendered, the pad wholly out of view), n_markers (how many of the pad's markers the detector used;
0: no detection) and marker_0 ... marker_{MAX_FRAME_MARKERS-1} (their ids in the detector's order, -1 past
n_markers).  Older flights have no such file; readers must do without it.  Also beside it, ``<same stem>.sim.json``:
the world the flight was flown in (vehicle file, camera mount, pad, SIM_* values; :mod:`sitl.flight_setup`).
"""

from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Callable, Sequence

from mavsim_core.log_naming import flight_stem
from mavsim_core.npy_log import NpyLogWriter

SUFFIX = ".truth.npy"
FRAMES_SUFFIX = ".frames.npy"
MAX_FRAME_MARKERS = 8  # marker id columns of a frame record (the nested pad has 5)
POST_DISARM_S = 1.0

_STATE_FIELDS = (
    "pos_n_m",
    "pos_e_m",
    "pos_d_m",
    "vel_n_m_s",
    "vel_e_m_s",
    "vel_d_m_s",
    "roll_rad",
    "pitch_rad",
    "yaw_rad",
    "rate_p_rad_s",
    "rate_q_rad_s",
    "rate_r_rad_s",
)


UGV_FIELDS = ("ugv_n_m", "ugv_e_m", "ugv_d_m", "ugv_vn_m_s", "ugv_ve_m_s", "ugv_yaw_rad")


def truth_log_fields(n_motors: int, ugv: bool = False) -> list[tuple[str, str]]:
    return (
        [("time_us", "q"), ("armed", "B")]
        + [(name, "f") for name in _STATE_FIELDS]
        + [(f"motor_{i}", "f") for i in range(n_motors)]
        + ([(name, "f") for name in UGV_FIELDS] if ugv else [])
    )


def frame_log_fields() -> list[tuple[str, str]]:
    """The camera-frame log's columns (the module docstring)."""
    return (
        [("time_us", "q"), ("gimbal_roll_deg", "f"), ("gimbal_pitch_deg", "f"), ("gimbal_yaw_deg", "f")]
        + [("rendered", "B"), ("n_markers", "B")]
        + [(f"marker_{i}", "h") for i in range(MAX_FRAME_MARKERS)]
    )


@dataclass(frozen=True)
class CameraFrame:
    """One camera frame as the companion saw it: its capture time (simulated us), the gimbal's joint angles then
    (roll, pitch, yaw; rad; None for a fixed camera), whether it was rendered, and the ids of the pad's markers
    the detector used (empty: no detection)."""

    time_us: int
    gimbal_rpy_rad: tuple[float, float, float] | None
    rendered: bool
    marker_ids: tuple[int, ...] = ()

    def row(self) -> tuple:
        """The values of a :func:`frame_log_fields` record."""
        rpy = [math.degrees(a) for a in self.gimbal_rpy_rad] if self.gimbal_rpy_rad else [math.nan] * 3
        ids = list(self.marker_ids[:MAX_FRAME_MARKERS])
        return (self.time_us, *rpy, int(self.rendered), len(ids), *ids, *[-1] * (MAX_FRAME_MARKERS - len(ids)))


class TruthRecorder:
    """Opens a truth log when the vehicle arms, closes it ``POST_DISARM_S`` after it disarms.

    :meth:`record` takes the period's :class:`sitl.simulation.SensorTruth`, :meth:`record_frame` a camera
    frame (written to the ``.frames.npy`` beside the open truth log, created at its first frame); any I/O
    error switches logging off (reported once), never the simulation.
    """

    def __init__(self, log_dir: str | Path, n_motors: int, instance: int = 0, ugv: bool = False) -> None:
        self.log_dir = Path(log_dir)
        self.log_dir.mkdir(parents=True, exist_ok=True)
        self.n_motors = n_motors
        self.instance = instance
        self.fields = truth_log_fields(n_motors, ugv)
        self.ugv = ugv
        self._w: NpyLogWriter | None = None
        self._frames: NpyLogWriter | None = None
        self._close_at_us: int | None = None
        self.files: list[Path] = []
        self.disabled = False
        self.on_open: Callable[[Path], None] | None = None  # called with each new truth log (sitl/flight_setup.py)

    def record(self, time_us: int, t, armed: bool, motor_commands: Sequence[float], ugv=None) -> None:
        """One period: ``t`` a :class:`sitl.simulation.SensorTruth`, ``ugv`` a :class:`sitl.ugv_world.UgvTruth` or
        a function giving it (or None), called only while the log is open (the lockstep's: every step)."""
        if self.disabled:
            return
        try:
            if armed and (self._w is None or self._close_at_us is not None):
                self._close()
                stem = flight_stem(self.log_dir, time.time(), self.instance, (SUFFIX, FRAMES_SUFFIX))
                self._w = NpyLogWriter(self.log_dir / (stem + SUFFIX), self.fields)
                self.files.append(self._w.path)
                print(f"[sitl] logging ground truth to {self._w.path}", file=sys.stderr, flush=True)
                if self.on_open is not None:
                    self.on_open(self._w.path)
            elif not armed and self._w is not None and self._close_at_us is None:
                self._close_at_us = time_us + int(POST_DISARM_S * 1e6)
            w = self._w
            if w is None:
                return
            (r00, _, _), (r10, _, _), (r20, r21, r22) = t.r_ned_frd
            s = r20 if r20 < 1.0 else 1.0  # max(-1.0, min(1.0, r20)) without the calls (NaN -> 1.0 as there)
            s = s if s > -1.0 else -1.0
            n = self.n_motors
            motors = motor_commands[:n]
            if len(motors) < n:
                motors = [*motors, *[0.0] * (n - len(motors))]
            if self.ugv:
                extra: Sequence[float] = [math.nan] * len(UGV_FIELDS)
                ugv = ugv() if callable(ugv) else ugv
                if ugv is not None:
                    extra = [*ugv.deck_pos_ned_m.tolist(), *ugv.vel_ned_m_s[:2].tolist(), ugv.yaw_rad]
                motors = [*motors, *extra]
            roll, pitch, yaw = math.atan2(r21, r22), -math.asin(s), math.atan2(r10, r00)
            w.append(time_us, armed, *t.pos_ned_m, *t.vel_ned_m_s, roll, pitch, yaw, *t.rate_frd_rad_s, *motors)
            if self._close_at_us is not None and time_us >= self._close_at_us:
                self._close()
        except Exception as exc:
            self.disabled = True
            print(f"[sitl] ground-truth logging stopped: {exc!r}", file=sys.stderr, flush=True)

    def record_frame(self, frame: CameraFrame) -> None:
        """A camera frame (the companion's :class:`CameraFrame`), kept only while the truth log is open."""
        if self.disabled or self._w is None:
            return
        try:
            if self._frames is None:
                path = self._w.path.with_name(self._w.path.name[: -len(SUFFIX)] + FRAMES_SUFFIX)
                self._frames = NpyLogWriter(path, frame_log_fields(), chunk_rows=30)
                self.files.append(path)
            self._frames.append(*frame.row())
        except Exception as exc:
            self.disabled = True
            print(f"[sitl] ground-truth logging stopped: {exc!r}", file=sys.stderr, flush=True)

    def _close(self) -> None:
        w, self._w = self._w, None
        frames, self._frames = self._frames, None
        self._close_at_us = None
        try:
            if w is not None:
                w.close()
        finally:
            if frames is not None:
                frames.close()

    def close(self) -> None:
        try:
            self._close()
        except Exception as exc:
            print(f"[sitl] closing the ground-truth log failed: {exc!r}", file=sys.stderr, flush=True)
