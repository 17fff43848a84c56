"""More telemetry messages, and the one registry of every message the link can stream or send on request.

The builders here follow :mod:`autopilot.mavlink.telemetry`'s rules: pure functions of a
:class:`~autopilot.topics.TelemetrySnapshot` (SI units, NED/FRD, quaternions w, x, y, z; the IMU
sample, UTC clock and flight times in its ``extras``, :mod:`autopilot.telemetry_extras`) and the
simulated time ``now_us``, returning a pymavlink message in MAVLink's units or None when there is
nothing to report.  Unknown values are NaN in float fields, as the MAVLink spec asks.

:func:`link_builders` is the registry the link uses: message id -> builder, for the streams
(SET_MESSAGE_INTERVAL / GET_MESSAGE_INTERVAL) and for REQUEST_MESSAGE; :data:`DEFAULT_STREAM_RATES_HZ`
the streams every endpoint starts with (every other message: off until asked for).
"""

from __future__ import annotations

import math
from typing import Callable

import numpy as np
from pymavlink.dialects.v20 import common as mavlink

from autopilot.estimation.estimator import pressure_to_altitude_m
from autopilot.mavlink import telemetry
from autopilot.mavlink.identity import Identity, autopilot_version
from autopilot.mavlink.protocol_version import MAVLINK_MSG_ID_PROTOCOL_VERSION, protocol_version
from autopilot.mavlink.telemetry import INT16_MAX, UINT16_MAX, Builder, clamp_int, deg_e7, time_boot_ms
from autopilot.topics import LandedState, TelemetrySnapshot
from mavsim_core import quaternion as quat
from mavsim_core.geodesy import ned_to_geodetic

NAN = math.nan
_INT32 = (-(2**31), 2**31 - 1, 0)
# HIGHRES_IMU_UPDATED_* (13 bits), the bits of HIL_SENSOR's flags too, but no differential pressure: no airspeed
# sensor (HIL_SENSOR's diff_pressure is a 0 placeholder)
HIGHRES_IMU_FIELDS = 0x1FFF & ~mavlink.HIGHRES_IMU_UPDATED_DIFF_PRESSURE
_COVARIANCE_DIAGONAL = (0, 6, 11, 15, 18, 20)  # a 6x6 upper triangle, row-major: the diagonal's indices


def _alt_relative_m(s: TelemetrySnapshot) -> float:
    """Height above home (m), NaN without home or estimate."""
    e, h = s.estimate, s.home
    if e is None or h is None:
        return NAN
    return float(h.pos_ned_m[2] - e.pos_ned_m[2])


