"""Where the camera gimbal points: a camera attitude, the angle limits it must respect, a direction to look along.

Pure geometry for the gimbal manager (:mod:`autopilot.mavlink.gimbal_manager`) and the precision landing's
request (:class:`GimbalRequest`, carried in the commander's status): no I/O, no clock.  Angles as gimbal protocol
v2 and PX4 use them (radians): roll right positive, pitch up positive (straight down is -pi/2), yaw right positive,
ZYX Euler order.  Roll and pitch are always to the horizon; yaw is either relative to the vehicle's heading
(follow) or from North (lock, ``yaw_earth``).
Directions are NED metres or unit vectors.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum

from mavsim_core import quaternion

Vec3 = tuple[float, float, float]
HORIZONTAL_EPS_M = 1e-6  # a direction with less horizontal extent than this has no heading of its own


@dataclass(frozen=True, slots=True)
class CameraAttitude:
    """A camera attitude the manager asks of the gimbal device (rad, see the module docstring)."""

    roll_rad: float
    pitch_rad: float
    yaw_rad: float
    yaw_earth: bool = False  # True: yaw from North; False: relative to the vehicle's heading

    def quaternion_wxyz(self) -> tuple[float, float, float, float]:
        """GIMBAL_DEVICE_SET_ATTITUDE's ``q``: (w, x, y, z) of the ZYX Euler angles."""
        w, x, y, z = (float(c) for c in quaternion.from_euler(self.roll_rad, self.pitch_rad, self.yaw_rad))
        return w, x, y, z

    def yaw_relative_rad(self, vehicle_yaw_rad: float) -> float:
        """The yaw relative to the vehicle's heading (rad, -pi..pi) for a vehicle heading (rad from North)."""
        if not self.yaw_earth:
            return self.yaw_rad
        return quaternion.wrap_pi(self.yaw_rad - vehicle_yaw_rad)


def attitude_from_quaternion(q_wxyz, yaw_earth: bool) -> CameraAttitude | None:
    """The camera attitude of a (w, x, y, z) quaternion (normalised here); None if it is not a finite
    non-zero quaternion (GIMBAL_MANAGER_SET_ATTITUDE's all-NaN ``q`` means "rates only")."""
    w, x, y, z = (float(c) for c in q_wxyz)
    n = math.sqrt(w * w + x * x + y * y + z * z)
    if not math.isfinite(n) or n < 1e-6:
        return None
    roll, pitch, yaw = quaternion.to_euler((w / n, x / n, y / n, z / n))
    return CameraAttitude(roll, pitch, yaw, yaw_earth)


@dataclass(frozen=True, slots=True)
class AngleLimits:
    """The angles the manager accepts (rad, inclusive); yaw relative to the vehicle's heading."""

    roll_min_rad: float
    roll_max_rad: float
    pitch_min_rad: float
    pitch_max_rad: float
    yaw_min_rad: float
    yaw_max_rad: float

    def violation(self, att: CameraAttitude, vehicle_yaw_rad: float) -> str | None:
        """Why ``att`` is out of range (the axis, the angle and the range, in degrees), or None if it is in
        range.  An earth-frame yaw is checked relative to the vehicle's heading ``vehicle_yaw_rad``."""
        checks = (
            ("roll", att.roll_rad, self.roll_min_rad, self.roll_max_rad),
            ("pitch", att.pitch_rad, self.pitch_min_rad, self.pitch_max_rad),
            ("yaw", att.yaw_relative_rad(vehicle_yaw_rad), self.yaw_min_rad, self.yaw_max_rad),
        )
        for axis, angle, lo, hi in checks:
            if not math.isfinite(angle):
                return f"{axis} is not a number"
            if not lo - 1e-6 <= angle <= hi + 1e-6:
                return f"{axis} {math.degrees(angle):.1f} deg outside {math.degrees(lo):.1f}..{math.degrees(hi):.1f}"
        return None

    def narrowed(self, other: AngleLimits) -> AngleLimits:
        """The angles both accept."""
        return AngleLimits(
            max(self.roll_min_rad, other.roll_min_rad),
            min(self.roll_max_rad, other.roll_max_rad),
            max(self.pitch_min_rad, other.pitch_min_rad),
            min(self.pitch_max_rad, other.pitch_max_rad),
            max(self.yaw_min_rad, other.yaw_min_rad),
            min(self.yaw_max_rad, other.yaw_max_rad),
        )

    def clamped(self, att: CameraAttitude, vehicle_yaw_rad: float) -> CameraAttitude:
        """``att`` with each angle held inside its range (for setpoints that move by rates, never jumps)."""
        yaw_rel = min(self.yaw_max_rad, max(self.yaw_min_rad, att.yaw_relative_rad(vehicle_yaw_rad)))
        yaw = quaternion.wrap_pi(yaw_rel + vehicle_yaw_rad) if att.yaw_earth else yaw_rel
        return CameraAttitude(
            min(self.roll_max_rad, max(self.roll_min_rad, att.roll_rad)),
            min(self.pitch_max_rad, max(self.pitch_min_rad, att.pitch_rad)),
            yaw,
            att.yaw_earth,
        )


