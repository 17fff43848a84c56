"""The gimbal manager's decisions, apart from its effects: who is in control of the gimbal, which angles the
manager accepts, its parameters and messages, and the device setpoint of a camera attitude (gimbal protocol v2
as PX4's gimbal module reads it; used by :mod:`autopilot.mavlink.gimbal_manager`).  Pure: no sockets, no clock.
Radians, NED/FRD.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from pymavlink.dialects.v20 import common as mavlink

from autopilot.control.gimbal_pointing import AngleLimits, CameraAttitude
from autopilot.mavlink.command_fields import FieldError
from autopilot.parameters import ParamDef, ParamType, param

# The parameters this module reads (listed in autopilot/param_catalogue.py); PX4's names, ranges and defaults,
# except MNT_MODE_IN/OUT, whose defaults are those PX4's simulated gimbal airframes set.
PARAMS: tuple[ParamDef, ...] = (
    param(
        "MNT_MODE_IN", 4, -1, 4, "",
        "Mount input mode: -1 disabled (no gimbal manager), 0 auto (RC and MAVLink gimbal protocol v2), "
        "4 MAVLink gimbal protocol v2 (1 RC, 2 and 3 protocol v1: not simulated, the manager is off)",
        ParamType.INT32, reboot_required=True,
    ),
    param(
        "MNT_MODE_OUT", 2, 0, 2, "",
        "Mount output mode: 2 MAVLink gimbal protocol v2 (the simulator's gimbal device; 0 AUX and 1 protocol "
        "v1 are not simulated: the manager is off)",
        ParamType.INT32, reboot_required=True,
    ),
    param(
        "MNT_MAV_COMPID", 154, 1, 255, "",
        "Component id of the gimbal device (GIMBAL_MANAGER_INFORMATION's gimbal_device_id, the source of the "
        "relayed GIMBAL_DEVICE_ATTITUDE_STATUS)",
        ParamType.INT32, reboot_required=True,
    ),
    param("MNT_RATE_PITCH", 30.0, 1.0, 90.0, "deg/s", "Angular pitch rate of full manual input (-1..1)"),
    param("MNT_RATE_YAW", 30.0, 1.0, 90.0, "deg/s", "Angular yaw rate of full manual input (-1..1)"),
    param("MNT_LND_P_MIN", -90.0, -90.0, 90.0, "deg", "Pitch minimum when landed"),
    param("MNT_LND_P_MAX", 90.0, -90.0, 90.0, "deg", "Pitch maximum when landed"),
)  # fmt: skip

NOBODY = (0, 0)
CAP_FLAGS = (  # PX4's, plus the roll axis this device has
    mavlink.GIMBAL_MANAGER_CAP_FLAGS_HAS_NEUTRAL
    | mavlink.GIMBAL_MANAGER_CAP_FLAGS_HAS_ROLL_AXIS
    | mavlink.GIMBAL_MANAGER_CAP_FLAGS_HAS_ROLL_LOCK
    | mavlink.GIMBAL_MANAGER_CAP_FLAGS_HAS_PITCH_AXIS
    | mavlink.GIMBAL_MANAGER_CAP_FLAGS_HAS_PITCH_LOCK
    | mavlink.GIMBAL_MANAGER_CAP_FLAGS_HAS_YAW_AXIS
    | mavlink.GIMBAL_MANAGER_CAP_FLAGS_HAS_YAW_FOLLOW
    | mavlink.GIMBAL_MANAGER_CAP_FLAGS_HAS_YAW_LOCK
    | mavlink.GIMBAL_MANAGER_CAP_FLAGS_CAN_POINT_LOCATION_GLOBAL
)
Source = tuple[int, int]  # (system id, component id) of a client
# PX4's manager range (its GIMBAL_MANAGER_INFORMATION): pitch +-90 deg, yaw +-180 deg; roll as the device allows
PX4_MANAGER_LIMITS = AngleLimits(-math.pi, math.pi, -math.pi / 2, math.pi / 2, -math.pi, math.pi)
_LOCKS = mavlink.GIMBAL_DEVICE_FLAGS_ROLL_LOCK | mavlink.GIMBAL_DEVICE_FLAGS_PITCH_LOCK


# --------------------------------------------------------------------------- who is in control


def resolve_control_id(value: int, current: int, own: int, sender: int) -> int:
    """One id of DO_GIMBAL_MANAGER_CONFIGURE as PX4 reads it: 0..255 that id, -1 unchanged, -2 the autopilot
    itself (``own``), -3 released (0) if ``sender`` holds it, else unchanged; FieldError otherwise."""
    if 0 <= value <= 255:
        return value
    if value == -1:
        return current
    if value == -2:
        return own
    if value == -3:
        return 0 if current == sender else current
    raise FieldError(f"{value} is not an id (0..255) nor -1, -2, -3")


@dataclass(frozen=True, slots=True)
class GimbalControl:
    """Who may point the gimbal: the primary and the secondary controller ((0, 0): nobody)."""

    primary: Source = NOBODY
    secondary: Source = NOBODY

    def configured(self, values: tuple[int, int, int, int], sender: Source, own: Source) -> GimbalControl:
        """After DO_GIMBAL_MANAGER_CONFIGURE's param1..4 (primary sysid, compid, secondary sysid, compid) from
        ``sender``, on the autopilot ``own`` (FieldError for a value PX4 does not know)."""
        p_sys, p_comp, s_sys, s_comp = values
        primary = (
            resolve_control_id(p_sys, self.primary[0], own[0], sender[0]),
            resolve_control_id(p_comp, self.primary[1], own[1], sender[1]),
        )
        secondary = (
            resolve_control_id(s_sys, self.secondary[0], own[0], sender[0]),
            resolve_control_id(s_comp, self.secondary[1], own[1], sender[1]),
        )
        return GimbalControl(primary, secondary)

    def allows(self, sender: Source) -> bool:
        """May ``sender`` point the gimbal (it is the primary or the secondary controller)?"""
        return sender != NOBODY and sender in (self.primary, self.secondary)


# --------------------------------------------------------------------------- the device as reported


@dataclass(frozen=True, slots=True)
class DeviceRange:
    """The device's joint ranges from its GIMBAL_DEVICE_INFORMATION (rad; NaN: unknown, no limit)."""

    limits: AngleLimits

    @staticmethod
    def from_information(msg) -> DeviceRange:
        def lim(v: float, default: float) -> float:
            return float(v) if math.isfinite(v) else default

        pi = math.pi
        return DeviceRange(
            AngleLimits(
                lim(msg.roll_min, -pi), lim(msg.roll_max, pi), lim(msg.pitch_min, -pi), lim(msg.pitch_max, pi),
                lim(msg.yaw_min, -pi), lim(msg.yaw_max, pi),
            )
        )  # fmt: skip

    @property
    def tilt_reach_rad(self) -> float:
        """How far the joints can turn the camera away from the body's down axis in every direction (rad, 0..pi/2):
        the smallest of the roll joint's reach either side of level and the pitch joint's either side of straight
        down (pitch -pi/2, PX4's convention; the landing camera's neutral).

        Why the smallest, not the roll range alone: the vehicle tilts toward wherever the deck is, ahead, aside or
        behind; looking down, a tilt to the side is taken out by the roll joint, a nose-down tilt by pitching up
        toward ``pitch_max`` and a nose-up one by pitching down past -90 deg toward ``pitch_min`` (the vehicle
        files' gimbal: -135 deg, 45 deg past, as its roll's +-45).  So the camera still looks down after any tilt
        within the smallest of the four, which is what PLD_CAM_REACH means.  The yaw joint turns the camera about
        the down axis and adds no reach.  An unknown joint range (NaN: no limit) leaves the others; a range that
        does not contain level roll or straight-down pitch gives 0."""
        lim, down = self.limits, -math.pi / 2
        reach = min(-lim.roll_min_rad, lim.roll_max_rad, down - lim.pitch_min_rad, lim.pitch_max_rad - down)
        return min(max(reach, 0.0), math.pi / 2)


