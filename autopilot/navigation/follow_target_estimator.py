"""The follow target's position and velocity, filtered and extrapolated (PX4's follow-target estimator).

FOLLOW_TARGET messages arrive at 1 Hz (MAVSDK's FollowMe repeats the last location every second and
sends at once when the application gives a new one) to 10 Hz (a ground vehicle's telemetry), with
GPS noise.  :class:`TargetEstimator` keeps the target's position (m NED) and velocity (m/s NED):

- between messages it extrapolates at constant velocity (:meth:`TargetEstimator.predict`, at most
  :data:`TARGET_TIMEOUT_S` ahead);
- each message is fused as a fading-memory (critically damped) g-h filter with the discount factor
  theta = ``FLW_TGT_RS`` (0: take each measurement as it is, towards 1: smoother and slower):
  the position takes the share g = 1 - theta^2 of the residual (measured minus predicted); the velocity
  takes h = (1 - theta)^2 of the residual divided by the time since the last fusion, or, when the
  message carries a velocity, moves towards it by ``FLW_TGT_VG`` * g;
- a message repeating the last fused one (MAVSDK's keep-alive) is fused only once
  :data:`REPEAT_FUSION_S` has passed since the last fusion, so a target that stopped sending new
  positions is slowed to a stop instead of being extrapolated away (PX4 does the same).

The target is lost when its latest message is older than :data:`TARGET_TIMEOUT_S` (PX4's
GPS_MESSAGE_STALE_TIMEOUT_MS, 3 s); the flight task then holds (:mod:`.follow_target`).

Frames and units: metres NED from the estimator origin, m/s NED; time is simulated microseconds
handed in (nothing here reads a clock).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

TARGET_TIMEOUT_S = 3.0  # PX4's GPS_MESSAGE_STALE_TIMEOUT_MS: a target silent this long is lost
REPEAT_FUSION_S = 0.5  # PX4's MINIMUM_TIME_BETWEEN_POS_FUSIONS_MS: a repeated message is fused this often
MIN_VEL_DT_S = 0.05  # fusions closer than this in time do not derive a velocity from the position


@dataclass(frozen=True, slots=True)
class FollowTargetFix:
    """One FOLLOW_TARGET message, decoded (PX4's follow_target topic; kept here, not in
    :mod:`autopilot.topics`, which is at its length limit): where the target to follow is.

    Geodetic position (deg, m AMSL; converted to local NED by the follow task with the estimate's
    origin), velocity over ground m/s NED (NaN: not given), heading rad from north (NaN: no attitude).
    ``source`` is the sender's (system id, component id); ``capabilities`` its est_capabilities bits.
    ``received_us`` is the simulated time it arrived, ``received_wall_s`` the wall clock's
    (time.monotonic), as :class:`autopilot.topics.ManualInput`'s.
    """

    received_us: int
    received_wall_s: float
    source: tuple[int, int]
    lat_deg: float
    lon_deg: float
    alt_amsl_m: float
    vel_ned_m_s: np.ndarray
    yaw_rad: float = math.nan
    capabilities: int = 0


def filter_gains(responsiveness: float) -> tuple[float, float]:
    """(g, h) of the fading-memory g-h filter with the discount factor theta = ``responsiveness`` (0..1)."""
    theta = min(max(float(responsiveness), 0.0), 1.0)
    return 1.0 - theta * theta, (1.0 - theta) ** 2


class TargetEstimator:
    """Position and velocity of the target from its measurements (see the module docstring)."""

    def __init__(self) -> None:
        self.pos_ned_m: np.ndarray | None = None  # at ``fused_us``
        self.vel_ned_m_s = np.zeros(3)
        self.fused_us = 0
        self._last: tuple | None = None  # the last fused measurement, to recognise a repeat

    @property
    def valid(self) -> bool:
        return self.pos_ned_m is not None

    def reset(self) -> None:
        """Forget the target (after a loss: the next measurement starts afresh)."""
        self.pos_ned_m, self.vel_ned_m_s, self.fused_us, self._last = None, np.zeros(3), 0, None

    def fuse(
        self, pos_ned_m: np.ndarray, vel_ned_m_s: np.ndarray, t_us: int, responsiveness: float, vel_gain: float
    ) -> bool:
        """Fuse a measurement taken at ``t_us`` (velocity NaN: not measured); False if skipped as a repeat."""
        key = (*pos_ned_m.tolist(), *vel_ned_m_s.tolist())
        measured_vel = bool(np.all(np.isfinite(vel_ned_m_s)))
        if self.pos_ned_m is None:
            self.pos_ned_m = pos_ned_m.astype(float).copy()
            self.vel_ned_m_s = vel_ned_m_s.astype(float).copy() if measured_vel else np.zeros(3)
            self.fused_us, self._last = t_us, key
            return True
        dt = (t_us - self.fused_us) * 1e-6
        if key == self._last and dt < REPEAT_FUSION_S:
            return False
        g, h = filter_gains(responsiveness)
        pred_pos, pred_vel = self.predict(t_us)
        residual = pos_ned_m - pred_pos
        self.pos_ned_m = pred_pos + g * residual
        if measured_vel:
            self.vel_ned_m_s = pred_vel + min(max(vel_gain, 0.0), 1.0) * g * (vel_ned_m_s - pred_vel)
        elif dt >= MIN_VEL_DT_S:
            self.vel_ned_m_s = pred_vel + h * residual / dt
        self.fused_us, self._last = t_us, key
        return True

    def predict(self, t_us: int) -> tuple[np.ndarray, np.ndarray]:
        """(position, velocity) at ``t_us``: constant velocity from the last fusion, at most TARGET_TIMEOUT_S ahead."""
        if self.pos_ned_m is None:
            raise ValueError("no target measurement yet")
        ahead = min(max((t_us - self.fused_us) * 1e-6, 0.0), TARGET_TIMEOUT_S)
        return self.pos_ned_m + self.vel_ned_m_s * ahead, self.vel_ned_m_s.copy()
