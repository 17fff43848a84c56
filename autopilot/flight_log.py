"""The flight controller's own log: setpoints, estimates and motor outputs at the control rate.

One row per control step (250 Hz; ``every`` > 1 keeps one step in ``every``), written
by :class:`FlightLogWriter` as an append-only ``.npy`` of records (:mod:`mavsim_core.npy_log`):
``np.load("2026-01-01_12-00-00.fc.npy")["pos_d_m"]``.  Columns (NED world, FRD body,
quaternions w, x, y, z taking FRD to NED; NaN where there is no setpoint):

=========================  ===================================================================
time_us                    simulated time of the step, µs (int64; the lockstep clock)
armed, main_mode, sub_mode  arming state and PX4 mode numbers
pos_sp_{n,e,d}_m           position setpoint (NaN on an axis that is not position-controlled)
vel_sp_{n,e,d}_m_s         velocity setpoint (position P output + feed-forward, limited)
acc_sp_{n,e,d}_m_s2        acceleration setpoint of the velocity PID
yaw_sp_rad                 yaw setpoint
q_sp_{w,x,y,z}             attitude setpoint
rate_sp_{p,q,r}_rad_s      body-rate setpoint (attitude controller output)
thrust_sp                  collective thrust setpoint, fraction of the maximum
thrust                     collective thrust delivered by the mixer, fraction of the maximum
pos_{n,e,d}_m              position estimate the outer loops used (updated at 50 Hz; estimator
                           origin: the first good GPS fix)
vel_{n,e,d}_m_s            velocity estimate (likewise)
q_{w,x,y,z}                attitude estimate
rate_{p,q,r}_rad_s         body rates, bias-corrected
motor_0 ... motor_{N-1}    motor commands 0..1
tgt_{n,e,d}_m              landing target relative to the vehicle (target minus vehicle, NED),
                           the estimate of :mod:`autopilot.landing_target_input` (NaN: none)
tgt_v{n,e}_m_s             the target's velocity over the ground (NaN: none)
tgt_meas                   LANDING_TARGET measurements fused so far (a counter)
precland_phase             the precision landing's phase (0 none, 1 preparation, 2 tracking,
                           3 approaching, 4 docking, 5 search, 6 fallback, 7 done)
=========================  ===================================================================

The values are read after each step from the records the flight controller and the
commander publish (``fc.actuators``, ``fc.commander.status``) and from the controllers'
and the estimator's attributes; nothing in them changes.
"""

from __future__ import annotations

import math
from pathlib import Path

from mavsim_core.npy_log import NpyLogWriter

from .control.position_control import PositionSetpoint

SUFFIX = ".fc.npy"

_SETPOINT_FIELDS = (
    "pos_sp_n_m",
    "pos_sp_e_m",
    "pos_sp_d_m",
    "vel_sp_n_m_s",
    "vel_sp_e_m_s",
    "vel_sp_d_m_s",
    "acc_sp_n_m_s2",
    "acc_sp_e_m_s2",
    "acc_sp_d_m_s2",
    "yaw_sp_rad",
    "q_sp_w",
    "q_sp_x",
    "q_sp_y",
    "q_sp_z",
    "rate_sp_p_rad_s",
    "rate_sp_q_rad_s",
    "rate_sp_r_rad_s",
    "thrust_sp",
)
_ESTIMATE_FIELDS = (
    "thrust",
    "pos_n_m",
    "pos_e_m",
    "pos_d_m",
    "vel_n_m_s",
    "vel_e_m_s",
    "vel_d_m_s",
    "q_w",
    "q_x",
    "q_y",
    "q_z",
    "rate_p_rad_s",
    "rate_q_rad_s",
    "rate_r_rad_s",
)
_NO_SETPOINT = (math.nan,) * len(_SETPOINT_FIELDS)
_NO_POSITION_LOOP = (math.nan,) * 10  # position, velocity, acceleration and yaw setpoints: attitude flown
_NO_POS_VEL = (math.nan,) * 6


_TARGET_FIELDS = ("tgt_n_m", "tgt_e_m", "tgt_d_m", "tgt_vn_m_s", "tgt_ve_m_s")
_NO_TARGET = (math.nan,) * len(_TARGET_FIELDS)
PRECLAND_PHASES = ("preparation", "tracking", "approaching", "docking", "search", "fallback", "done")


