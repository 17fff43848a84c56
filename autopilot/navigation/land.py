"""Land: hold north/east and descend at a speed that slows near the ground (velocity control on D).

Above MPC_LAND_ALT1 over home the descent speed is the larger of MPC_LAND_SPEED and
MPC_Z_VEL_MAX_DN, below it MPC_LAND_SPEED (PX4's two-stage descent).  The descent speed
setpoint starts from the vehicle's own vertical speed at the first update and changes at
most MPC_ACC_DOWN_MAX per second, so the thrust never steps.  Without a horizontal
position (GPS lost) north/east are not controlled: the vehicle is held level (a horizontal
acceleration setpoint of zero, no velocity loop) and the height is the barometer's, as PX4's
Descend flies.  A velocity held at zero on the unaided inertial estimate would chase that
estimate's drift: after a few seconds of dead reckoning it is wrong by tenths of a metre per second,
and on touchdown, pushed by the legs' contact, the vehicle tilted to "stop" a motion it did not
have and skipped along the ground instead of landing.

The land never reports ``done``: touchdown is the land detector's call
(:mod:`autopilot.navigation.land_detector`), and the commander ends the task then.
Positions are metres NED relative to the estimator origin, speeds m/s (positive down).
"""

from __future__ import annotations

import math

import numpy as np

from autopilot.control import gains_from_params
from autopilot.navigation.flight_task import PositionSetpoint, defined_in
from autopilot.parameters import ParamDef, ParameterStore, param
from autopilot.topics import VehicleEstimate

_NO_POSITION = np.array([math.nan, math.nan, math.nan])
_LEVEL = np.array([0.0, 0.0, math.nan])  # m/s^2 NED: none horizontally, the vertical velocity loop's own

P_LAND_SPEED = param("MPC_LAND_SPEED", 0.7, 0.2, 2.0, "m/s", "Landing descent speed (final phase)")
P_ACC_DOWN_MAX = param(
    "MPC_ACC_DOWN_MAX",
    3.0,
    2.0,
    15.0,
    "m/s^2",
    "Largest change per second of the descent speed setpoint when landing starts or slows",
)
P_LAND_ALT1 = param("MPC_LAND_ALT1", 5.0, 0.0, 50.0, "m", "Below this height above home, descend at MPC_LAND_SPEED")

# The parameters the landing reads (listed in autopilot/param_catalogue.py); MPC_Z_VEL_MAX_DN is
# the position controller's.
PARAMS: tuple[ParamDef, ...] = (
    P_LAND_SPEED,
    P_ACC_DOWN_MAX,
    P_LAND_ALT1,
    defined_in(gains_from_params.POSITION_PARAMS, "MPC_Z_VEL_MAX_DN"),
)


class LandTask:
    """Descend at the parameters' speeds over ``north_east`` (m NED), heading ``yaw_rad``.

    ``home_down_m`` (m NED) is the height MPC_LAND_ALT1 is measured from.  ``north_east`` or
    ``yaw_rad`` None take the vehicle's at activation.
    """

    def __init__(
        self,
        home_down_m: float,
        params: ParameterStore,
        north_east: np.ndarray | None = None,
        yaw_rad: float | None = None,
    ) -> None:
        self.ne = None if north_east is None else north_east.astype(float).copy()
        self.yaw_rad = yaw_rad
        self.home_down_m = home_down_m
        self.params = params
        self._speed: float | None = None  # the descent speed setpoint flown, m/s down
        self._last_us: int | None = None

    def activate(self, est: VehicleEstimate, now_us: int) -> None:
        """Fix the point and heading (the estimate's where none was given); the speed starts at the first update."""
        if self.ne is None:
            self.ne = est.pos_ned_m[:2].astype(float).copy()
        if self.yaw_rad is None:
            self.yaw_rad = est.yaw_rad
        self._speed = None
        self._last_us = None

    def update(self, est: VehicleEstimate, now_us: int) -> PositionSetpoint:
        """North/east held (NaN without a position), down not controlled, the slewed descent speed."""
        height = self.home_down_m - float(est.pos_ned_m[2])
        slow = self.params.get("MPC_LAND_SPEED")
        want = slow if height < self.params.get("MPC_LAND_ALT1") else max(slow, self.params.get("MPC_Z_VEL_MAX_DN"))
        # Change the speed at most MPC_ACC_DOWN_MAX per second, starting from the vehicle's own: a step
        # of the velocity setpoint would cut the thrust at once (and tilt the vehicle further).
        if self._speed is None:
            vz = float(est.vel_ned_m_s[2])
            self._speed = vz if math.isfinite(vz) else 0.0
        dt = 0.0 if self._last_us is None else max(0.0, (now_us - self._last_us) * 1e-6)
        self._last_us = now_us
        step = self.params.get("MPC_ACC_DOWN_MAX") * dt
        self._speed += min(max(want - self._speed, -step), step)
        speed = self._speed
        assert self.ne is not None and self.yaw_rad is not None  # (activate fixed both)
        if not est.position_valid:  # level: no horizontal acceleration asked, the velocity left alone
            return PositionSetpoint(_NO_POSITION, np.array([math.nan, math.nan, speed]), self.yaw_rad, _LEVEL)
        return PositionSetpoint(np.array([self.ne[0], self.ne[1], math.nan]), np.array([0.0, 0.0, speed]), self.yaw_rad)

    @property
    def speed_m_s(self) -> float | None:
        """The descent speed setpoint flown (m/s, positive down); None before the first update."""
        return self._speed

    @property
    def done(self) -> bool:
        return False

    @property
    def failed(self) -> bool:
        return False

    def shift(self, delta_ned_m: np.ndarray) -> None:
        """Move the held point and home's height with an estimator reset."""
        if self.ne is not None:
            self.ne += delta_ned_m[:2]
        self.home_down_m += float(delta_ned_m[2])
