"""The stick modes: POSCTL, ALTCTL, STABILIZED and ACRO (PX4's manual flight tasks and the stabilized
and acro paths of its attitude and rate controllers).

Sticks are :class:`~autopilot.topics.ManualInput`: ``pitch`` forward +1, ``roll`` right +1, ``yaw``
clockwise +1 (each -1..1), ``throttle`` 0..1 with 0.5 centred.  In POSCTL and ALTCTL a stick within
MPC_HOLD_DZ of centre counts as centred and the travel beyond it is rescaled, so a full stick still
gives the full value; STABILIZED and ACRO take roll, pitch and throttle as they come.  The sticks are then
shaped as PX4 shapes them (:mod:`autopilot.navigation.stick_expo`): MPC_XY_MAN_EXPO on POSCTL's horizontal
sticks, MPC_Z_MAN_EXPO on the climb rate, MPC_YAW_EXPO on the yaw rate (with the deadzone in STABILIZED too),
MC_ACRO_EXPO(_Y) and MC_ACRO_SUPEXPO(Y) on ACRO's rates; ALTCTL's tilt and STABILIZED's angles stay linear.

- POSCTL (:class:`PosCtlTask`): the horizontal sticks command a velocity in the heading frame (full
  stick MPC_VEL_MANUAL m/s, changing at most MPC_ACC_HOR_MAX m/s^2); centred, the vehicle brakes and
  then holds the position where it stopped (slower than :data:`STOPPED_M_S`, or after
  :data:`BRAKE_MAX_S` of braking).  No sticks at all: hold where the task started.
- ALTCTL (:class:`AltCtlTask`): the horizontal sticks command a tilt: an acceleration setpoint
  g tan(stick MPC_MAN_TILT_MAX) with position and velocity not controlled on north and east.
- Both: the throttle stick commands the climb rate (full up MPC_Z_VEL_MAX_UP, full down
  MPC_Z_VEL_MAX_DN); centred, the vertical speed is braked to zero and the altitude where it stopped held.
  The yaw stick commands the yaw rate (MPC_MAN_Y_MAX).  On the ground the motors idle (None) until
  the throttle is raised past :data:`TAKEOFF_STICK` above centre; then the vehicle climbs.
- STABILIZED (:class:`StabilizedTask`): roll and pitch angles stick * MPC_MAN_TILT_MAX, the heading
  integrated from the yaw stick's rate, and collective thrust from the throttle stick: bottom
  MPC_MANTHR_MIN, centre the hover thrust, top MPC_THR_MAX (PX4's MPC_THR_CURVE "rescale").
- ACRO (:class:`AcroTask`): body rates stick * MC_ACRO_R/P/Y_MAX, thrust as STABILIZED.  Both
  idle (None) on the ground while the throttle is at the bottom.

Frames and units: positions m NED from the estimator origin, velocities m/s NED, accelerations m/s^2
NED, angles rad (parameters in PX4's deg and deg/s), thrust a fraction of the vehicle's maximum.
The heading frame is NED turned by the vehicle's yaw: forward, right, down.  Time is ``now_us``
(simulated microseconds); nothing here reads a clock.
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np

from autopilot.control import gains_from_params
from autopilot.navigation import stick_expo
from autopilot.navigation.flight_task import PositionSetpoint, defined_in
from autopilot.parameters import ParamDef, ParameterStore, param
from autopilot.topics import AttitudeSetpoint, ManualInput, VehicleEstimate
from mavsim_core import quaternion as quat
from mavsim_core.constants import GRAVITY_M_S2
from mavsim_core.frames import heading_to_ned

# The parameters the stick modes read (listed in autopilot/param_catalogue.py); the vertical speed
# and thrust limits are the position controller's.
PARAMS: tuple[ParamDef, ...] = (
    param(
        "MPC_VEL_MANUAL", 1.0, 0.5, 20.0, "m/s",
        "Horizontal speed at full stick in Position mode (PX4: default 10, min 3; here 1 m/s, as joystick flight)",
    ),
    param("MPC_ACC_HOR_MAX", 5.0, 2.0, 15.0, "m/s^2", "Largest change per second of the Position mode stick velocity"),
    param(
        "MPC_MAN_Y_MAX", 11.46, 0.0, 400.0, "deg/s",
        "Yaw rate at full yaw stick in Stabilized, Altitude and Position mode (PX4: 150; here 0.2 rad/s)",
    ),
    param("MPC_MAN_TILT_MAX", 35.0, 1.0, 70.0, "deg", "Tilt at full stick in Stabilized and Altitude mode"),
    param("MPC_HOLD_DZ", 0.1, 0.0, 1.0, "norm", "Stick deadzone in Position and Altitude mode (fraction of travel)"),
    param("MPC_MANTHR_MIN", 0.08, 0.0, 1.0, "norm", "Collective thrust at the lowest throttle stick (Stabilized)"),
    param("MC_ACRO_R_MAX", 100.0, 0.0, 1800.0, "deg/s", "Acro mode roll rate at full stick"),
    param("MC_ACRO_P_MAX", 100.0, 0.0, 1800.0, "deg/s", "Acro mode pitch rate at full stick"),
    param("MC_ACRO_Y_MAX", 100.0, 0.0, 1800.0, "deg/s", "Acro mode yaw rate at full stick"),
    defined_in(gains_from_params.POSITION_PARAMS, "MPC_Z_VEL_MAX_UP"),
    defined_in(gains_from_params.POSITION_PARAMS, "MPC_Z_VEL_MAX_DN"),
    defined_in(gains_from_params.POSITION_PARAMS, "MPC_THR_MAX"),
    *stick_expo.PARAMS,
)  # fmt: skip

TAKEOFF_STICK = 0.3  # zero-centred throttle (-1..1, after the deadzone, before the expo) lifting off in POSCTL / ALTCTL
THROTTLE_BOTTOM = 0.05  # throttle stick (0..1) at or below which STABILIZED / ACRO idle on the ground
STOPPED_M_S = 0.15  # centred sticks: the position (altitude) is held once the speed is below this ...
BRAKE_MAX_S = 2.0  # ... or after braking this long (so a noisy speed estimate cannot keep it from holding)
MAX_DT_S = 0.1  # longest step integrated (a pause in updates does not jump the heading)

Sticks = Callable[[], ManualInput | None]


def deadzone(x: float, dz: float) -> float:
    """``x`` (-1..1) with the band |x| <= ``dz`` zeroed and the rest rescaled to reach +-1."""
    dz = min(max(dz, 0.0), 0.99)
    x = min(max(x, -1.0), 1.0)
    if abs(x) <= dz:
        return 0.0
    return math.copysign((abs(x) - dz) / (1.0 - dz), x)


def climb_stick(throttle: float) -> float:
    """The throttle stick 0..1 as -1 (full down) .. +1 (full up), 0 centred."""
    return min(max(2.0 * throttle - 1.0, -1.0), 1.0)


def unit_disc(a: float, b: float) -> tuple[float, float]:
    """The stick vector (a, b) shortened to length 1 at most (diagonals are no faster)."""
    n = math.hypot(a, b)
    return (a / n, b / n) if n > 1.0 else (a, b)


def thrust_curve(throttle: float, hover: float, low: float, high: float) -> float:
    """Collective thrust (fraction of maximum) of the throttle stick: 0 -> ``low``, 0.5 -> ``hover``,
    1 -> ``high``, linear between (PX4's MPC_THR_CURVE rescale to the hover thrust)."""
    t = min(max(throttle, 0.0), 1.0)
    if t <= 0.5:
        return low + (hover - low) * t / 0.5
    return hover + (high - hover) * (t - 0.5) / 0.5


class _PilotedTask:
    """What every stick mode shares: the sticks, the heading setpoint, the step time, on_ground."""

    def __init__(self, params: ParameterStore, sticks: Sticks) -> None:
        self.params = params
        self.sticks = sticks
        self.on_ground = False  # the commander sets it before each update
        self.yaw_rad = 0.0  # heading setpoint
        self.yaw_rate_rad_s = 0.0
        self._last_us: int | None = None

    def activate(self, est: VehicleEstimate, now_us: int) -> None:
        self.yaw_rad = est.yaw_rad
        self._last_us = now_us

    def _dt(self, now_us: int) -> float:
        last, self._last_us = self._last_us, now_us
        return 0.0 if last is None else min(max((now_us - last) * 1e-6, 0.0), MAX_DT_S)

    def _shaped(self, x: float, expo_param: str) -> float:
        """A stick after the deadzone (MPC_HOLD_DZ), then the expo curve of ``expo_param`` (PX4's expo_deadzone)."""
        return stick_expo.expo(deadzone(x, self.params.get("MPC_HOLD_DZ")), self.params.get(expo_param))

    def _turn(self, est: VehicleEstimate, yaw_stick: float, dt: float) -> None:
        """Integrate the yaw stick's rate into the heading setpoint (reset to the vehicle's on the ground)."""
        if self.on_ground:
            self.yaw_rad, self.yaw_rate_rad_s = est.yaw_rad, 0.0
            return
        self.yaw_rate_rad_s = yaw_stick * math.radians(self.params.get("MPC_MAN_Y_MAX"))
        self.yaw_rad = quat.wrap_pi(self.yaw_rad + self.yaw_rate_rad_s * dt)

    @property
    def done(self) -> bool:
        return False

    @property
    def failed(self) -> bool:
        return False

    def shift(self, delta_ned_m: np.ndarray) -> None:
        """Nothing held in position: nothing to move."""


class _HeightHoldTask(_PilotedTask):
    """POSCTL and ALTCTL: throttle = climb rate, centred holds the altitude; yaw stick = yaw rate."""

    def __init__(self, params: ParameterStore, sticks: Sticks) -> None:
        super().__init__(params, sticks)
        self.hold = np.full(3, math.nan)  # held position, m NED (NaN: axis not held now)
        self.braking_s = np.zeros(2)  # how long the horizontal / vertical speed has been braked, s

    def activate(self, est: VehicleEstimate, now_us: int) -> None:
        super().activate(est, now_us)
        self.hold = est.pos_ned_m.astype(float).copy()

    def shift(self, delta_ned_m: np.ndarray) -> None:
        """Move the held point with an estimator reset, so the vehicle itself does not move."""
        self.hold = self.hold + delta_ned_m

    def _dz(self, x: float) -> float:
        return deadzone(x, self.params.get("MPC_HOLD_DZ"))

    def update(self, est: VehicleEstimate, now_us: int) -> PositionSetpoint | None:
        """The setpoint for this step; None on the ground until the pilot raises the throttle."""
        dt = self._dt(now_us)
        s = self.sticks()
        up = self._dz(climb_stick(s.throttle)) if s is not None else 0.0
        if self.on_ground:
            self.hold = est.pos_ned_m.astype(float).copy()
            self._turn(est, 0.0, dt)
            self._on_ground_reset()
            if up <= TAKEOFF_STICK:
                return None
        else:
            self._turn(est, self._shaped(s.yaw, "MPC_YAW_EXPO") if s is not None else 0.0, dt)
        pos_d, vel_d = self._vertical(est, stick_expo.expo(up, self.params.get("MPC_Z_MAN_EXPO")), dt)
        pos, vel, acc = self._horizontal(est, s, dt)
        pos[2], vel[2], acc[2] = pos_d, vel_d, 0.0
        return PositionSetpoint(pos, vel, self.yaw_rad, acc)

    def _on_ground_reset(self) -> None:
        """Forget horizontal motion while on the ground (subclasses)."""

    def _stopped(self, axis: int, speed: float, dt: float) -> bool:
        """Braking on ``axis`` (0 horizontal, 1 vertical) is over: slow enough, braked long enough, or no speed."""
        self.braking_s[axis] += dt
        return not speed >= STOPPED_M_S or self.braking_s[axis] >= BRAKE_MAX_S

    def _vertical(self, est: VehicleEstimate, up: float, dt: float) -> tuple[float, float]:
        """(down position or NaN, down velocity) from the zero-centred throttle after the deadzone and the expo."""
        p = self.params
        if up != 0.0:
            self.hold[2], self.braking_s[1] = math.nan, 0.0
            limit = p.get("MPC_Z_VEL_MAX_UP") if up > 0 else p.get("MPC_Z_VEL_MAX_DN")
            return math.nan, -up * limit
        if math.isnan(self.hold[2]):
            if not self._stopped(1, abs(float(est.vel_ned_m_s[2])), dt):
                return math.nan, 0.0  # braking
            self.hold[2] = float(est.pos_ned_m[2])
        return float(self.hold[2]), 0.0

    def _horizontal(
        self, est: VehicleEstimate, s: ManualInput | None, dt: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        raise NotImplementedError


class PosCtlTask(_HeightHoldTask):
    """POSCTL: sticks command velocity in the heading frame; centred, brake and hold (module docstring)."""

    def __init__(self, params: ParameterStore, sticks: Sticks) -> None:
        super().__init__(params, sticks)
        self.vel_xy = np.zeros(2)  # the stick velocity setpoint flown, m/s north, east

    def activate(self, est: VehicleEstimate, now_us: int) -> None:
        super().activate(est, now_us)
        self.vel_xy = np.zeros(2)

    def _on_ground_reset(self) -> None:
        self.vel_xy = np.zeros(2)

    def update(self, est: VehicleEstimate, now_us: int) -> PositionSetpoint | None:
        if self.sticks() is None:  # no pilot: hold where the task started (idle on the ground)
            self._dt(now_us)
            if self.on_ground:
                return None
            return PositionSetpoint(self.hold.copy(), np.zeros(3), self.yaw_rad, np.zeros(3))
        return super().update(est, now_us)

    def _horizontal(
        self, est: VehicleEstimate, s: ManualInput | None, dt: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        p = self.params
        nan = math.nan
        xy = (0.0, 0.0) if s is None or self.on_ground else (s.pitch, s.roll)
        fwd, right = unit_disc(*(self._shaped(v, "MPC_XY_MAN_EXPO") for v in xy))
        want = heading_to_ned(fwd, right, est.yaw_rad) * p.get("MPC_VEL_MANUAL")
        step = want - self.vel_xy
        max_step = p.get("MPC_ACC_HOR_MAX") * dt
        n = math.hypot(step[0], step[1])
        if n > max_step:
            step *= max_step / n
        acc = step / dt if dt > 0 else np.zeros(2)
        self.vel_xy = self.vel_xy + step
        moving = fwd != 0.0 or right != 0.0 or bool(np.any(self.vel_xy != 0.0))
        if moving:
            self.hold[:2], self.braking_s[0] = nan, 0.0
            return np.array([nan, nan, nan]), np.array([*self.vel_xy, 0.0]), np.array([*acc, 0.0])
        if math.isnan(self.hold[0]):
            speed = math.hypot(float(est.vel_ned_m_s[0]), float(est.vel_ned_m_s[1]))
            if not self._stopped(0, speed, dt):
                return np.array([nan, nan, nan]), np.zeros(3), np.zeros(3)  # braking
            self.hold[:2] = est.pos_ned_m[:2]
        return np.array([self.hold[0], self.hold[1], nan]), np.zeros(3), np.zeros(3)


class AltCtlTask(_HeightHoldTask):
    """ALTCTL: sticks command tilt (horizontal acceleration, north/east otherwise free); module docstring."""

    def _horizontal(
        self, est: VehicleEstimate, s: ManualInput | None, dt: float
    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        nan = math.nan
        self.hold[:2] = nan  # ALTCTL never holds a horizontal position
        fwd, right = (0.0, 0.0) if s is None or self.on_ground else unit_disc(self._dz(s.pitch), self._dz(s.roll))
        n = math.hypot(fwd, right)
        acc = np.zeros(2)
        if n > 0.0:
            tilt = n * math.radians(self.params.get("MPC_MAN_TILT_MAX"))
            acc = heading_to_ned(fwd / n, right / n, est.yaw_rad) * (GRAVITY_M_S2 * math.tan(tilt))
        return np.array([nan, nan, nan]), np.array([nan, nan, nan]), np.array([*acc, 0.0])


class _ThrottleTask(_PilotedTask):
    """STABILIZED and ACRO: collective thrust straight from the throttle stick."""

    def __init__(self, params: ParameterStore, sticks: Sticks, hover_thrust_frac: float) -> None:
        super().__init__(params, sticks)
        self.hover_thrust_frac = hover_thrust_frac

    def _thrust(self, throttle: float) -> float:
        p = self.params
        low, high = p.get("MPC_MANTHR_MIN"), p.get("MPC_THR_MAX")
        return thrust_curve(throttle, min(max(self.hover_thrust_frac, low), high), low, high)

    def _sticks(self) -> ManualInput | None:
        """The sticks, or None when the motors should idle (on the ground, throttle at the bottom or no sticks)."""
        s = self.sticks()
        if self.on_ground and (s is None or s.throttle <= THROTTLE_BOTTOM):
            return None
        return s if s is not None else ManualInput(0, 0.0, 0.0, 0.0, 0.5, 0.0)


class StabilizedTask(_ThrottleTask):
    """STABILIZED: attitude from the sticks, heading from the yaw stick's rate (module docstring)."""

    def update(self, est: VehicleEstimate, now_us: int) -> AttitudeSetpoint | None:
        dt = self._dt(now_us)
        s = self._sticks()
        if s is None:
            self._turn(est, 0.0, dt)
            return None
        self._turn(est, self._shaped(s.yaw, "MPC_YAW_EXPO"), dt)
        tilt_max = math.radians(self.params.get("MPC_MAN_TILT_MAX"))
        roll, pitch = unit_disc(s.roll, -s.pitch)  # rotation about forward (roll) and right (pitch) axes
        angle = math.hypot(roll, pitch) * tilt_max
        if angle > 0.0:
            k = math.sin(angle / 2) / math.hypot(roll, pitch)
            tilt = np.array([math.cos(angle / 2), k * roll, k * pitch, 0.0])
        else:
            tilt = np.array([1.0, 0.0, 0.0, 0.0])
        q = quat.mul(quat.from_euler(0.0, 0.0, self.yaw_rad), tilt)
        return AttitudeSetpoint(q, None, self._thrust(s.throttle), self.yaw_rate_rad_s)


class AcroTask(_ThrottleTask):
    """ACRO: body rates from the sticks (MC_ACRO_*_MAX, shaped by MC_ACRO_EXPO(_Y) and MC_ACRO_SUPEXPO(Y)), thrust as
    STABILIZED."""

    def update(self, est: VehicleEstimate, now_us: int) -> AttitudeSetpoint | None:
        self._dt(now_us)
        s = self._sticks()
        if s is None:
            return None
        p = self.params

        def rate(stick: float, name: str, expo: str, sup: str) -> float:
            return stick_expo.superexpo(stick, p.get(expo), p.get(sup)) * math.radians(p.get(name))

        rp = ("MC_ACRO_EXPO", "MC_ACRO_SUPEXPO")
        rates = np.array([
            rate(s.roll, "MC_ACRO_R_MAX", *rp), rate(-s.pitch, "MC_ACRO_P_MAX", *rp),
            rate(s.yaw, "MC_ACRO_Y_MAX", "MC_ACRO_EXPO_Y", "MC_ACRO_SUPEXPOY"),
        ])  # fmt: skip
        return AttitudeSetpoint(None, rates, self._thrust(s.throttle))
