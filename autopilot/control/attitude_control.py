"""Attitude P controller on quaternions (PX4's AttitudeControl, simplified).

Error quaternion q_e = q^-1 q_sp (body FRD); the rate setpoint is
2 sign(w_e) (x_e, y_e, z_e) times the per-axis gains MC_ROLL_P, MC_PITCH_P,
MC_YAW_P, limited to MC_*RATE_MAX.  Rates in rad/s.
"""

from __future__ import annotations

import numpy as np

from autopilot import quat
from autopilot.parameters import ParameterStore, declare

declare("MC_ROLL_P", 6.5, 0.0, 12.0, "1/s", "Roll angle proportional gain")
declare("MC_PITCH_P", 6.5, 0.0, 12.0, "1/s", "Pitch angle proportional gain")
declare("MC_YAW_P", 2.8, 0.0, 5.0, "1/s", "Yaw angle proportional gain")
declare("MC_ROLLRATE_MAX", 220.0, 0.0, 1800.0, "deg/s", "Maximum roll rate")
declare("MC_PITCHRATE_MAX", 220.0, 0.0, 1800.0, "deg/s", "Maximum pitch rate")
declare("MC_YAWRATE_MAX", 200.0, 0.0, 1800.0, "deg/s", "Maximum yaw rate")


class AttitudeControl:
    def __init__(self, params: ParameterStore) -> None:
        self.params = params
        self._load()
        params.subscribe(lambda name, value: self._load() if name.startswith("MC_") else None)

    def _load(self) -> None:
        g = self.params.get
        self.gain = np.array([g("MC_ROLL_P"), g("MC_PITCH_P"), g("MC_YAW_P")])
        self.rate_max = np.radians([g("MC_ROLLRATE_MAX"), g("MC_PITCHRATE_MAX"), g("MC_YAWRATE_MAX")])

    def update(self, q: np.ndarray, q_sp: np.ndarray) -> np.ndarray:
        """Rate setpoint (rad/s, FRD) that turns attitude q toward q_sp."""
        qe = quat.mul(quat.conj(q), q_sp)
        sign = 1.0 if qe[0] >= 0 else -1.0
        rate_sp = 2.0 * sign * qe[1:4] * self.gain
        return np.minimum(np.maximum(rate_sp, -self.rate_max), self.rate_max)