def symmetric_limits(roll_range_deg: float, pitch_range_deg: float, yaw_range_deg: float) -> AngleLimits:
    """Limits of PX4's MNT_RANGE_* (the full range of each axis, degrees, centred on zero)."""
    r, p, y = (math.radians(v) / 2.0 for v in (roll_range_deg, pitch_range_deg, yaw_range_deg))
    return AngleLimits(-r, r, -p, p, -y, y)


def look_along(direction_ned: Vec3) -> CameraAttitude:
    """The level camera attitude whose optical axis lies along ``direction_ned`` (any length): yaw from North
    toward it; straight up or down (no horizontal extent) it keeps the vehicle's heading (yaw 0, following),
    so the top of the image stays toward the nose."""
    n, e, d = (float(c) for c in direction_ned)
    horizontal = math.hypot(n, e)
    if horizontal < HORIZONTAL_EPS_M:
        if abs(d) < HORIZONTAL_EPS_M:
            raise ValueError("gimbal pointing: a zero direction has no attitude")
        return CameraAttitude(0.0, -math.copysign(math.pi / 2, d), 0.0, yaw_earth=False)
    return CameraAttitude(0.0, math.atan2(-d, horizontal), math.atan2(e, n), yaw_earth=True)


def look_at(vehicle_pos_ned_m: Vec3, target_pos_ned_m: Vec3) -> CameraAttitude:
    """The camera attitude from a vehicle position toward a target position (both NED m, one origin)."""
    return look_along(tuple(t - v for t, v in zip(target_pos_ned_m, vehicle_pos_ned_m)))  # type: ignore[arg-type]


class GimbalAim(IntEnum):
    """What the flight controller's own use of the camera gimbal asks (:class:`GimbalRequest`)."""

    RELEASE = 0  # nothing: the gimbal is its clients' (control back to whoever held it before)
    DOWN = 1  # straight down, the top of the image toward the nose
    ALONG = 2  # along ``GimbalRequest.direction_ned``


@dataclass(frozen=True, slots=True)
class GimbalRequest:
    """The commander's decision for the camera gimbal (a precision landing points it at the target estimate,
    :mod:`autopilot.navigation.precland_gimbal`), applied by the gimbal manager
    (:mod:`autopilot.mavlink.gimbal_manager`).  ``direction_ned``: where the optical axis should point, NED
    (any length, from the vehicle), read only for ALONG."""

    aim: GimbalAim = GimbalAim.RELEASE
    direction_ned: tuple[float, float, float] = (0.0, 0.0, 1.0)


NO_GIMBAL_REQUEST = GimbalRequest()
