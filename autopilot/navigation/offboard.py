"""OFFBOARD mode (PX4 main mode 6): fly the setpoints a companion computer or ground station streams.

The setpoints arrive as :class:`~autopilot.topics.OffboardSetpoint` (decoded and converted to local NED
at reception by :mod:`autopilot.mavlink.offboard_messages`); :class:`OffboardTask` flies the latest one:

- position / velocity / acceleration (``kind`` POSITION, VELOCITY, ACCELERATION): a
  :class:`~autopilot.control.position_control.PositionSetpoint` with NaN where the sender gave nothing
  (the position controller then flies the next level down on that axis, or holds its speed at zero);
  the heading is the setpoint's yaw, else its yaw rate integrated, else held; as in PX4 it goes to the
  controllers as given (no slew: a sender that wants a gentle turn streams one);
- attitude + thrust, body rates + thrust (ATTITUDE, BODY_RATES): an
  :class:`~autopilot.topics.AttitudeSetpoint` for the inner loops (no thrust given: the hover thrust).

Before the first setpoint the task holds where it was activated.  On the ground (``on_ground``, set by
the commander each update) it returns None (motors idle) until the setpoint asks to climb: a position
more than :data:`TAKEOFF_ABOVE_M` above the vehicle, an upward velocity or acceleration
(:data:`TAKEOFF_UP_M_S`, :data:`TAKEOFF_UP_M_S2`), or a thrust above :data:`IDLE_THRUST_FRAC`; so
MAVSDK's "arm, stream, offboard.start()" lifts off once the stream asks for height.

Entry and loss, as PX4: OFFBOARD may be entered only while setpoints stream (:func:`offboard_refusal`:
the latest is no older than ``COM_OF_LOSS_T``, as PX4's offboard check; one is enough); it is lost when the
latest setpoint is older than ``COM_OF_LOSS_T`` on both clocks (:func:`offboard_lost`; a client streams
on the wall clock while the simulation may run faster).  Then the failsafes switch to
:func:`loss_fallback_mode` of ``COM_OBL_RC_ACT``: 0 Position, 1 Altitude and 2 Manual (PX4: these
need sticks) all give POSCTL here, which holds position while the sticks are centred or absent (and
follows them when a pilot is present); 3 Return, 4 Land, 5 Hold; 6 Terminate and 7 Disarm stop the
motors (:data:`TERMINATE`, the failsafes' forced disarm).

Frames and units: positions m NED from the estimator origin, velocities m/s NED, accelerations m/s^2
NED, angles rad, rates rad/s (FRD body), thrust a fraction of the vehicle's maximum.  Time is ``now_us``
(simulated µs) and, for the input ages, ``wall_s`` (s) handed in: nothing here reads a clock.
"""

from __future__ import annotations

import math
from typing import Callable, Protocol

import numpy as np

from autopilot.navigation.flight_task import PositionSetpoint
from autopilot.parameters import ParamDef, ParameterStore, ParamType, param
from autopilot.topics import AttitudeSetpoint, OffboardKind, OffboardSetpoint, VehicleEstimate
from mavsim_core import quaternion as quat
from mavsim_core.px4_modes import Mode


class ExternalInputs(Protocol):
    """What is read of :class:`autopilot.commander.external_inputs.ExternalInputs` (ages in s, both clocks)."""

    def offboard_age_s(self, now_us: int, wall_s: float | None) -> float | None: ...


# The parameters of OFFBOARD mode (listed in autopilot/param_catalogue.py), PX4's names, defaults, ranges.
PARAMS: tuple[ParamDef, ...] = (
    param("COM_OF_LOSS_T", 1.0, 0.0, 60.0, "s", "Offboard setpoints silent this long: offboard lost (COM_OBL_RC_ACT)"),
    param(
        "COM_OBL_RC_ACT", 0, 0, 7, "",
        "Offboard loss action: 0 Position, 1 Altitude, 2 Manual (all: Position mode, which holds without "
        "sticks), 3 Return, 4 Land, 5 Hold, 6 Terminate, 7 Disarm (both: motors off)", ParamType.INT32,
    ),
)  # fmt: skip

TERMINATE = "terminate"  # loss_fallback_mode's "stop the motors" (autopilot.commander.failsafes.TERMINATE)
FALLBACK: dict[int, Mode | str] = {
    0: Mode.POSCTL, 1: Mode.POSCTL, 2: Mode.POSCTL, 3: Mode.AUTO_RTL, 4: Mode.AUTO_LAND, 5: Mode.AUTO_LOITER,
    6: TERMINATE, 7: TERMINATE,
}  # fmt: skip

TAKEOFF_ABOVE_M = 0.3  # on the ground: a position setpoint this far above the vehicle lifts off ...
TAKEOFF_UP_M_S = 0.1  # ... or an upward velocity setpoint faster than this ...
TAKEOFF_UP_M_S2 = 0.1  # ... or an upward acceleration setpoint larger than this ...
IDLE_THRUST_FRAC = 0.1  # ... or an attitude / rate setpoint's thrust above this (fraction of maximum)
MAX_DT_S = 0.1  # longest step of the yaw-rate integration (a pause in updates does not jump the heading)

Latest = Callable[[], OffboardSetpoint | None]