def manager_limits(device: DeviceRange | None, landed: bool, lnd_pitch_deg: tuple[float, float]) -> AngleLimits:
    """The angles the manager accepts: PX4's manager range, the device's range, and when landed
    MNT_LND_P_MIN..MAX."""
    limits = PX4_MANAGER_LIMITS if device is None else PX4_MANAGER_LIMITS.narrowed(device.limits)
    if landed:
        lo, hi = (math.radians(v) for v in lnd_pitch_deg)
        limits = limits.narrowed(AngleLimits(-math.pi, math.pi, lo, hi, -math.pi, math.pi))
    return limits


def device_setpoint(target: CameraAttitude | None, sysid: int, device_compid: int) -> mavlink.MAVLink_message:
    """GIMBAL_DEVICE_SET_ATTITUDE for a camera attitude (None: the device's neutral), roll and pitch locked to
    the horizon, yaw in the earth frame or the vehicle's as the attitude says (``sitl/gimbal_link.py``)."""
    nan = math.nan
    if target is None:
        return mavlink.MAVLink_gimbal_device_set_attitude_message(
            sysid, device_compid, mavlink.GIMBAL_DEVICE_FLAGS_NEUTRAL, [nan] * 4, nan, nan, nan
        )
    flags = _LOCKS | (
        mavlink.GIMBAL_DEVICE_FLAGS_YAW_LOCK | mavlink.GIMBAL_DEVICE_FLAGS_YAW_IN_EARTH_FRAME
        if target.yaw_earth
        else mavlink.GIMBAL_DEVICE_FLAGS_YAW_IN_VEHICLE_FRAME
    )
    return mavlink.MAVLink_gimbal_device_set_attitude_message(
        sysid, device_compid, flags, list(target.quaternion_wxyz()), nan, nan, nan
    )


@dataclass(frozen=True, slots=True)
class Roi:
    """A region of interest: a global location (deg, deg, m AMSL)."""

    lat_deg: float
    lon_deg: float
    alt_amsl_m: float


def manager_information(time_ms: int, device_compid: int, lim: AngleLimits) -> mavlink.MAVLink_message:
    """GIMBAL_MANAGER_INFORMATION: CAP_FLAGS, the device's component id, the manager's limits (rad)."""
    return mavlink.MAVLink_gimbal_manager_information_message(
        time_ms, CAP_FLAGS, device_compid, lim.roll_min_rad, lim.roll_max_rad,
        lim.pitch_min_rad, lim.pitch_max_rad, lim.yaw_min_rad, lim.yaw_max_rad,
    )  # fmt: skip


def manager_status(time_ms: int, device_flags: int, device_compid: int, c: GimbalControl) -> mavlink.MAVLink_message:
    """GIMBAL_MANAGER_STATUS: the device's flags, who is in control."""
    return mavlink.MAVLink_gimbal_manager_status_message(time_ms, device_flags, device_compid, *c.primary, *c.secondary)
