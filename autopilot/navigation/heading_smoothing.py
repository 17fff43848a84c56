"""A heading that turns toward its target at a limited rate and acceleration, and stops on it.

PX4 never hands a heading step to the attitude loop in its automatic modes: the flight task moves the
heading setpoint at most MPC_YAWRAUTO_MAX (FlightTaskAuto's yaw rate limit) and, in its go-to and
dead-reckoning return, also at most MPC_YAWRAUTO_ACC (its HeadingSmoothing), and it feeds the setpoint's
own rate forward as the yawspeed setpoint.  A step instead makes the attitude loop ask for its full
yaw rate (MC_YAW_P x the error, up to MC_YAWRATE_MAX); the vehicle speeds up as fast as its yaw
authority allows and, with the proportional law asking to slow down later than that authority can
stop it, sails past the heading: 16 to 18 deg on the quadcopter (its yaw authority is about
28 deg/s^2 at hover), 40 to 80 deg on the hexacopter (200 deg/s asked, 130 reached; benchmarks/
heading_benchmark.py, issue 36).

:class:`HeadingSmoothing` is that trajectory: each step its rate moves toward the fastest rate from which
it can still stop on the target at the acceleration limit (the braking curve of discrete steps, so the
last step lands on the target), never above the rate limit, changing by at most the acceleration limit
times the step.  Started from a turning vehicle (``reset`` with its yaw rate) it first slows down as
needed.  The heading is unwrapped inside (``turn`` gives turns of more than half a circle);
:meth:`update` takes the target either as the shorter way round (``shortest``) or as given.

Radians, rad/s, rad/s^2; ``dt`` seconds.  Pure: no clock, no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from autopilot.parameters import ParamDef, ParameterStore, param
from mavsim_core.quaternion import wrap_pi

P_YAW_ACC = param(
    "MPC_YAWRAUTO_ACC", 60.0, 5.0, 360.0, "deg/s^2", "Yaw acceleration of automatic modes (the heading's turns)"
)
YAW_RATE_DEFAULT_DEG_S = 45.0  # MPC_YAWRAUTO_MAX's default (declared with the mission runner, which reads it too)

PARAMS: tuple[ParamDef, ...] = (P_YAW_ACC,)  # (listed in the catalogue with the go-to's, goto.PARAMS)


@dataclass(frozen=True, slots=True)
class HeadingLimits:
    """How fast an automatic heading turns: rate (rad/s) and acceleration (rad/s^2), both > 0."""

    rate_rad_s: float = math.radians(YAW_RATE_DEFAULT_DEG_S)
    acc_rad_s2: float = math.radians(P_YAW_ACC.default)

    @classmethod
    def from_params(cls, params: ParameterStore, rate_rad_s: float | None = None) -> HeadingLimits:
        """MPC_YAWRAUTO_MAX (or ``rate_rad_s``) and MPC_YAWRAUTO_ACC."""
        rate = math.radians(params.get("MPC_YAWRAUTO_MAX")) if rate_rad_s is None else rate_rad_s
        return cls(rate, math.radians(params.get("MPC_YAWRAUTO_ACC")))


def stopping_rate(distance_rad: float, acc_rad_s2: float, dt: float) -> float:
    """The fastest rate (rad/s, >= 0) from which steps of ``dt``, each slower by ``acc_rad_s2 * dt`` (the heading
    moved by each step's rate), stop within ``distance_rad`` (>= 0).  From (n + f) a dt (n whole, 0 <= f < 1)
    the steps cover a dt^2 ((n + 1) f + n (n + 1) / 2): n is the whole part of the root of
    n (n + 1) / 2 = distance / (a dt^2), f what is left of the distance over n + 1 steps."""
    d = distance_rad / (acc_rad_s2 * dt * dt)
    n = math.floor(0.5 * (math.sqrt(1.0 + 8.0 * d) - 1.0))
    f = min(max((d - 0.5 * n * (n + 1)) / (n + 1), 0.0), 1.0)
    return (n + f) * acc_rad_s2 * dt


class HeadingSmoothing:
    """The heading (rad, unwrapped) and its rate (rad/s), turning toward a target within ``limits``."""

    def __init__(self, limits: HeadingLimits, heading_rad: float = 0.0, rate_rad_s: float = 0.0) -> None:
        self.limits = limits
        self.heading_rad = heading_rad
        self.rate_rad_s = rate_rad_s
        self.acc_rad_s2 = 0.0  # the latest step's change of rate / dt
        self.on_target = False  # the latest step ended on its target, at rest

    def reset(self, heading_rad: float, rate_rad_s: float = 0.0) -> None:
        """Start again from this heading and rate (a NaN rate: 0)."""
        self.heading_rad = heading_rad
        self.rate_rad_s = rate_rad_s if math.isfinite(rate_rad_s) else 0.0
        self.acc_rad_s2 = 0.0
        self.on_target = False

    @property
    def yaw_rad(self) -> float:
        """The heading wrapped to [-pi, pi) (an angle already inside is returned as it is, bit for bit)."""
        h = self.heading_rad
        return h if -math.pi <= h < math.pi else wrap_pi(h)

    def update(self, target_rad: float, dt: float, shortest: bool = True) -> float:
        """One step of ``dt`` s toward ``target_rad`` (the shorter way round if ``shortest``, else the unwrapped
        angle as given); the new heading, wrapped.  A NaN target or a ``dt`` not above 0 leaves it where it is."""
        if not (math.isfinite(target_rad) and dt > 0.0):
            return self.yaw_rad
        lim = self.limits
        h, r = self.heading_rad, self.rate_rad_s
        togo = wrap_pi(target_rad - h) if shortest else target_rad - h
        dv = lim.acc_rad_s2 * dt
        last = togo / dt  # the rate that reaches the target in this step
        self.on_target = abs(last - r) <= dv and abs(last) <= dv  # reachable, and stopping there is within the limit
        if self.on_target:  # (the target itself, not h + togo: a held heading stays the one given, bit for bit)
            self.heading_rad = target_rad if not shortest or -math.pi <= target_rad < math.pi else h + togo
            self.rate_rad_s, self.acc_rad_s2 = 0.0, -r / dt
            return self.yaw_rad
        wanted = math.copysign(min(lim.rate_rad_s, stopping_rate(abs(togo), lim.acc_rad_s2, dt)), togo)
        new = r + max(-dv, min(dv, wanted - r))
        self.heading_rad, self.rate_rad_s, self.acc_rad_s2 = h + new * dt, new, (new - r) / dt
        return self.yaw_rad


def yaw_rate_of(q_wxyz: np.ndarray, rate_frd_rad_s: np.ndarray) -> float:
    """The rate (rad/s) about NED down of body rates (FRD) at attitude ``q_wxyz`` (FRD -> NED): the heading's
    rate, for starting a turn from the vehicle's own motion."""
    w, x, y, z = q_wxyz.tolist()
    p, q, r = rate_frd_rad_s.tolist()
    return 2.0 * (x * z - w * y) * p + 2.0 * (y * z + w * x) * q + (w * w - x * x - y * y + z * z) * r
