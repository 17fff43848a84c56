"""Body-rate PID (PX4's RateControl), output as angular acceleration.

alpha_sp = P e + I integral(e) + D d(-rate)/dt, per FRD axis, in rad/s^2; the
caller turns it into torque with the vehicle's inertia (tau = J alpha), so gains
carry over between airframes.  Seed 000 section 3.4's clamps: the integrator is
limited to MC_*R_INT_LIM and stops growing on an axis the mixer reports
saturated in the same direction.  NaN inputs never reach the integrator.
"""

from __future__ import annotations

import numpy as np

from autopilot.parameters import ParameterStore, declare

declare("MC_ROLLRATE_P", 12.0, 0.0, 60.0, "1/s", "Roll rate P: angular acceleration (rad/s^2) per rad/s of error")
declare("MC_ROLLRATE_I", 6.0, 0.0, 60.0, "1/s^2", "Roll rate integral gain")
declare("MC_ROLLRATE_D", 0.15, 0.0, 2.0, "-", "Roll rate derivative gain")
declare("MC_PITCHRATE_P", 12.0, 0.0, 60.0, "1/s", "Pitch rate P: angular acceleration (rad/s^2) per rad/s of error")
declare("MC_PITCHRATE_I", 6.0, 0.0, 60.0, "1/s^2", "Pitch rate integral gain")
declare("MC_PITCHRATE_D", 0.15, 0.0, 2.0, "-", "Pitch rate derivative gain")
declare("MC_YAWRATE_P", 6.0, 0.0, 60.0, "1/s", "Yaw rate P: angular acceleration (rad/s^2) per rad/s of error")
declare("MC_YAWRATE_I", 2.0, 0.0, 60.0, "1/s^2", "Yaw rate integral gain")
declare("MC_YAWRATE_D", 0.0, 0.0, 2.0, "-", "Yaw rate derivative gain")
declare("MC_RR_INT_LIM", 5.0, 0.0, 50.0, "rad/s^2", "Roll rate integrator clamp")
declare("MC_PR_INT_LIM", 5.0, 0.0, 50.0, "rad/s^2", "Pitch rate integrator clamp")
declare("MC_YR_INT_LIM", 3.0, 0.0, 50.0, "rad/s^2", "Yaw rate integrator clamp")
declare("MC_RATE_D_LIM", 100.0, 0.0, 1000.0, "rad/s^2", "Clamp of the rate derivative term (seed 000 3.4)")

_D_CUTOFF_HZ = 30.0


class RateControl:
    def __init__(self, params: ParameterStore) -> None:
        self.params = params
        self.integral = np.zeros(3)
        self.prev_rate: np.ndarray | None = None
        self.d_filtered = np.zeros(3)
        self._load()
        params.subscribe(lambda name, value: self._load() if name.startswith("MC_") else None)

    def _load(self) -> None:
        g = self.params.get
        axes = ("ROLL", "PITCH", "YAW")
        self.p = np.array([g(f"MC_{a}RATE_P") for a in axes])
        self.i = np.array([g(f"MC_{a}RATE_I") for a in axes])
        self.d = np.array([g(f"MC_{a}RATE_D") for a in axes])
        self.int_lim = np.array([g("MC_RR_INT_LIM"), g("MC_PR_INT_LIM"), g("MC_YR_INT_LIM")])
        self.d_lim = g("MC_RATE_D_LIM")

    def reset(self) -> None:
        self.integral[:] = 0.0
        self.prev_rate = None
        self.d_filtered[:] = 0.0

    def update(self, rate: np.ndarray, rate_sp: np.ndarray, dt: float,
               sat_pos: np.ndarray | None = None, sat_neg: np.ndarray | None = None,
               integrate: bool = True) -> np.ndarray:
        """Angular acceleration setpoint (rad/s^2, FRD).

        ``sat_pos``/``sat_neg``: per axis, the mixer could not deliver more
        positive / negative torque last step; the integrator does not grow that way.
        """
        err = rate_sp - rate
        if not np.all(np.isfinite(err)):
            return np.zeros(3)
        if self.prev_rate is not None and dt > 0:
            raw = -(rate - self.prev_rate) / dt
            alpha = dt / (dt + 1.0 / (2 * np.pi * _D_CUTOFF_HZ))
            self.d_filtered += alpha * (raw - self.d_filtered)
        self.prev_rate = rate.copy()
        d_term = np.minimum(np.maximum(self.d * self.d_filtered, -self.d_lim), self.d_lim)
        out = self.p * err + self.integral + d_term
        if integrate and dt > 0:
            grow = self.i * err * dt
            if sat_pos is not None:
                grow = np.where(sat_pos & (grow > 0), 0.0, grow)
            if sat_neg is not None:
                grow = np.where(sat_neg & (grow < 0), 0.0, grow)
            self.integral = np.minimum(np.maximum(self.integral + grow, -self.int_lim), self.int_lim)
        return out