def flight_log_fields(n_motors: int) -> list[tuple[str, str]]:
    """(name, struct code) of every column, for a vehicle with ``n_motors`` rotors."""
    return (
        [("time_us", "q"), ("armed", "B"), ("main_mode", "B"), ("sub_mode", "B")]
        + [(name, "f") for name in _SETPOINT_FIELDS + _ESTIMATE_FIELDS]
        + [(f"motor_{i}", "f") for i in range(n_motors)]
        + [(name, "f") for name in _TARGET_FIELDS]
        + [("tgt_meas", "I"), ("precland_phase", "B")]
    )


def _target_columns(fc) -> tuple | list:
    """The landing target estimate, the measurement count and the precision-landing phase code."""
    lt = fc.landing_target
    e = lt.estimate
    phase = getattr(fc.commander.task, "phase", None)
    code = PRECLAND_PHASES.index(phase.value) + 1 if phase is not None and phase.value in PRECLAND_PHASES else 0
    if e is None or not e.valid:  # the usual case: no target (one tuple, no copies)
        return (*_NO_TARGET, lt.accepted, code)
    row = e.rel_pos_ned_m.tolist()
    row += e.target_vel_ned_m_s[:2].tolist() if e.target_vel_ned_m_s is not None else _NO_TARGET[3:]
    return row + [lt.accepted, code]


class FlightLogWriter:
    """Appends one row per control step of a :class:`~autopilot.flight_controller.FlightController`."""

    def __init__(self, path: str | Path, fc, every: int = 1, chunk_rows: int = 250) -> None:
        self.fc = fc
        self.n_motors = len(fc.spec.rotors)
        self.max_thrust_n = self.n_motors * fc.spec.max_thrust_per_rotor_n
        self.every = max(1, int(every))
        self._count = 0
        self.writer = NpyLogWriter(path, flight_log_fields(self.n_motors), chunk_rows)
        self._idle_motors = (0.0,) * self.n_motors
        self._status = None  # the latest commander status seen, and its columns (a new record on every change):
        self._head: tuple = (False, 0, 0)  # armed, main_mode, sub_mode
        self._pos_vel: tuple = _NO_POS_VEL  # the estimate the outer loops used (position, velocity: 50 Hz)

    @property
    def path(self) -> Path:
        return self.writer.path

    def record(self) -> None:
        """Log the step that just ran (call after ``FlightController.step``)."""
        self._count += 1
        if self._count < self.every:
            return
        self._count = 0
        fc = self.fc
        status = fc.commander.status
        if status is not self._status:  # a new (frozen) record on every change: its columns once each
            self._status = status
            self._head = (status.armed, *status.mode.value)
            e = status.estimate
            self._pos_vel = _NO_POS_VEL if e is None else (*e.pos_ned_m.tolist(), *e.vel_ned_m_s.tolist())
        sp = fc.setpoint
        if sp is not None and status.armed:  # .tolist(): far cheaper than numpy scalars
            pc = fc.position_control
            tv = getattr(fc, "thrust_vec", None)
            if tv is not None:
                x, y, z = tv.tolist()
                thrust_sp = math.sqrt(x * x + y * y + z * z) / self.max_thrust_n
            else:
                thrust_sp = math.nan
            if isinstance(sp, PositionSetpoint):
                head = (*sp.pos_ned_m.tolist(), *pc.vel_sp.tolist(), *pc.acc_sp.tolist(), sp.yaw_rad)
            else:  # an attitude or body rates flown (AttitudeSetpoint): no position-loop setpoints
                head = _NO_POSITION_LOOP
            setpoints = [*head, *fc.q_sp.tolist(), *fc.rate_sp.tolist(), thrust_sp]
        else:
            setpoints = _NO_SETPOINT
        est = fc.estimator
        q = getattr(est, "q", None)  # the selected filter's attitude, updated every step
        actuators = fc.actuators
        self.writer.append(
            fc.last_us or 0, *self._head, *setpoints, actuators.throttle_frac, *self._pos_vel,
            *(q if q is not None else est.attitude.q).tolist(), *est.rate_frd.tolist(),
            *(actuators.motor_outputs or self._idle_motors)[: self.n_motors], *_target_columns(fc),
        )  # fmt: skip

    def flush(self) -> None:
        self.writer.flush()

    def close(self) -> None:
        self.writer.close()