def climbs(sp: OffboardSetpoint, est: VehicleEstimate) -> bool:
    """The setpoint asks the vehicle on the ground to lift off (module docstring)."""
    if sp.kind in (OffboardKind.ATTITUDE, OffboardKind.BODY_RATES):
        return math.isfinite(sp.thrust_frac) and sp.thrust_frac > IDLE_THRUST_FRAC
    pos_d, vel_d, acc_d = float(sp.pos_ned_m[2]), float(sp.vel_ned_m_s[2]), float(sp.acc_ned_m_s2[2])
    if sp.kind is OffboardKind.POSITION and math.isfinite(pos_d):
        return pos_d < float(est.pos_ned_m[2]) - TAKEOFF_ABOVE_M
    if math.isfinite(vel_d):
        return vel_d < -TAKEOFF_UP_M_S
    return math.isfinite(acc_d) and acc_d < -TAKEOFF_UP_M_S2


class OffboardTask:
    """OFFBOARD: fly the latest offboard setpoint (``latest()``), see the module docstring."""

    def __init__(self, params: ParameterStore, latest: Latest, hover_thrust_frac: float) -> None:
        self.params = params
        self.latest = latest
        self.hover_thrust_frac = hover_thrust_frac
        self.on_ground = False  # the commander sets it before each update
        self.hold = np.zeros(3)  # where the task holds without a setpoint, m NED
        self.yaw_rad = 0.0  # heading setpoint, rad
        self._last_us: int | None = None

    def activate(self, est: VehicleEstimate, now_us: int) -> None:
        self.hold = est.pos_ned_m.astype(float).copy()
        self.yaw_rad = est.yaw_rad
        self._last_us = now_us

    def _dt(self, now_us: int) -> float:
        last, self._last_us = self._last_us, now_us
        return 0.0 if last is None else min(max((now_us - last) * 1e-6, 0.0), MAX_DT_S)

    def update(self, est: VehicleEstimate, now_us: int) -> PositionSetpoint | AttitudeSetpoint | None:
        """The setpoint for this step; None (motors idle) on the ground until the setpoint asks to climb."""
        dt = self._dt(now_us)
        sp = self.latest()
        if self.on_ground:
            self.hold, self.yaw_rad = est.pos_ned_m.astype(float).copy(), est.yaw_rad
            if sp is None or not climbs(sp, est):
                return None
        if sp is None:
            return PositionSetpoint(self.hold.copy(), np.zeros(3), self.yaw_rad, np.zeros(3))
        if sp.kind is OffboardKind.ATTITUDE:
            assert sp.q_wxyz is not None  # (an attitude setpoint carries its quaternion)
            self.yaw_rad = quat.to_euler(sp.q_wxyz)[2]
            rate = sp.yaw_rate_rad_s if math.isfinite(sp.yaw_rate_rad_s) else 0.0
            return AttitudeSetpoint(np.array(sp.q_wxyz, dtype=float), None, self._thrust(sp), rate)
        if sp.kind is OffboardKind.BODY_RATES:
            self.yaw_rad = est.yaw_rad
            return AttitudeSetpoint(None, np.array(sp.body_rate_frd_rad_s, dtype=float), self._thrust(sp))
        if math.isfinite(sp.yaw_rad):
            self.yaw_rad = sp.yaw_rad
        elif math.isfinite(sp.yaw_rate_rad_s):
            self.yaw_rad = quat.wrap_pi(self.yaw_rad + sp.yaw_rate_rad_s * dt)
        return PositionSetpoint(sp.pos_ned_m.copy(), sp.vel_ned_m_s.copy(), self.yaw_rad, sp.acc_ned_m_s2.copy())

    def _thrust(self, sp: OffboardSetpoint) -> float:
        return sp.thrust_frac if math.isfinite(sp.thrust_frac) else self.hover_thrust_frac

    @property
    def done(self) -> bool:
        return False

    @property
    def failed(self) -> bool:
        return False

    def shift(self, delta_ned_m: np.ndarray) -> None:
        """Move the held point with an estimator reset (the sender's setpoints are its own to correct)."""
        self.hold = self.hold + delta_ned_m


def offboard_refusal(inputs: ExternalInputs, now_us: int, wall_s: float | None, params: ParameterStore) -> str | None:
    """Why OFFBOARD cannot be entered now, or None: as PX4's offboard check, the latest setpoint must be no
    older than COM_OF_LOSS_T (on either clock).  One is enough: MAVSDK's examples send one setpoint, then
    start offboard at once, while the client streams the rest."""
    age = inputs.offboard_age_s(now_us, wall_s)
    if age is None or age > params.get("COM_OF_LOSS_T"):
        return "no offboard setpoints streaming"
    return None


def offboard_lost(inputs: ExternalInputs, now_us: int, wall_s: float | None, params: ParameterStore) -> bool:
    """The offboard setpoints are silent for longer than COM_OF_LOSS_T (on both clocks), or never came."""
    age = inputs.offboard_age_s(now_us, wall_s)
    return age is None or age > params.get("COM_OF_LOSS_T")


def loss_fallback_mode(params: ParameterStore) -> Mode | str:
    """The mode to fly when offboard is lost (COM_OBL_RC_ACT; module docstring); :data:`TERMINATE` for 6, 7."""
    return FALLBACK.get(int(params.get("COM_OBL_RC_ACT")), Mode.POSCTL)
