"""Body-rate PID (PX4's RateControl), output as angular acceleration.

alpha_sp = P e + I integral(e) + D d(-rate)/dt, per FRD axis, in rad/s^2; the
caller turns it into torque with the vehicle's inertia (tau = J alpha), so gains
carry over between airframes.  Seed 000 section 3.4's clamps: the integrator is
limited to MC_*R_INT_LIM and stops growing on an axis the mixer reports
saturated in the same direction.  NaN inputs never reach the integrator.
"""

from __future__ import annotations

import math

import numpy as np

from autopilot.parameters import ParamDef, ParameterStore, param


# The parameters this module reads (listed in autopilot/param_catalogue.py).
PARAMS: tuple[ParamDef, ...] = (
    param("MC_ROLLRATE_P", 12.0, 0.0, 150.0, "1/s", "Roll rate P: angular acceleration (rad/s^2) per rad/s of error"),
    param("MC_ROLLRATE_I", 6.0, 0.0, 60.0, "1/s^2", "Roll rate integral gain"),
    param("MC_ROLLRATE_D", 0.15, 0.0, 2.0, "-", "Roll rate derivative gain"),
    param("MC_PITCHRATE_P", 12.0, 0.0, 150.0, "1/s", "Pitch rate P: angular acceleration (rad/s^2) per rad/s of error"),
    param("MC_PITCHRATE_I", 6.0, 0.0, 60.0, "1/s^2", "Pitch rate integral gain"),
    param("MC_PITCHRATE_D", 0.15, 0.0, 2.0, "-", "Pitch rate derivative gain"),
    param("MC_YAWRATE_P", 6.0, 0.0, 60.0, "1/s", "Yaw rate P: angular acceleration (rad/s^2) per rad/s of error"),
    param("MC_YAWRATE_I", 2.0, 0.0, 60.0, "1/s^2", "Yaw rate integral gain"),
    param("MC_YAWRATE_D", 0.0, 0.0, 2.0, "-", "Yaw rate derivative gain"),
    param("MC_RR_INT_LIM", 5.0, 0.0, 50.0, "rad/s^2", "Roll rate integrator clamp"),
    param("MC_PR_INT_LIM", 5.0, 0.0, 50.0, "rad/s^2", "Pitch rate integrator clamp"),
    param("MC_YR_INT_LIM", 3.0, 0.0, 50.0, "rad/s^2", "Yaw rate integrator clamp"),
    param("MC_RATE_D_LIM", 100.0, 0.0, 1000.0, "rad/s^2", "Clamp of the rate derivative term (seed 000 3.4)"),
)

_D_CUTOFF_HZ = 30.0


class RateControl:
    def __init__(self, params: ParameterStore) -> None:
        self.params = params
        self.integral = [0.0, 0.0, 0.0]  # rad/s^2
        self.prev_rate: list[float] | None = None
        self.d_filtered = [0.0, 0.0, 0.0]
        self._load()
        params.subscribe(lambda name, value: self._load() if name.startswith("MC_") else None)

    def _load(self) -> None:
        g = self.params.get
        axes = ("ROLL", "PITCH", "YAW")
        self.p = [g(f"MC_{a}RATE_P") for a in axes]
        self.i = [g(f"MC_{a}RATE_I") for a in axes]
        self.d = [g(f"MC_{a}RATE_D") for a in axes]
        self.int_lim = [g("MC_RR_INT_LIM"), g("MC_PR_INT_LIM"), g("MC_YR_INT_LIM")]
        self.d_lim = g("MC_RATE_D_LIM")

    def reset(self) -> None:
        self.integral = [0.0, 0.0, 0.0]
        self.prev_rate = None
        self.d_filtered = [0.0, 0.0, 0.0]

    def update(self, rate: np.ndarray, rate_sp: np.ndarray, dt: float,
               sat_pos: np.ndarray | None = None, sat_neg: np.ndarray | None = None,
               integrate: bool = True) -> np.ndarray:
        """Angular acceleration setpoint (rad/s^2, FRD).

        ``sat_pos``/``sat_neg``: per axis, the mixer could not deliver more
        positive / negative torque last step; the integrator does not grow that way.
        Runs at the IMU rate on Python floats (three axes; cheaper than numpy calls).
        """
        err = [float(rate_sp[i]) - float(rate[i]) for i in range(3)]
        if not math.isfinite(err[0] + err[1] + err[2]):
            return np.zeros(3)  # NaN never reaches the integrator
        if self.prev_rate is not None and dt > 0:
            a = dt / (dt + 1.0 / (2 * math.pi * _D_CUTOFF_HZ))
            for i in range(3):
                raw = -(float(rate[i]) - self.prev_rate[i]) / dt
                self.d_filtered[i] += a * (raw - self.d_filtered[i])
        self.prev_rate = [float(rate[0]), float(rate[1]), float(rate[2])]
        out = [0.0, 0.0, 0.0]
        lim = self.d_lim
        for i in range(3):
            d_term = min(max(self.d[i] * self.d_filtered[i], -lim), lim)
            out[i] = self.p[i] * err[i] + self.integral[i] + d_term
            if integrate and dt > 0:
                grow = self.i[i] * err[i] * dt
                if (grow > 0 and sat_pos is not None and sat_pos[i]) or (grow < 0 and sat_neg is not None and sat_neg[i]):
                    grow = 0.0
                self.integral[i] = min(max(self.integral[i] + grow, -self.int_lim[i]), self.int_lim[i])
        return np.array(out)
