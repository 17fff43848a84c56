"""Orbit (MAV_CMD_DO_ORBIT): circle a centre at a radius and speed, facing as the yaw behaviour says.

The setpoint moves on the circle: its angle ``theta`` about the centre (atan2(east, north),
so a growing angle is clockwise seen from above) advances at ``speed / radius``; the
setpoint's radius starts at the vehicle's distance from the centre and moves to the
commanded radius at up to MPC_XY_CRUISE (accelerating and braking at MPC_ACC_HOR), so a
vehicle at the centre flies out to the circle without a jump; the tangential speed ramps
up at MPC_ACC_HOR too.  The velocity (tangential + radial) and the centripetal
acceleration are fed forward.  The altitude moves to the commanded one at 70 % of
MPC_Z_VEL_MAX_UP / _DN.  As PX4's FlightTaskOrbit, the speed is limited so the centripetal
acceleration stays within MPC_ACC_HOR and to ORBIT_SPEED_MAX_M_S.

Yaw behaviour (ORBIT_YAW_BEHAVIOUR): 0 front to the centre, 1 the initial heading,
2 uncontrolled (the initial heading is held), 3 front along the tangent, 4 RC-controlled
(no sticks here: as 0).  MC_ORBIT_YAW_MOD is the default when the command gives none.

Frames and units: metres NED from the estimator origin, m/s, m/s^2, yaw radians; time is
simulated microseconds.
"""

from __future__ import annotations

import math

import numpy as np

from autopilot.navigation.flight_task import PositionSetpoint
from autopilot.parameters import ParamDef, ParameterStore, ParamType, param
from autopilot.topics import VehicleEstimate

PARAMS: tuple[ParamDef, ...] = (
    param("MC_ORBIT_RAD_MAX", 1000.0, 1.0, 10000.0, "m", "Maximum radius of an orbit"),
    param(
        "MC_ORBIT_YAW_MOD", 0, 0, 4, "", "Orbit yaw behaviour when the command gives none (0: face the centre, "
        "1: initial heading, 2: uncontrolled, 3: tangent, 4: RC controlled)", ParamType.INT32,
    ),
)  # fmt: skip

ORBIT_RADIUS_MIN_M = 1.0  # PX4's smallest orbit
ORBIT_SPEED_MAX_M_S = 10.0  # PX4's fastest orbit
ORBIT_DEFAULT_RADIUS_M = 10.0  # a first orbit without a radius
ORBIT_DEFAULT_SPEED_M_S = 1.0  # PX4's default orbit speed
FACE_CENTRE, INITIAL_HEADING, UNCONTROLLED, TANGENT, RC_CONTROLLED = 0, 1, 2, 3, 4


def orbit_speed_limit(radius_m: float, accel_m_s2: float) -> float:
    """The fastest orbit of ``radius_m`` whose centripetal acceleration stays within ``accel_m_s2``."""
    return min(ORBIT_SPEED_MAX_M_S, math.sqrt(max(accel_m_s2, 0.0) * abs(radius_m)))


