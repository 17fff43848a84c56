"""AUTO.FOLLOW_TARGET (PX4's follow-me, MAVSDK's FollowMe): fly at a distance, angle and height from a target.

The target is what FOLLOW_TARGET messages say (a ground station's GPS, MAVSDK's
``follow_me.set_target_location``, the simulated ground vehicle's broadcast), decoded into
:class:`~autopilot.navigation.follow_target_estimator.FollowTargetFix` and filtered by
:class:`~autopilot.navigation.follow_target_estimator.TargetEstimator` (``FLW_TGT_RS``,
``FLW_TGT_VG``), extrapolated between messages.  Each step:

- the follow point is ``FLW_TGT_DST`` from the target along the orbit angle alpha (rad from north,
  target to follow point); alpha turns towards the target's course + ``FLW_TGT_FA`` (0 in front,
  90 on its right, 180 behind, -90 on its left; the target's heading while it moves slower than
  :data:`COURSE_MIN_SPEED_M_S`, if it sends an attitude, else alpha stays) at no more than
  ``FLW_TGT_MAX_VEL`` / ``FLW_TGT_DST`` rad/s, so the vehicle flies round the target, not over it;
  the orbit's centripetal acceleration and its speeding up and braking stay within MPC_ACC_HOR
  (:func:`orbit_limits`);
- the height is ``FLW_TGT_HT`` above home (``FLW_TGT_ALT_M`` 0; 1, above the terrain, is the same
  here: the ground is flat at home's altitude) or above the target (2), approached at 70 % of
  MPC_Z_VEL_MAX_UP / _DN; as PX4, the vehicle moves horizontally only within
  :data:`ALT_ACCEPTANCE_M` of that height;
- never lower than :data:`FLOOR_M` above home (a target reported below home, as a phone's GPS
  altitude often is, would otherwise take the vehicle to the ground: it landed and disarmed); and
  when the vehicle is below PX4's minimum safety altitude (:data:`MIN_SAFETY_ALT_M` above home), it
  stops moving horizontally and climbs at :data:`EMERGENCY_ASCENT_M_S` until above it, as PX4's
  emergency ascent does.  Each is said once per activation;
- the position setpoint's velocity goes towards the follow point's velocity (the target's, plus the
  orbit's) plus a closing speed on any gap (up to MPC_XY_CRUISE, braking at MPC_ACC_HOR), changing by
  no more than MPC_ACC_HOR: taking up the position from afar and swinging round a turning target are
  moves the vehicle can fly, not velocity steps it lags behind; following is exact once caught up;
  the setpoint's velocity and acceleration are fed forward;
- the nose points at the target (when more than :data:`YAW_MIN_DISTANCE_M` away).

Before the first message, and when the target is lost (no message for
:data:`~autopilot.navigation.follow_target_estimator.TARGET_TIMEOUT_S`, on both clocks), the vehicle
holds where it is, still in the mode, as PX4 does; it follows again when messages return.  The
task says so through ``say`` (the commander's STATUSTEXT).

Frames and units: metres NED from the estimator origin, m/s, radians; time is simulated µs.
"""

from __future__ import annotations

import math
from typing import Callable, Protocol

import numpy as np

from autopilot.navigation.flight_task import PositionSetpoint
from autopilot.navigation.follow_target_estimator import TARGET_TIMEOUT_S, FollowTargetFix, TargetEstimator
from autopilot.parameters import ParamDef, ParameterStore, ParamType, param
from autopilot.topics import VehicleEstimate
from mavsim_core.geodesy import geodetic_to_ned
from mavsim_core.quaternion import wrap_pi

