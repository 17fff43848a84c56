"""What the estimator publishes: the vehicle estimate, the EKF's status flags and its pre-arm failures.

Read-only views of an :class:`autopilot.estimation.estimator.Estimator` (its methods
``estimate``, ``status`` and ``prearm_failures`` call these):

* :func:`vehicle_estimate`: :class:`autopilot.topics.VehicleEstimate` from the selected
  estimator (``SYS_MC_EST_GROUP``): attitude FRD -> NED, position (m) and velocity (m/s)
  NED from the estimator origin, and whether attitude and position can be flown on;
* :func:`estimator_status`: :class:`autopilot.topics.EstimatorStatus`, the EKF's health
  (ESTIMATOR_STATUS flags, innovation test ratios, standard deviations in m and rad);
* :func:`ekf_prearm_failures`: why the EKF is not yet fit to fly on.

Times are the simulated µs of the latest IMU sample.
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

from autopilot.estimation.gps_fusion import GPS_RESET_S
from autopilot.topics import EstimatorStatus, VehicleEstimate
from mavsim_core import quaternion as quat

if TYPE_CHECKING:
    from autopilot.estimation.estimator import Estimator

ALIGN_TIME_S = 3.0  # attitude must have run this long before it is trusted
POSITION_SETTLE_S = 3.0  # GPS must have been fused this long before position is trusted
MAX_H_STD_M = 0.5
MAX_V_STD_M = 0.5
MAX_TILT_STD_RAD = math.radians(1.5)  # the EKF's roll/pitch must be this certain to arm
MAX_YAW_STD_RAD = math.radians(5.0)

# ESTIMATOR_STATUS_FLAGS (MAVLink common).
FLAG_ATTITUDE, FLAG_VEL_HORIZ, FLAG_VEL_VERT = 1, 2, 4
FLAG_POS_HORIZ_REL, FLAG_POS_HORIZ_ABS, FLAG_POS_VERT_ABS = 8, 16, 32
FLAG_CONST_POS_MODE, FLAG_GPS_GLITCH = 128, 1024


def ekf_position_ok(est: Estimator, now: int) -> bool:
    """The EKF's position can be flown on at ``now`` (µs): GPS fused recently and the filter certain."""
    e, gps = est.ekf, est.gps
    return (
        gps.origin is not None
        and gps.last_pos_fused_us is not None
        and now - gps.last_pos_fused_us < GPS_RESET_S * 1e6
        and gps.ok(now)
        and e.horizontal_pos_std_m() < MAX_H_STD_M
        and e.vertical_pos_std_m() < MAX_V_STD_M
    )


def vehicle_estimate(est: Estimator) -> VehicleEstimate:
    """The selected estimator's state at its latest IMU sample, with the output predictor's rate."""
    now = est.last_imu_us if est.last_imu_us is not None else 0
    gps = est.gps
    settled = gps.first_us is not None and now - gps.first_us >= POSITION_SETTLE_S * 1e6
    if est.use_ekf:
        e = est.ekf
        q, pos, vel = e.q, e.p.copy(), e.v.copy()
        att_ok = e.initialised and e.time_aligned_s >= ALIGN_TIME_S and e.tilt_std_rad() < 5 * MAX_TILT_STD_RAD
        pos_ok = settled and ekf_position_ok(est, now)
    else:
        q, pos, vel = est.attitude.q, est.position.pos_ned_m, est.position.vel_ned_m_s
        att_ok = est.attitude.initialised and est.attitude.time_aligned_s >= ALIGN_TIME_S
        pos_ok = (
            settled
            and gps.ok(now)
            and est.position.horizontal_std_m() < MAX_H_STD_M
            and est.position.vertical_std_m() < MAX_V_STD_M
        )
    att_ok = att_ok and est.sensor_checks.imu_ok  # a failed accelerometer or gyro: nothing to trust
    roll, pitch, yaw = quat.to_euler(q)
    o = gps.origin or (math.nan, math.nan, math.nan)
    return VehicleEstimate(
        timestamp_us=now,
        q_wxyz=q.copy(),
        rate_frd_rad_s=est.rate_frd.copy(),
        accel_ned_m_s2=est.accel_ned.copy(),
        pos_ned_m=pos,
        vel_ned_m_s=vel,
        attitude_valid=att_ok,
        position_valid=pos_ok,
        height_valid=gps.origin is not None,
        origin_lat_deg=o[0],
        origin_lon_deg=o[1],
        origin_alt_amsl_m=o[2],
        roll_rad=roll,
        pitch_rad=pitch,
        yaw_rad=yaw,
        reset_count=gps.reset_count,
        reset_delta_ned_m=gps.reset_delta_ned_m.copy(),
    )


