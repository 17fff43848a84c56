"""Take-off: climb straight up from where the vehicle stands to a height, then hold there.

The climb is a go-to (:class:`~autopilot.navigation.goto.GotoTask`) from the vehicle's
position at activation to the same north/east at ``goal_down_m`` (metres NED, relative to
the estimator origin), at MPC_TKO_SPEED with TAKEOFF_ACCEL_M_S2.  ``done`` once the profile
has ended and the vehicle is within the go-to's arrival radius of the goal; the commander
then switches to a loiter at ``goal`` with ``yaw_rad``.
"""

from __future__ import annotations

import numpy as np

from autopilot.navigation.goto import GotoTask
from autopilot.parameters import ParamDef, ParameterStore, param
from autopilot.topics import VehicleEstimate

P_TAKEOFF_ALT = param("MIS_TAKEOFF_ALT", 2.5, 0.0, 100.0, "m", "Take-off altitude above home when none is given")
P_TKO_SPEED = param("MPC_TKO_SPEED", 1.5, 0.5, 5.0, "m/s", "Take-off climb speed")

# The parameters of the take-off (listed in autopilot/param_catalogue.py).  The commander reads
# MIS_TAKEOFF_ALT to choose the height when the command gives none; the task reads MPC_TKO_SPEED.
PARAMS: tuple[ParamDef, ...] = (
    P_TAKEOFF_ALT,
    P_TKO_SPEED,
)

TAKEOFF_ACCEL_M_S2 = 1.0  # acceleration of the climb profile, m/s^2


class TakeoffTask(GotoTask):
    """Climb from the position at activation to ``goal_down_m`` (m NED), keeping north, east and yaw."""

    def __init__(self, goal_down_m: float, params: ParameterStore) -> None:
        super().__init__(np.full(3, np.nan), 0.0, 0.0, TAKEOFF_ACCEL_M_S2)
        self.goal_down_m = goal_down_m
        self.params = params

    def activate(self, est: VehicleEstimate, now_us: int) -> None:
        """Start the climb from the estimated position and heading at ``now_us``."""
        self.goal = np.array([est.pos_ned_m[0], est.pos_ned_m[1], self.goal_down_m], dtype=float)
        self.yaw_rad = est.yaw_rad
        self.cruise_m_s = self.params.get("MPC_TKO_SPEED")
        self.start = None
        super().activate(est, now_us)