# PX4's follow-target parameters (FlightTaskAutoFollowTarget), names, defaults, ranges and units as PX4's;
# PX4 sets no maximum for FLW_TGT_HT and FLW_TGT_DST: 1000 m here.
PARAMS: tuple[ParamDef, ...] = (
    param("FLW_TGT_HT", 8.0, 8.0, 1000.0, "m", "Follow height: above home (FLW_TGT_ALT_M 0, 1) or the target (2)"),
    param("FLW_TGT_DST", 8.0, 1.0, 1000.0, "m", "Horizontal distance from the target to follow it at"),
    param(
        "FLW_TGT_FA", 180.0, -180.0, 180.0, "deg",
        "Follow angle from the target's course (its heading while it stands): 0 in front, 90 right, 180 behind",
    ),
    param(
        "FLW_TGT_RS", 0.1, 0.0, 1.0, "",
        "Responsiveness of the target estimate: lower values follow the measurements faster, higher ones smooth more",
    ),
    param("FLW_TGT_VG", 0.9, 0.1, 1.0, "", "Velocity fusion gain of the target estimate relative to the position's"),
    param(
        "FLW_TGT_ALT_M", 0, 0, 2, "",
        "Altitude mode: 0 constant height above home, 1 above the terrain (flat: as 0), 2 track the target's altitude",
        ParamType.INT32,
    ),
    param(
        "FLW_TGT_MAX_VEL", 5.0, 0.0, 20.0, "m/s",
        "Fastest speed round the target while the follow angle's direction changes",
    ),
)  # fmt: skip

COURSE_MIN_SPEED_M_S = 0.5  # slower than this the target's course is not used (noise); its heading is
YAW_MIN_DISTANCE_M = 1.0  # closer than this the heading is held (PX4: MINIMUM_DISTANCE_TO_TARGET_FOR_YAW_CONTROL)
ALT_ACCEPTANCE_M = 3.0  # PX4's ALT_ACCEPTANCE_THRESHOLD: horizontal following starts this close to the height
CATCH_UP_GAIN_PER_S = 1.0  # below the braking profile, a gap closes at this rate
ALT_TRACK_TARGET = 2  # FLW_TGT_ALT_M
MIN_SAFETY_ALT_M = 1.0  # PX4's MINIMUM_SAFETY_ALTITUDE above home: below it, stop horizontally and climb ...
EMERGENCY_ASCENT_M_S = 0.5  # ... at this speed (PX4's EMERGENCY_ASCENT_SPEED)
# The lowest height flown (above home).  PX4 plans down to the target's height and only the emergency ascent
# stops it at 1 m, so it hovers on that threshold, stopping and starting its horizontal following; half a metre
# above it the height and position estimates' errors and the height loop's undershoot stay clear of it.
FLOOR_M = MIN_SAFETY_ALT_M + 0.5
SEVERITY_WARNING, SEVERITY_INFO = 4, 6  # MAV_SEVERITY values of what the task says


class FollowInputs(Protocol):
    """What is read of :class:`autopilot.commander.external_inputs.ExternalInputs` (ages in s, both clocks)."""

    follow_target: FollowTargetFix | None

    def follow_target_age_s(self, now_us: int, wall_s: float | None) -> float | None: ...


def fresh_target(inputs: FollowInputs, now_us: int, wall_s: float | None) -> FollowTargetFix | None:
    """The latest target message if it is younger than TARGET_TIMEOUT_S (on either clock), else None."""
    age = inputs.follow_target_age_s(now_us, wall_s)
    return inputs.follow_target if age is not None and age <= TARGET_TIMEOUT_S else None


def follow_point(target_ned_m: np.ndarray, alpha_rad: float, distance_m: float) -> np.ndarray:
    """The horizontal point ``distance_m`` from the target along the bearing ``alpha_rad`` (from north), m NED."""
    return target_ned_m[:2] + distance_m * np.array([math.cos(alpha_rad), math.sin(alpha_rad)])