def system_time(s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message:
    """SYSTEM_TIME: UTC µs (the wall clock at start, advancing with simulated time, as PX4 SITL's; 0 if unknown)
    and the simulated ms since boot."""
    x = s.extras
    utc = x.utc_at_zero_us + now_us if x is not None and x.utc_at_zero_us > 0 else 0
    return mavlink.MAVLink_system_time_message(utc, time_boot_ms(now_us))


def altitude(s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
    """ALTITUDE (m): monotonic = the uncorrected barometric altitude (standard atmosphere, as PX4), AMSL and local
    (up from the estimator origin) from the estimate, relative to home; no terrain or range sensor: NaN."""
    e = s.estimate
    imu = s.extras.imu if s.extras is not None else None
    if e is None and imu is None:
        return None
    baro = pressure_to_altitude_m(imu.pressure_hpa) if imu is not None and imu.pressure_hpa > 0 else NAN
    have_height = e is not None and e.height_valid
    amsl = e.alt_amsl_m if e is not None and have_height else NAN
    local = -float(e.pos_ned_m[2]) if e is not None and have_height else NAN
    relative = _alt_relative_m(s) if have_height else NAN
    return mavlink.MAVLink_altitude_message(now_us, baro, amsl, local, relative, NAN, NAN)


def odometry(s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
    """ODOMETRY: pose in MAV_FRAME_LOCAL_NED (m from the estimator origin, quaternion FRD -> NED), twist in
    MAV_FRAME_BODY_FRD (velocity m/s and rates rad/s in the body frame); the pose covariance's diagonal from
    the EKF's 1-sigma accuracies (other entries NaN: unknown), velocity covariance unknown (NaN);
    MAV_ESTIMATOR_TYPE_AUTOPILOT, quality 0 (unknown), as PX4."""
    e = s.estimate
    if e is None or not e.position_valid:
        return None
    r_ned_frd = quat.to_matrix(e.q_wxyz)
    v_frd = r_ned_frd.T @ np.asarray(e.vel_ned_m_s, dtype=float)
    pose_cov = [NAN] * 21
    st = s.estimator_status
    if st is not None:
        h, v, tilt, yaw = st.pos_horiz_accuracy_m, st.pos_vert_accuracy_m, st.tilt_std_rad, st.yaw_std_rad
        for i, sigma in zip(_COVARIANCE_DIAGONAL, (h, h, v, tilt, tilt, yaw)):
            pose_cov[i] = sigma * sigma if math.isfinite(sigma) else NAN
    return mavlink.MAVLink_odometry_message(
        e.timestamp_us, mavlink.MAV_FRAME_LOCAL_NED, mavlink.MAV_FRAME_BODY_FRD,
        *(float(x) for x in e.pos_ned_m), [float(x) for x in e.q_wxyz], *(float(x) for x in v_frd),
        *(float(x) for x in e.rate_frd_rad_s), pose_cov, [NAN] * 21, e.reset_count & 0xFF,
        mavlink.MAV_ESTIMATOR_TYPE_AUTOPILOT, 0,
    )  # fmt: skip


def highres_imu(s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
    """HIGHRES_IMU: the IMU sample the flight controller last stepped on, as the simulator sent it (specific
    force m/s² FRD, rates rad/s FRD, field gauss FRD, pressure hPa, temperature °C), the pressure altitude
    (m, standard atmosphere) and the sample's HIL_SENSOR flags (the same bits; no differential pressure)."""
    imu = s.extras.imu if s.extras is not None else None
    if imu is None:
        return None
    p = imu.pressure_hpa
    pressure_alt = pressure_to_altitude_m(p) if math.isfinite(p) and p > 0 else NAN
    return mavlink.MAVLink_highres_imu_message(
        imu.timestamp_us, *(float(x) for x in imu.accel_frd_m_s2), *(float(x) for x in imu.gyro_frd_rad_s),
        *(float(x) for x in imu.mag_frd_gauss), p, 0.0, pressure_alt, imu.temperature_c,
        imu.fields_updated & HIGHRES_IMU_FIELDS, 0,
    )  # fmt: skip


def gps_global_origin(s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
    """GPS_GLOBAL_ORIGIN: the local frame's origin (the first good fix): lat/lon degE7, altitude mm AMSL;
    None before it is set.  The time it was set is not kept: time_usec 0."""
    e = s.estimate
    if e is None or not all(math.isfinite(x) for x in (e.origin_lat_deg, e.origin_lon_deg, e.origin_alt_amsl_m)):
        return None
    alt_mm = clamp_int(e.origin_alt_amsl_m * 1000.0, *_INT32)
    return mavlink.MAVLink_gps_global_origin_message(deg_e7(e.origin_lat_deg), deg_e7(e.origin_lon_deg), alt_mm, 0)


def flight_information(s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message:
    """FLIGHT_INFORMATION of the latest flight, as the spec and PX4 fill it: arming and take-off times in µs
    since boot (the fields named "_utc" are not UTC), landing time in ms since boot (0: not yet, reset on
    arming) and flight_uuid = the flight's number (COM_FLIGHT_UUID: one more at each arming, kept with
    --state-dir; 0 before the first)."""
    x = s.extras
    if x is None:
        return mavlink.MAVLink_flight_information_message(time_boot_ms(now_us), 0, 0, 0, 0)
    return mavlink.MAVLink_flight_information_message(
        time_boot_ms(now_us), x.armed_us, x.takeoff_us, x.flight_number, time_boot_ms(x.landed_us)
    )


def manual_control(s: TelemetrySnapshot, now_us: int, sysid: int = 1) -> mavlink.MAVLink_message | None:
    """MANUAL_CONTROL: the sticks the vehicle read last, as PX4's stream echoes its manual_control_setpoint
    (target our system id; x, y, r -1000..1000, z 0..1000; aux1..aux6 with their enabled_extensions bits where
    known), and also what PX4 drops (buttons, buttons2, s, t) as received; None before any sticks came.  (PX4
    sends each new sample once; this stream repeats the latest at its rate.)"""
    m = s.extras.manual if s.extras is not None else None
    if m is None:
        return None
    mask, ext = 0, []
    for bit, v in enumerate((m.s, m.t, *m.aux)):
        known = math.isfinite(v)
        mask |= (1 << bit) if known else 0
        ext.append(clamp_int(v * 1000.0, -1000, 1000, 0))
    sticks = [clamp_int(v * 1000.0, -1000, 1000, 0) for v in (m.pitch, m.roll, m.throttle, m.yaw)]
    return mavlink.MAVLink_manual_control_message(sysid, *sticks, m.buttons & 0xFFFF, m.buttons2 & 0xFFFF, mask, *ext)


def utm_global_position(s: TelemetrySnapshot, now_us: int, uas_id: bytes = bytes(18)) -> mavlink.MAVLink_message | None:
    """UTM_GLOBAL_POSITION: UTC µs, position degE7 / mm AMSL / mm above home, velocity NED cm/s, accuracies
    (mm; the EKF's 1-sigma), flight state from the land detector; no next waypoint (flag clear)."""
    e = s.estimate
    if e is None or not e.position_valid:
        return None
    F = mavlink
    lat, lon, alt = ned_to_geodetic(e.pos_ned_m, e.origin_lat_deg, e.origin_lon_deg, e.origin_alt_amsl_m)
    vn, ve, vd = (clamp_int(v * 100.0, -INT16_MAX - 1, INT16_MAX, 0) for v in e.vel_ned_m_s)
    st = s.estimator_status
    h_acc = clamp_int(st.pos_horiz_accuracy_m * 1000.0, 0, UINT16_MAX, 0) if st is not None else 0
    v_acc = clamp_int(st.pos_vert_accuracy_m * 1000.0, 0, UINT16_MAX, 0) if st is not None else 0
    flags = F.UTM_DATA_AVAIL_FLAGS_POSITION_AVAILABLE | F.UTM_DATA_AVAIL_FLAGS_ALTITUDE_AVAILABLE
    flags |= F.UTM_DATA_AVAIL_FLAGS_HORIZONTAL_VELO_AVAILABLE | F.UTM_DATA_AVAIL_FLAGS_VERTICAL_VELO_AVAILABLE
    flags |= F.UTM_DATA_AVAIL_FLAGS_UAS_ID_AVAILABLE if any(uas_id) else 0
    rel = _alt_relative_m(s)
    flags |= F.UTM_DATA_AVAIL_FLAGS_RELATIVE_ALTITUDE_AVAILABLE if math.isfinite(rel) else 0
    x = s.extras
    utc = x.utc_at_zero_us + now_us if x is not None and x.utc_at_zero_us > 0 else 0
    flags |= F.UTM_DATA_AVAIL_FLAGS_TIME_VALID if utc else 0
    if s.system_status == F.MAV_STATE_EMERGENCY:
        state = F.UTM_FLIGHT_STATE_EMERGENCY
    elif s.landed_state is LandedState.UNDEFINED:
        state = F.UTM_FLIGHT_STATE_UNKNOWN
    else:
        state = F.UTM_FLIGHT_STATE_GROUND if s.landed_state is LandedState.ON_GROUND else F.UTM_FLIGHT_STATE_AIRBORNE
    return mavlink.MAVLink_utm_global_position_message(
        utc, list(uas_id[:18].ljust(18, b"\x00")), deg_e7(lat), deg_e7(lon), clamp_int(alt * 1000.0, *_INT32),
        clamp_int(rel * 1000.0, *_INT32), vn, ve, vd, h_acc, v_acc, 0, 0, 0, 0, 0, state, flags,
    )  # fmt: skip


# Message id -> builder: the messages of telemetry.py and these; with the link's identity, link_builders().
BUILDERS: dict[int, Builder] = {
    **telemetry.BUILDERS,
    mavlink.MAVLINK_MSG_ID_SYSTEM_TIME: system_time,
    mavlink.MAVLINK_MSG_ID_ALTITUDE: altitude,
    mavlink.MAVLINK_MSG_ID_ODOMETRY: odometry,
    mavlink.MAVLINK_MSG_ID_HIGHRES_IMU: highres_imu,
    mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN: gps_global_origin,
    mavlink.MAVLINK_MSG_ID_FLIGHT_INFORMATION: flight_information,
    MAVLINK_MSG_ID_PROTOCOL_VERSION: lambda s, now_us: protocol_version(),
}

# Streams every endpoint starts with, Hz of simulated time: telemetry.py's and PX4's normal-profile rates of
# these (ALTITUDE 1 Hz, GPS_GLOBAL_ORIGIN 0.1 Hz), SYSTEM_TIME 1 Hz (MAVSDK's unix_epoch_time, PX4's onboard).
DEFAULT_STREAM_RATES_HZ: dict[int, float] = {
    **telemetry.DEFAULT_STREAM_RATES_HZ,
    mavlink.MAVLINK_MSG_ID_SYSTEM_TIME: 1.0,
    mavlink.MAVLINK_MSG_ID_ALTITUDE: 1.0,
    mavlink.MAVLINK_MSG_ID_GPS_GLOBAL_ORIGIN: 0.1,
}


def link_builders(identity: Identity, sysid: int = 1) -> dict[int, Builder]:
    """Every message the link can stream or send on request: :data:`BUILDERS`, AUTOPILOT_VERSION of
    ``identity``, UTM_GLOBAL_POSITION with its ``uid2`` as the UAS id (PX4 sends its board GUID) and the
    MANUAL_CONTROL echo addressed as from ``sysid``."""
    version = autopilot_version(identity)
    uas_id = identity.uid2
    extra: dict[int, Callable] = {
        mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION: lambda s, now_us: version,
        mavlink.MAVLINK_MSG_ID_UTM_GLOBAL_POSITION: lambda s, now_us: utm_global_position(s, now_us, uas_id),
        mavlink.MAVLINK_MSG_ID_MANUAL_CONTROL: lambda s, now_us: manual_control(s, now_us, sysid),
    }
    return {**BUILDERS, **extra}