class OrbitTask:
    """Circle ``centre_ned_m`` (its down: the altitude flown) at ``radius_m`` (> 0 clockwise seen from above,
    < 0 counter-clockwise) and ``speed_m_s`` along the circle, yaw as ``yaw_behaviour``."""

    def __init__(
        self, centre_ned_m: np.ndarray, radius_m: float, speed_m_s: float, yaw_behaviour: int, params: ParameterStore
    ) -> None:
        self.centre = centre_ned_m.astype(float).copy()
        self.radius_m = float(radius_m)
        self.yaw_behaviour = int(yaw_behaviour)
        self.accel = params.get("MPC_ACC_HOR")
        self.radial_max = params.get("MPC_XY_CRUISE")
        self.up_max = 0.7 * params.get("MPC_Z_VEL_MAX_UP")
        self.down_max = 0.7 * params.get("MPC_Z_VEL_MAX_DN")
        self.speed_m_s = min(abs(speed_m_s), orbit_speed_limit(radius_m, self.accel))

    def activate(self, est: VehicleEstimate, now_us: int) -> None:
        """Start from the vehicle: its angle and distance about the centre, its altitude and heading."""
        d = est.pos_ned_m[:2] - self.centre[:2]
        self.r = float(np.hypot(*d))
        self.theta = math.atan2(d[1], d[0]) if self.r > 0.1 else est.yaw_rad
        self.v_r = 0.0  # radial speed of the setpoint, m/s (outwards)
        self.v_t = 0.0  # tangential speed, m/s
        self.down = float(est.pos_ned_m[2])
        self.v_down = 0.0
        self.initial_yaw = est.yaw_rad
        self.last_us = now_us

    @property
    def direction(self) -> float:
        """+1 clockwise (theta grows), -1 counter-clockwise."""
        return 1.0 if self.radius_m >= 0 else -1.0

    def set_speed(self, speed_m_s: float) -> None:
        """A new speed along the circle (DO_CHANGE_SPEED), within the centripetal limit."""
        self.speed_m_s = min(abs(speed_m_s), orbit_speed_limit(self.radius_m, self.accel))

    def _radial(self, dt: float) -> None:
        """Move the setpoint's radius towards |radius_m|: accelerate, cruise, brake onto it."""
        left = abs(self.radius_m) - self.r
        want = math.copysign(min(self.radial_max, math.sqrt(2.0 * self.accel * abs(left))), left)
        step = self.accel * dt
        self.v_r = min(max(want, self.v_r - step), self.v_r + step)
        self.r = max(self.r + self.v_r * dt, 0.0)
        if abs(left) < 1e-3 and abs(self.v_r) < step:
            self.r, self.v_r = abs(self.radius_m), 0.0

    def _vertical(self, dt: float) -> None:
        left = self.centre[2] - self.down
        limit = self.down_max if left > 0 else self.up_max
        want = math.copysign(min(limit, math.sqrt(2.0 * self.accel * abs(left))), left)
        step = self.accel * dt
        self.v_down = min(max(want, self.v_down - step), self.v_down + step)
        self.down += self.v_down * dt
        if abs(left) < 1e-3 and abs(self.v_down) < step:
            self.down, self.v_down = float(self.centre[2]), 0.0

    def update(self, est: VehicleEstimate, now_us: int) -> PositionSetpoint:
        """The point on the (growing or shrinking) circle, with velocity and centripetal acceleration."""
        dt = max((now_us - self.last_us) * 1e-6, 0.0)
        self.last_us = now_us
        self._radial(dt)
        self._vertical(dt)
        target = min(self.speed_m_s, orbit_speed_limit(max(self.r, ORBIT_RADIUS_MIN_M), self.accel))
        step = self.accel * dt
        self.v_t = min(max(target, self.v_t - step), self.v_t + step)
        self.theta += self.direction * self.v_t / max(self.r, ORBIT_RADIUS_MIN_M) * dt
        out = np.array([math.cos(self.theta), math.sin(self.theta)])
        along = self.direction * np.array([-out[1], out[0]])
        pos = np.array([*(self.centre[:2] + self.r * out), self.down])
        vel = np.array([*(self.v_t * along + self.v_r * out), self.v_down])
        acc = np.array([*(-(self.v_t**2) / max(self.r, ORBIT_RADIUS_MIN_M) * out), 0.0])
        return PositionSetpoint(pos, vel, self._yaw(along), acc)

    def _yaw(self, along: np.ndarray) -> float:
        if self.yaw_behaviour in (INITIAL_HEADING, UNCONTROLLED):
            return self.initial_yaw
        if self.yaw_behaviour == TANGENT:
            return math.atan2(along[1], along[0])
        return math.atan2(-math.sin(self.theta), -math.cos(self.theta))  # front to the centre

    @property
    def done(self) -> bool:
        return False  # circles until another task takes over

    @property
    def failed(self) -> bool:
        return False

    def shift(self, delta_ned_m: np.ndarray) -> None:
        """Move the centre with an estimator reset, so the vehicle itself does not move."""
        self.centre += delta_ned_m
        self.down += float(delta_ned_m[2])