def orbit_limits(distance_m: float, speed_max_m_s: float, acc_m_s2: float) -> tuple[float, float]:
    """(rate rad/s, angular acceleration rad/s^2) of the orbit angle at ``distance_m`` from the target.

    The speed round the target is at most ``speed_max_m_s`` (FLW_TGT_MAX_VEL) and its centripetal
    acceleration at most half of ``acc_m_s2`` (MPC_ACC_HOR); speeding up and slowing down the orbit
    takes at most the other half, so the vehicle can fly the swing as it is set."""
    half = 0.5 * max(acc_m_s2, 0.0)
    return min(max(speed_max_m_s, 0.0) / distance_m, math.sqrt(half / distance_m)), half / distance_m


def step_angle(
    alpha_rad: float, rate_rad_s: float, goal_rad: float, limits: tuple[float, float], dt_s: float
) -> tuple[float, float]:
    """``alpha_rad`` turned towards ``goal_rad`` the short way; its rate at most ``limits[0]``, changing by
    at most ``limits[1] * dt_s``, braking to arrive at rest.  (new angle, new rate)."""
    moved, rate = approach(0.0, rate_rad_s, wrap_pi(goal_rad - alpha_rad), limits[0], limits[1], dt_s)
    return wrap_pi(alpha_rad + moved), rate


def approach(pos: float, vel: float, goal: float, v_max: float, a_max: float, dt: float) -> tuple[float, float]:
    """One step of a 1-D move to ``goal``: speed up to ``v_max``, accelerate and brake at ``a_max``."""
    left = goal - pos
    want = math.copysign(min(v_max, math.sqrt(2.0 * a_max * abs(left))), left)
    vel = min(max(want, vel - a_max * dt), vel + a_max * dt)
    if abs(left) < 1e-3 and abs(vel) <= a_max * dt:
        return goal, 0.0
    return pos + vel * dt, vel


