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
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path
from typing import Sequence

from mavsim_core.log_naming import flight_stem
from mavsim_core.npy_log import NpyLogWriter

SUFFIX = ".truth.npy"
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


class TruthRecorder:
    """Opens a truth log when the vehicle arms, closes it ``POST_DISARM_S`` after it disarms.

    :meth:`record` takes the period's :class:`sitl.simulation.SensorTruth`; any I/O
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
        self._close_at_us: int | None = None
        self.files: list[Path] = []
        self.disabled = False

    def record(self, time_us: int, t, armed: bool, motor_commands: Sequence[float], ugv=None) -> None:
        """One period: ``t`` a :class:`sitl.simulation.SensorTruth`, ``ugv`` a :class:`sitl.ugv_world.UgvTruth`."""
        if self.disabled:
            return
        try:
            if armed and (self._w is None or self._close_at_us is not None):
                self._close()
                stem = flight_stem(self.log_dir, time.time(), self.instance, (SUFFIX,))
                self._w = NpyLogWriter(self.log_dir / (stem + SUFFIX), self.fields)
                self.files.append(self._w.path)
                print(f"[sitl] logging ground truth to {self._w.path}", file=sys.stderr, flush=True)
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

    def _close(self) -> None:
        w, self._w = self._w, None
        self._close_at_us = None
        if w is not None:
            w.close()

    def close(self) -> None:
        try:
            self._close()
        except Exception as exc:
            print(f"[sitl] closing the ground-truth log failed: {exc!r}", file=sys.stderr, flush=True)
