"""How hard a precision landing may chase the deck: as hard as keeps the marker in the camera's view, not a fixed
tilt cap (issue 34 item 5).

Chasing a deck ahead, the vehicle tilts toward it and its down axis swings away from it: a body-fixed camera (PX4's
and [F]'s) looks past the marker once the tilt plus the marker's angle off straight down exceeds the half field of
view; a gimbal takes the tilt out up to its joints' reach, then the same happens.  :func:`view_cone` gives the cone
the vehicle's down axis must stay in (around the line of sight to the target estimate, half-angle = the gimbal's
reach + the camera's half field of view - a margin), which the position controller enforces by shortening the
horizontal thrust (:mod:`autopilot.control.thrust_cone`); inside MPC_TILTMAX_AIR, which stays the airframe's limit.

The gimbal's reach (PLD_CAM_REACH) is by default automatic (-1): the reach of the gimbal device the flight
controller sees, as its gimbal manager publishes it (:attr:`autopilot.mavlink.gimbal_control.DeviceRange.
tilt_reach_rad`, the smallest of the joints' reach from straight down; the commander hands it to the landing each
step), and 0 (a body-fixed camera) while no device reports or the manager is off: with ``SIM_CAM_MOUNT`` fixed
there is no gimbal device, and the cone is the fixed camera's without a parameter to set.  A value >= 0 is the
user's and wins.

How fast it may change its mind: PLD_ACC_SLEW caps how fast the chase's horizontal acceleration setpoint swings
(``ViewLimits.slew_m_s3``, carried by the landing's setpoints as ``PositionSetpoint.acc_slew_m_s3``): at a
figure-8's reversal an unlimited chase asked for 35 deg of tilt in 0.16 s and the vehicle sank 1 m.

Frames and units: NED metres; the parameters in degrees, radians inside (PLD_ACC_SLEW in m/s^3).  Pure.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numpy as np

from autopilot.control.thrust_cone import AxisCone
from autopilot.parameters import ParamDef, ParameterStore, ParamType, param

AUTO_REACH = -1.0  # PLD_CAM_REACH: follow the gimbal device the flight controller sees (0 without one)
PARAMS: tuple[ParamDef, ...] = (
    param(
        "PLD_VIEW_LIM", 1, 0, 1, "",
        "Precision landing limits its chase to keep the marker in the camera's view: 1 on, 0 only MPC_TILTMAX_AIR",
        ParamType.INT32,
    ),
    param("PLD_CAM_FOV", 73.7, 10.0, 170.0, "deg", "Landing camera's narrower field of view (full angle)"),
    param(
        "PLD_CAM_REACH", AUTO_REACH, AUTO_REACH, 90.0, "deg",
        "How far the camera gimbal turns the camera from the body's down axis in any direction; 0: a body-fixed "
        "downward camera; -1: automatic, the reporting gimbal device's joint ranges (the smallest of roll either "
        "side and pitch either side of straight down), 0 without a gimbal device",
    ),
    param("PLD_VIEW_MARG", 8.0, 0.0, 45.0, "deg", "The marker kept this far inside the edge of the view"),
    param(
        "PLD_ACC_SLEW", 20.0, 0.0, 200.0, "m/s^3",
        "Precision landing's horizontal acceleration setpoint changes at most this fast from tracking on (0: no "
        "limit; ours)",
    ),
)  # fmt: skip


@dataclass(frozen=True, slots=True)
class ViewLimits:
    """The PARAMS' values (radians; ``enabled`` False: no cone).  ``reach_rad`` is the user's PLD_CAM_REACH, or
    None for automatic (PLD_CAM_REACH < 0): then the gimbal device's reach ``device_reach_rad`` (the gimbal
    manager's, :meth:`with_device`; None: no device reports, a body-fixed camera) is the reach."""

    enabled: bool = True
    half_fov_rad: float = math.radians(73.7 / 2.0)
    reach_rad: float | None = None
    margin_rad: float = math.radians(8.0)
    device_reach_rad: float | None = None
    slew_m_s3: float = math.inf  # PLD_ACC_SLEW (0: inf, no limit)

    @staticmethod
    def from_store(store: ParameterStore) -> ViewLimits:
        reach_deg = store.get("PLD_CAM_REACH")
        return ViewLimits(
            bool(int(store.get("PLD_VIEW_LIM"))),
            math.radians(store.get("PLD_CAM_FOV") / 2.0),
            None if reach_deg < 0.0 else math.radians(reach_deg),
            math.radians(store.get("PLD_VIEW_MARG")),
            slew_m_s3=float(store.get("PLD_ACC_SLEW")) or math.inf,
        )

    def with_device(self, device_reach_rad: float | None) -> ViewLimits:
        """These limits with the gimbal device's reach now (rad from the body's down axis; None: no device)."""
        return self if device_reach_rad == self.device_reach_rad else replace(self, device_reach_rad=device_reach_rad)

    @property
    def reach_in_use_rad(self) -> float:
        """The gimbal's reach the cone allows for (rad): the user's; automatic: the device's, held to 0..90 deg
        (the parameter's range), 0 without a device (or with a reach that is not a number)."""
        if self.reach_rad is not None:
            return self.reach_rad
        device = self.device_reach_rad
        if device is None or not math.isfinite(device):
            return 0.0
        return min(max(device, 0.0), math.pi / 2)

    @property
    def half_angle_rad(self) -> float:
        """How far the down axis may be from the line of sight with the marker still in view (rad)."""
        return self.reach_in_use_rad + self.half_fov_rad - self.margin_rad


def view_cone(rel_target_ned_m: np.ndarray | None, limits: ViewLimits) -> AxisCone | None:
    """The cone for the vehicle's down axis that keeps a target at ``rel_target_ned_m`` (target minus vehicle, NED m)
    in view; None when off, without a target, or with the target not below the vehicle."""
    if not limits.enabled or rel_target_ned_m is None:
        return None
    n, e, d = (float(c) for c in rel_target_ned_m)
    if not (math.isfinite(n) and math.isfinite(e) and math.isfinite(d)) or d <= 0.0:
        return None
    return AxisCone((n, e, d), limits.half_angle_rad)