class FollowTargetTask:
    """AUTO.FOLLOW_TARGET (see the module docstring).  ``target()``: the latest fresh target message or None;
    ``home_down_m``: home's down (m NED), the ground the height is measured from; ``say(severity, text)``."""

    def __init__(
        self,
        params: ParameterStore,
        target: Callable[[], FollowTargetFix | None],
        home_down_m: float,
        say: Callable[[int, str], None] = lambda severity, text: None,
    ) -> None:
        self.params, self.target, self.home_down_m, self.say = params, target, float(home_down_m), say
        self.estimator = TargetEstimator()
        self.following = False  # a fresh target is being followed (False before the first and after a loss)
        self._fix: FollowTargetFix | None = None  # the last message handed to the estimator

    def activate(self, est: VehicleEstimate, now_us: int) -> None:
        """Hold where the vehicle is until the first target message."""
        self.hold = est.pos_ned_m.astype(float).copy()
        self.sp_xy = self.hold[:2].copy()  # the horizontal setpoint, m NED
        self.sp_vel = np.zeros(2)  # its velocity, m/s NED
        self.down, self.v_down = float(self.hold[2]), 0.0
        self.yaw_rad = est.yaw_rad
        self.alpha, self.alpha_rate = 0.0, 0.0  # the orbit angle (rad from north) and its rate (rad/s)
        self.last_us = now_us
        self.ascending = False  # in PX4's emergency ascent (below MIN_SAFETY_ALT_M above home)
        self._said: set[str] = set()  # what is said once per activation

    def update(self, est: VehicleEstimate, now_us: int) -> PositionSetpoint:
        dt = min(max((now_us - self.last_us) * 1e-6, 0.0), 0.1)
        self.last_us = now_us
        fix = self.target()
        if fix is None:
            if self.following:
                self.following = False
                self.say(SEVERITY_WARNING, f"Follow target lost (no FOLLOW_TARGET for {TARGET_TIMEOUT_S:g} s): holding")
                self.hold, self.yaw_rad = est.pos_ned_m.astype(float).copy(), est.yaw_rad
            return PositionSetpoint(self.hold.copy(), np.zeros(3), self.yaw_rad, np.zeros(3))
        if fix is not self._fix:
            self._fuse(fix, est)
        tgt, tgt_vel = self.estimator.predict(now_us)
        return self._follow(est, fix, tgt, tgt_vel, dt)

    def _fuse(self, fix: FollowTargetFix, est: VehicleEstimate) -> None:
        p = self.params
        pos = geodetic_to_ned(
            fix.lat_deg, fix.lon_deg, fix.alt_amsl_m, est.origin_lat_deg, est.origin_lon_deg, est.origin_alt_amsl_m
        )
        if not self.following:  # the first message, or the first after a loss: start afresh from here
            self.estimator.reset()
            d = est.pos_ned_m[:2] - pos[:2]
            self.alpha = math.atan2(d[1], d[0]) if math.hypot(*d) > 0.1 else est.yaw_rad + math.pi
            self.alpha_rate = 0.0
            self.sp_xy, self.sp_vel = est.pos_ned_m[:2].astype(float).copy(), est.vel_ned_m_s[:2].astype(float).copy()
            self.down, self.v_down = float(est.pos_ned_m[2]), 0.0
            self.following = True
            self.say(SEVERITY_INFO, f"Following target {fix.source[0]}/{fix.source[1]}")
        self.estimator.fuse(pos, fix.vel_ned_m_s, fix.received_us, p.get("FLW_TGT_RS"), p.get("FLW_TGT_VG"))
        self._fix = fix

    def _goal_angle(self, fix: FollowTargetFix, tgt_vel: np.ndarray) -> float | None:
        """Where alpha should go: the target's course (or heading) + FLW_TGT_FA; None: stay."""
        if math.hypot(tgt_vel[0], tgt_vel[1]) >= COURSE_MIN_SPEED_M_S:
            ref = math.atan2(tgt_vel[1], tgt_vel[0])
        elif math.isfinite(fix.yaw_rad):
            ref = fix.yaw_rad
        else:
            return None
        return ref + math.radians(self.params.get("FLW_TGT_FA"))

    def _follow(
        self, est: VehicleEstimate, fix: FollowTargetFix, tgt: np.ndarray, tgt_vel: np.ndarray, dt: float
    ) -> PositionSetpoint:
        p = self.params
        dist = p.get("FLW_TGT_DST")
        goal = self._goal_angle(fix, tgt_vel)
        limits = orbit_limits(dist, p.get("FLW_TGT_MAX_VEL"), p.get("MPC_ACC_HOR"))
        self.alpha, self.alpha_rate = step_angle(
            self.alpha, self.alpha_rate, self.alpha if goal is None else goal, limits, dt
        )
        point = follow_point(tgt, self.alpha, dist)
        point_vel = tgt_vel[:2] + self.alpha_rate * dist * np.array([-math.sin(self.alpha), math.cos(self.alpha)])
        to_target = tgt[:2] - est.pos_ned_m[:2]
        if math.hypot(*to_target) > YAW_MIN_DISTANCE_M:
            self.yaw_rad = math.atan2(to_target[1], to_target[0])
        if self.home_down_m - float(est.pos_ned_m[2]) < MIN_SAFETY_ALT_M:
            return self._ascend(est, dt)
        if self.ascending:  # back above the minimum: take the following up from where the vehicle is
            self.ascending = False
            self.sp_xy, self.sp_vel = est.pos_ned_m[:2].astype(float).copy(), est.vel_ned_m_s[:2].astype(float).copy()
        goal_down = self._goal_down(tgt)
        v_max = 0.7 * (p.get("MPC_Z_VEL_MAX_DN") if goal_down > self.down else p.get("MPC_Z_VEL_MAX_UP"))
        self.down, self.v_down = approach(self.down, self.v_down, goal_down, v_max, p.get("MPC_ACC_HOR"), dt)
        acc_xy = np.zeros(2)
        if abs(goal_down - float(est.pos_ned_m[2])) <= ALT_ACCEPTANCE_M:
            acc_xy = self._track(point, point_vel, dt)
        else:  # climb (or descend) to the height first, where the vehicle is
            self.sp_vel = np.zeros(2)
        pos = np.array([*self.sp_xy, self.down])
        return PositionSetpoint(pos, np.array([*self.sp_vel, self.v_down]), self.yaw_rad, np.array([*acc_xy, 0.0]))

    def _goal_down(self, tgt: np.ndarray) -> float:
        """The height to follow at (m NED down): FLW_TGT_HT above home or the target, never below FLOOR_M above home."""
        p = self.params
        ground = tgt[2] if int(p.get("FLW_TGT_ALT_M")) == ALT_TRACK_TARGET else self.home_down_m
        goal_down = ground - p.get("FLW_TGT_HT")
        floor_down = self.home_down_m - FLOOR_M
        if goal_down > floor_down:
            asked = self.home_down_m - goal_down
            text = f"Follow target: {asked:.1f} m above home asked: following at the minimum, {FLOOR_M:g} m"
            self._say_once("floor", text)
            return floor_down
        return goal_down

    def _ascend(self, est: VehicleEstimate, dt: float) -> PositionSetpoint:
        """PX4's emergency ascent: no horizontal position control (the velocity brought to zero: it stops where it
        can), the height setpoint rising at EMERGENCY_ASCENT_M_S from the vehicle (or the setpoint, if higher)."""
        if not self.ascending:
            self.ascending = True
            self.down = min(self.down, float(est.pos_ned_m[2]))
            text = f"Follow target: under {MIN_SAFETY_ALT_M:g} m above home: climbing at {EMERGENCY_ASCENT_M_S:g} m/s"
            self._say_once("ascent", text)
        self.v_down = -EMERGENCY_ASCENT_M_S
        self.down += self.v_down * dt
        self.sp_vel = np.zeros(2)
        pos = np.array([math.nan, math.nan, self.down])
        return PositionSetpoint(pos, np.array([0.0, 0.0, self.v_down]), self.yaw_rad, np.zeros(3))

    def _say_once(self, key: str, text: str) -> None:
        """A warning said once per activation of the mode, however long its cause lasts."""
        if key not in self._said:
            self._said.add(key)
            self.say(SEVERITY_WARNING, text)

    def _track(self, point: np.ndarray, point_vel: np.ndarray, dt: float) -> np.ndarray:
        """Move the setpoint one step towards the follow point; its acceleration (m/s^2 NED, horizontal).

        The wanted velocity is the point's plus a closing speed on the gap (up to MPC_XY_CRUISE, braking
        at MPC_ACC_HOR, at most CATCH_UP_GAIN_PER_S * gap); the setpoint's velocity changes towards it by
        at most MPC_ACC_HOR * dt."""
        gap = point - self.sp_xy
        size = float(np.hypot(*gap))
        acc, cruise = self.params.get("MPC_ACC_HOR"), self.params.get("MPC_XY_CRUISE")
        closing = min(cruise, math.sqrt(2.0 * acc * size), CATCH_UP_GAIN_PER_S * size)
        want = point_vel + (gap / size * closing if size > 1e-6 else 0.0)
        change = want - self.sp_vel
        n = float(np.hypot(*change))
        if n > acc * dt:
            change = change / n * acc * dt
        self.sp_vel = self.sp_vel + change
        self.sp_xy = self.sp_xy + self.sp_vel * dt
        return change / dt if dt > 0 else np.zeros(2)

    @property
    def done(self) -> bool:
        return False  # follows until another mode is chosen

    @property
    def failed(self) -> bool:
        return False

    def shift(self, delta_ned_m: np.ndarray) -> None:
        """Move the setpoint with an estimator reset (the target itself comes in geodetic coordinates)."""
        self.hold = self.hold + delta_ned_m
        self.sp_xy = self.sp_xy + delta_ned_m[:2]
        self.down += float(delta_ned_m[2])