def estimator_status(est: Estimator) -> EstimatorStatus:
    """The EKF's health, for ESTIMATOR_STATUS and SYS_STATUS."""
    e = est.ekf
    now = est.last_imu_us or 0
    flags = 0
    if e.initialised and e.time_aligned_s >= ALIGN_TIME_S:
        flags |= FLAG_ATTITUDE
    pos_ok = ekf_position_ok(est, now)
    if pos_ok:
        flags |= FLAG_VEL_HORIZ | FLAG_VEL_VERT | FLAG_POS_HORIZ_REL | FLAG_POS_HORIZ_ABS
    if est.gps.origin is not None:
        flags |= FLAG_POS_VERT_ABS
    if est.const_pos_mode:
        flags |= FLAG_CONST_POS_MODE
    if est.gps.glitch:
        flags |= FLAG_GPS_GLITCH
    r = e.ratio
    return EstimatorStatus(
        timestamp_us=now,
        flags=flags,
        vel_ratio=r["vel"],
        pos_horiz_ratio=r["pos"],
        pos_vert_ratio=r["hgt"],
        mag_ratio=r["mag"],
        pos_horiz_accuracy_m=e.horizontal_pos_std_m(),
        pos_vert_accuracy_m=e.vertical_pos_std_m(),
        tilt_std_rad=e.tilt_std_rad(),
        yaw_std_rad=e.yaw_std_rad(),
        mag_fault=est.mag.fault,
        gps_glitch=est.gps.glitch,
        position_ok=pos_ok,
        failed_sensors=tuple(failed_sensors(est)),
    )


def failed_sensors(est: Estimator) -> dict[str, str]:
    """The failed sensors and why: the sensor checks', and a barometer inconsistent with the GPS height."""
    failed = dict(est.sensor_checks.failed)
    if est.heights.failed:
        failed.setdefault("barometer", est.heights.failed)
    return failed


def ekf_prearm_failures(est: Estimator) -> list[str]:
    """Why the EKF is not yet fit to fly on (empty when converged and consistent)."""
    e = est.ekf
    out = [f"{name.capitalize()} failed: {why}" for name, why in failed_sensors(est).items()]
    if not e.initialised or e.time_aligned_s < ALIGN_TIME_S:
        return out + ["EKF attitude not aligned"]
    if e.tilt_std_rad() > MAX_TILT_STD_RAD:
        out.append(f"EKF not converged (tilt uncertainty {math.degrees(e.tilt_std_rad()):.1f} deg)")
    if not est.mag.fault and e.yaw_std_rad() > MAX_YAW_STD_RAD:
        out.append(f"EKF not converged (heading uncertainty {math.degrees(e.yaw_std_rad()):.1f} deg)")
    if est.mag.fault:
        out.append(f"EKF: {est.mag.fault_reason}")
    for kind, label in (("pos", "GPS position"), ("vel", "GPS velocity"), ("hgt", "height"), ("mag", "heading")):
        if e.ratio[kind] > 1.0:
            out.append(f"EKF {label} inconsistent (test ratio {e.ratio[kind]:.1f})")
    return out
