"""Health: SYS_STATUS sensor bits and the battery warning level.

:func:`sensors_health` turns the estimate, the GPS timeout, the EKF's status and the
pre-arm result into the MAV_SYS_STATUS_SENSOR bits a ground station shows as green or
red.  :func:`battery_warning` grades the remaining charge with PX4's thresholds
(``BAT_LOW_THR``, ``BAT_CRIT_THR``, ``BAT_EMERGEN_THR``: fractions of capacity): the
pre-arm battery check uses BAT_LOW_THR and BATTERY_STATUS reports the level as its
charge state, and the battery failsafe (:mod:`.failsafes`, COM_LOW_BAT_ACT) acts on it.
:func:`auto_disarm_reason`: when an armed vehicle on the ground disarms by itself
(COM_DISARM_LAND, COM_DISARM_PRFLT).
"""

from __future__ import annotations

from pymavlink.dialects.v20 import common as S

from autopilot.navigation.land_detector import LandDetector, Landed
from autopilot.parameters import ParamDef, ParameterStore, param
from autopilot.topics import BatteryWarning, EstimatorStatus, VehicleEstimate

# The parameters this module reads (listed in autopilot/param_catalogue.py).
PARAMS: tuple[ParamDef, ...] = (
    param(
        "BAT_LOW_THR",
        0.15,
        0.12,
        0.5,
        "norm",
        "Low battery: remaining charge below this fraction (refuses arming; BATTERY_STATUS charge state LOW)",
    ),
    param(
        "BAT_CRIT_THR",
        0.07,
        0.05,
        0.5,
        "norm",
        "Critical battery: remaining charge below this fraction (BATTERY_STATUS charge state CRITICAL)",
    ),
    param(
        "BAT_EMERGEN_THR",
        0.05,
        0.03,
        0.5,
        "norm",
        "Emergency battery: remaining charge below this fraction (BATTERY_STATUS charge state EMERGENCY)",
    ),
)

SENSORS_PRESENT = (
    S.MAV_SYS_STATUS_SENSOR_3D_GYRO
    | S.MAV_SYS_STATUS_SENSOR_3D_ACCEL
    | S.MAV_SYS_STATUS_SENSOR_3D_MAG
    | S.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE
    | S.MAV_SYS_STATUS_SENSOR_GPS
    | S.MAV_SYS_STATUS_SENSOR_ANGULAR_RATE_CONTROL
    | S.MAV_SYS_STATUS_SENSOR_ATTITUDE_STABILIZATION
    | S.MAV_SYS_STATUS_SENSOR_YAW_POSITION
    | S.MAV_SYS_STATUS_SENSOR_Z_ALTITUDE_CONTROL
    | S.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL
    | S.MAV_SYS_STATUS_SENSOR_MOTOR_OUTPUTS
    | S.MAV_SYS_STATUS_AHRS
    | S.MAV_SYS_STATUS_SENSOR_BATTERY
    | S.MAV_SYS_STATUS_PREARM_CHECK
)
ESTIMATOR_FLAG_ATTITUDE = 1  # ESTIMATOR_STATUS_FLAGS: ESTIMATOR_ATTITUDE
# The SYS_STATUS bit of each sensor the estimator's checks can declare failed (estimation/sensor_checks.py)
SENSOR_BITS = {
    "accelerometer": S.MAV_SYS_STATUS_SENSOR_3D_ACCEL,
    "gyro": S.MAV_SYS_STATUS_SENSOR_3D_GYRO,
    "barometer": S.MAV_SYS_STATUS_SENSOR_ABSOLUTE_PRESSURE,
}


def sensors_health(
    est: VehicleEstimate | None,
    gps_ok: bool,
    estimator_status: EstimatorStatus | None,
    ekf_in_use: bool,
    prearm_ok: bool,
) -> int:
    """The healthy bits among :data:`SENSORS_PRESENT` (all present sensors are enabled).

    ``prearm_ok``: armed, or no pre-arm check fails (the PREARM_CHECK bit).
    """
    health = SENSORS_PRESENT
    if est is None or not est.attitude_valid:
        health &= ~(S.MAV_SYS_STATUS_AHRS | S.MAV_SYS_STATUS_SENSOR_3D_GYRO | S.MAV_SYS_STATUS_SENSOR_3D_ACCEL)
    if not gps_ok:
        health &= ~S.MAV_SYS_STATUS_SENSOR_GPS
    if est is None or not est.position_valid:
        health &= ~S.MAV_SYS_STATUS_SENSOR_XY_POSITION_CONTROL
    if estimator_status is not None:
        if estimator_status.mag_fault:
            health &= ~S.MAV_SYS_STATUS_SENSOR_3D_MAG
        if estimator_status.gps_glitch:
            health &= ~S.MAV_SYS_STATUS_SENSOR_GPS
        for name in estimator_status.failed_sensors:
            health &= ~SENSOR_BITS.get(name, 0)
        if ekf_in_use and not estimator_status.flags & ESTIMATOR_FLAG_ATTITUDE:
            health &= ~S.MAV_SYS_STATUS_AHRS
    if not prearm_ok:
        health &= ~S.MAV_SYS_STATUS_PREARM_CHECK
    return health


def battery_warning(remaining_frac: float, params: ParameterStore) -> BatteryWarning:
    """The warning level of a remaining charge (fraction, < 0 or NaN unknown: NONE) by BAT_*_THR."""
    if not remaining_frac >= 0:
        return BatteryWarning.NONE
    if remaining_frac < params.get("BAT_EMERGEN_THR"):
        return BatteryWarning.EMERGENCY
    if remaining_frac < params.get("BAT_CRIT_THR"):
        return BatteryWarning.CRITICAL
    if remaining_frac < params.get("BAT_LOW_THR"):
        return BatteryWarning.LOW
    return BatteryWarning.NONE


def auto_disarm_reason(
    detector: LandDetector, armed_at_us: int, now_us: int, climbing_mode: bool, params: ParameterStore
) -> str | None:
    """Why an armed vehicle on the ground disarms now, or None: COM_DISARM_LAND seconds after a landing,
    COM_DISARM_PRFLT seconds after arming without a take-off (not in a mode that climbs by itself)."""
    if detector.state is not Landed.ON_GROUND or detector.landed_since_us is None:
        return None
    since = detector.landed_since_us
    limit = params.get("COM_DISARM_LAND")
    if since > armed_at_us and limit >= 0 and now_us - since >= limit * 1e6:
        return "landed"
    preflight = params.get("COM_DISARM_PRFLT")
    if since <= armed_at_us and preflight >= 0 and not climbing_mode and now_us - armed_at_us >= preflight * 1e6:
        return "no takeoff"
    return None
