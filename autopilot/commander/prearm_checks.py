"""Pre-arm checks: pure functions of the vehicle's state returning why arming is refused.

:func:`prearm_failures` judges a frozen :class:`PrearmInputs`; :func:`arming_refusal` decides an arming request
from its result.  Each check returns its failure reasons (short lower-case phrases, joined into the
"Arming denied: ..." STATUSTEXT); an empty list means "ready".  The order of
:func:`prearm_failures` is the order a ground station shows them in.  Units: degrees
for the tilt (as COM_ARM_TILT_MAX), fractions of capacity for the battery (as BAT_LOW_THR).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from autopilot.topics import BatteryState, GpsSample, HomePosition, VehicleEstimate
from mavsim_core import quaternion as quat


def tilt_deg(roll_rad: float, pitch_rad: float) -> float:
    """Angle between the body z axis and the vertical, degrees."""
    return math.degrees(quat.tilt_rad(roll_rad, pitch_rad))


def attitude_check(est: VehicleEstimate | None) -> list[str]:
    return [] if est is not None and est.attitude_valid else ["attitude estimate not ready"]


def gps_check(gps: GpsSample | None) -> list[str]:
    return [] if gps is not None and gps.fix_type >= 3 else ["no 3D GPS fix"]


def position_check(est: VehicleEstimate | None) -> list[str]:
    return [] if est is not None and est.position_valid else ["position estimate not ready"]


def home_check(home: HomePosition | None) -> list[str]:
    return [] if home is not None else ["home position not set"]


def level_check(est: VehicleEstimate | None, tilt_max_deg: float) -> list[str]:
    """The vehicle stands level within ``tilt_max_deg`` (COM_ARM_TILT_MAX); not judged without an attitude."""
    if est is None or not est.attitude_valid:
        return []
    tilt = tilt_deg(est.roll_rad, est.pitch_rad)
    return [f"vehicle not level ({tilt:.0f} deg)"] if tilt > tilt_max_deg else []


def battery_check(battery: BatteryState, low_thr: float) -> list[str]:
    """Remaining charge at least ``low_thr`` (BAT_LOW_THR, fraction); an unknown charge (< 0) passes."""
    remaining = battery.remaining_frac
    return [f"battery low ({remaining:.0%})"] if 0 <= remaining < low_thr else []


def termination_check(terminated: bool) -> list[str]:
    """DO_FLIGHTTERMINATION holds until a reboot (PX4: arming refused while flight termination is set)."""
    return ["flight terminated (reboot to clear)"] if terminated else []


@dataclass(frozen=True)
class PrearmInputs:
    """What the pre-arm checks judge now."""

    est: VehicleEstimate | None
    gps: GpsSample | None
    home: HomePosition | None
    battery: BatteryState
    estimator_failures: tuple[str, ...]  # the EKF's own (empty when another filter flies)
    tilt_max_deg: float  # COM_ARM_TILT_MAX
    battery_low_thr: float  # BAT_LOW_THR
    terminated: bool = False  # DO_FLIGHTTERMINATION was given (until a reboot)
    fence_failures: tuple[str, ...] = ()  # the geofence's (:func:`.mission_control.fence_prearm_failures`)


def prearm_failures(s: PrearmInputs) -> list[str]:
    """Every reason arming would be refused now, in the order a ground station lists them."""
    return (
        attitude_check(s.est)
        + gps_check(s.gps)
        + position_check(s.est)
        + list(s.estimator_failures)
        + home_check(s.home)
        + level_check(s.est, s.tilt_max_deg)
        + battery_check(s.battery, s.battery_low_thr)
        + termination_check(s.terminated)
        + list(s.fence_failures)
    )


def arming_refusal(failures: list[str], force: bool, has_estimate: bool) -> str | None:
    """The STATUSTEXT refusing an arming request (``force``: whatever the pre-arm checks say), or None: arm."""
    if failures and not force:
        return "Arming denied: " + "; ".join(failures)
    if not has_estimate:
        return "Arming denied: no sensor data"
    return None
