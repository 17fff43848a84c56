"""IMU increments summed between filter runs: delta angle (rad) and delta velocity (m/s), FRD, and their span.

PX4's downsampled delta angle and delta velocity: each 250 Hz sample adds rate x dt and specific force x dt;
a filter running at 50 Hz (or 10 Hz) takes the sums since it last ran.  Plain floats: on this per-sample path
NumPy's calls on 3-vectors cost more than their arithmetic.
"""

from __future__ import annotations


class ImuIncrements:
    """Summed ``dth`` (rad, FRD), ``dvel`` (m/s, FRD) over ``t`` seconds."""

    __slots__ = ("dth", "dvel", "t")

    def __init__(self) -> None:
        self.dth = [0.0, 0.0, 0.0]
        self.dvel = [0.0, 0.0, 0.0]
        self.t = 0.0

    def add_sample(self, gx: float, gy: float, gz: float, ax: float, ay: float, az: float, dt: float) -> None:
        """One sample: gyro (rad/s) and accelerometer (m/s^2), FRD, held for ``dt`` seconds."""
        dth, dvel = self.dth, self.dvel
        dth[0] += gx * dt
        dth[1] += gy * dt
        dth[2] += gz * dt
        dvel[0] += ax * dt
        dvel[1] += ay * dt
        dvel[2] += az * dt
        self.t += dt

    def add(self, dth: list[float], dvel: list[float], t: float) -> None:
        """Increments summed elsewhere (over ``t`` seconds)."""
        mine, minev = self.dth, self.dvel
        mine[0] += dth[0]
        mine[1] += dth[1]
        mine[2] += dth[2]
        minev[0] += dvel[0]
        minev[1] += dvel[1]
        minev[2] += dvel[2]
        self.t += t

    def take(self) -> tuple[list[float], list[float], float]:
        """The sums (delta angle, delta velocity, seconds), and start afresh."""
        out = (self.dth, self.dvel, self.t)
        self.dth, self.dvel, self.t = [0.0, 0.0, 0.0], [0.0, 0.0, 0.0], 0.0
        return out
