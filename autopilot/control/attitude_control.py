"""Attitude P controller on quaternions (PX4's AttitudeControl, simplified).

Error quaternion q_e = q^-1 q_sp (body FRD); the rate setpoint is
2 sign(w_e) (x_e, y_e, z_e) times the per-axis gains MC_ROLL_P, MC_PITCH_P,
MC_YAW_P, limited to MC_*RATE_MAX.  Rates in rad/s.
"""

from __future__ import annotations

import math

import numpy as np

from autopilot.parameters import ParamDef, ParameterStore, param


# The parameters this module reads (listed in autopilot/param_catalogue.py).
PARAMS: tuple[ParamDef, ...] = (
    param("MC_ROLL_P", 6.5, 0.0, 12.0, "1/s", "Roll angle proportional gain"),
    param("MC_PITCH_P", 6.5, 0.0, 12.0, "1/s", "Pitch angle proportional gain"),
    param("MC_YAW_P", 2.8, 0.0, 5.0, "1/s", "Yaw angle proportional gain"),
    param("MC_ROLLRATE_MAX", 220.0, 0.0, 1800.0, "deg/s", "Maximum roll rate"),
    param("MC_PITCHRATE_MAX", 220.0, 0.0, 1800.0, "deg/s", "Maximum pitch rate"),
    param("MC_YAWRATE_MAX", 200.0, 0.0, 1800.0, "deg/s", "Maximum yaw rate"),
)


class AttitudeControl:
    def __init__(self, params: ParameterStore) -> None:
        self.params = params
        self._load()
        params.subscribe(lambda name, value: self._load() if name.startswith("MC_") else None)

    def _load(self) -> None:
        g = self.params.get
        self.gain = (g("MC_ROLL_P"), g("MC_PITCH_P"), g("MC_YAW_P"))
        self.rate_max = tuple(math.radians(g(n)) for n in ("MC_ROLLRATE_MAX", "MC_PITCHRATE_MAX", "MC_YAWRATE_MAX"))

    def update(self, q: np.ndarray, q_sp: np.ndarray) -> np.ndarray:
        """Rate setpoint (rad/s, FRD) that turns attitude q toward q_sp.

        Runs at the IMU rate on Python floats (q_e = q^-1 q_sp written out: cheaper than numpy calls)."""
        w, x, y, z = q.tolist()
        sw, sx, sy, sz = q_sp.tolist()
        ew = w * sw + x * sx + y * sy + z * sz
        e = (w * sx - x * sw - y * sz + z * sy,
             w * sy + x * sz - y * sw - z * sx,
             w * sz - x * sy + y * sx - z * sw)
        k = 2.0 if ew >= 0 else -2.0
        return np.array([min(max(k * e[i] * self.gain[i], -self.rate_max[i]), self.rate_max[i]) for i in range(3)])
