"""Land detector: an explicit state machine with named hysteresis times.

ON_GROUND -> IN_AIR when, armed, the thrust command exceeds a fraction of hover
and the vehicle has climbed TAKEOFF_HEIGHT_M above where it was armed.
IN_AIR -> ON_GROUND when vertical speed, horizontal speed and thrust, each
low-pass filtered over FILTER_TIME_S, have all been low for LNDMC_TRIG_TIME
seconds (the motors no longer carry the weight).  ``ground_contact`` is true
while those conditions hold, before the hysteresis time has run out; the rate
controller stops integrating then, because the legs, not the air, hold the
attitude.  Times are simulated seconds.
"""

from __future__ import annotations

import math
from enum import Enum

import numpy as np

from autopilot.parameters import ParamDef, ParameterStore, param

P_TRIG_TIME = param(
    "LNDMC_TRIG_TIME", 1.0, 0.1, 10.0, "s", "Time the landed conditions must hold before landing is declared"
)
P_Z_VEL_MAX = param("LNDMC_Z_VEL_MAX", 0.3, 0.1, 2.0, "m/s", "Maximum vertical speed while landed")
P_XY_VEL_MAX = param("LNDMC_XY_VEL_MAX", 1.0, 0.1, 5.0, "m/s", "Maximum horizontal speed while landed")

# The parameters this module reads (listed in autopilot/param_catalogue.py).
PARAMS: tuple[ParamDef, ...] = (
    P_TRIG_TIME,
    P_Z_VEL_MAX,
    P_XY_VEL_MAX,
)

_DEFAULTS = {p.name: p.default for p in (P_TRIG_TIME, P_Z_VEL_MAX, P_XY_VEL_MAX)}
TAKEOFF_HEIGHT_M = 0.3
TAKEOFF_THRUST_FRAC_OF_HOVER = 0.7
LANDED_THRUST_FRAC_OF_HOVER = 0.8
FILTER_TIME_S = 0.3


class Landed(Enum):
    ON_GROUND = "on ground"
    IN_AIR = "in air"


class LandDetector:
    def __init__(self, params: ParameterStore | None = None) -> None:
        self.state = Landed.ON_GROUND
        self.params = params
        self.ground_down_m = 0.0
        self._low_since_us: int | None = None
        self.landed_since_us: int | None = 0
        self._last_us: int | None = None
        self._f_vz = 0.0
        self._f_vxy = 0.0
        self._f_thrust = 1.0

    @property
    def ground_contact(self) -> bool:
        return self.state is Landed.ON_GROUND or self._low_since_us is not None

    def _filter(self, now_us: int, vel_ned: np.ndarray, thrust: float) -> None:
        dt = 0.0 if self._last_us is None else (now_us - self._last_us) * 1e-6
        self._last_us = now_us
        a = min(1.0, max(0.0, dt / FILTER_TIME_S))  # time going back filters nothing
        vn, ve, vd = vel_ned.tolist() if type(vel_ned) is np.ndarray else vel_ned  # floats: cheaper than numpy's
        self._f_vz += a * (abs(vd) - self._f_vz)
        self._f_vxy += a * (math.hypot(vn, ve) - self._f_vxy)
        self._f_thrust += a * (thrust - self._f_thrust)

    def on_arm(self, down_m: float) -> None:
        """Remember the height at arming as the ground."""
        self.ground_down_m = down_m
        self.state = Landed.ON_GROUND

    def update(
        self, now_us: int, armed: bool, vel_ned: np.ndarray, down_m: float, thrust_frac_of_hover: float
    ) -> Landed:
        self._filter(now_us, vel_ned, thrust_frac_of_hover)
        if not armed:
            if self.state is not Landed.ON_GROUND:
                self.landed_since_us = now_us
            self.state = Landed.ON_GROUND
            self._low_since_us = None
            return self.state
        if self.state is Landed.ON_GROUND:
            if thrust_frac_of_hover > TAKEOFF_THRUST_FRAC_OF_HOVER and down_m < self.ground_down_m - TAKEOFF_HEIGHT_M:
                self.state = Landed.IN_AIR
                self.landed_since_us = None
            return self.state
        get = self.params.get if self.params is not None else (lambda n: _DEFAULTS[n])
        quiet = (
            self._f_vz < get("LNDMC_Z_VEL_MAX")
            and self._f_vxy < get("LNDMC_XY_VEL_MAX")
            and self._f_thrust < LANDED_THRUST_FRAC_OF_HOVER
        )
        if not quiet:
            self._low_since_us = None
        elif self._low_since_us is None:
            self._low_since_us = now_us
        elif now_us - self._low_since_us >= get("LNDMC_TRIG_TIME") * 1e6:
            self.state = Landed.ON_GROUND
            self.landed_since_us = now_us
            self._low_since_us = None
        return self.state
