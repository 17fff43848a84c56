"""Telemetry messages as pure functions of the vehicle's state and time.

Each builder takes a :class:`~autopilot.topics.TelemetrySnapshot` (SI units, radians,
NED/FRD, quaternions w, x, y, z) and the simulated time ``now_us`` (µs since the
simulator started) and returns a pymavlink message in MAVLink's units (degE7, mm,
cm/s, centidegrees, mV, cA, PWM µs), or None when there is nothing to report (e.g.
no estimate yet).  Nothing here touches a socket or a clock: the link
(:mod:`autopilot.mavlink.link`) decides when each one goes out (:data:`BUILDERS`,
:data:`DEFAULT_STREAM_RATES_HZ`).

Invalid inputs (NaN, infinity) are sent as the field's "unknown" value where
MAVLink defines one (UINT16_MAX, -1), else 0, and never raise.
"""

from __future__ import annotations

import math
from typing import Callable, Sequence

import numpy as np
from pymavlink.dialects.v20 import common as mavlink

from autopilot.topics import BatteryWarning, TelemetrySnapshot
from mavsim_core.geodesy import ned_to_geodetic
from mavsim_core.quaternion import to_euler

UINT16_MAX = 65535
INT16_MAX = 32767
INT32_MAX = 2**31 - 1
_INT32 = (-(2**31), INT32_MAX, 0)  # range and invalid value of an int32 field
REPORTED_LOAD_PERMILLE = 100  # SYS_STATUS.load: nothing to measure in simulation
PWM_MIN_US, PWM_MAX_US, PWM_DISARMED_US = 1000, 2000, 900  # PX4's PWM_MAIN_MIN/MAX/DISARM defaults

# AUTOPILOT_VERSION.capabilities (autopilot.mavlink.identity): PX4's bits for what works here (not its
# RESERVED3, once SET_ACTUATOR_TARGET), plus GLOBAL_INT targets and flight termination, which PX4 handles
# without saying so.  Exactly what is implemented: the mission protocol (MISSION_ITEM_INT and the legacy
# MISSION_ITEM) for missions, fences and rally points, COMMAND_INT, the parameter protocol (floats, integers byte-wise),
# MAVLink 2, offboard control (SET_POSITION_TARGET_LOCAL_NED / _GLOBAL_INT, SET_ATTITUDE_TARGET), MAVLink FTP,
# MAV_CMD_DO_FLIGHTTERMINATION.  No terrain protocol, compass calibration, gimbal or gripper.
CAPABILITIES = (
    mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_FLOAT
    | mavlink.MAV_PROTOCOL_CAPABILITY_FTP
    | mavlink.MAV_PROTOCOL_CAPABILITY_FLIGHT_TERMINATION
    | mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_FLOAT
    | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_INT
    | mavlink.MAV_PROTOCOL_CAPABILITY_COMMAND_INT
    | mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE
    | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_FENCE
    | mavlink.MAV_PROTOCOL_CAPABILITY_MISSION_RALLY
    | mavlink.MAV_PROTOCOL_CAPABILITY_MAVLINK2
    | mavlink.MAV_PROTOCOL_CAPABILITY_SET_ATTITUDE_TARGET
    | mavlink.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_LOCAL_NED
    | mavlink.MAV_PROTOCOL_CAPABILITY_SET_POSITION_TARGET_GLOBAL_INT
)
# PX4 1.14.0, FIRMWARE_VERSION_TYPE_OFFICIAL: major << 24 | minor << 16 | patch << 8 | type
DEFAULT_FLIGHT_SW_VERSION = 0x010E00FF

# POSITION_TARGET_LOCAL_NED type_mask bits of x, y, z, vx, vy, vz, afx, afy, afz, yaw
_POSITION_TARGET_IGNORE_BITS = (
    mavlink.POSITION_TARGET_TYPEMASK_X_IGNORE,
    mavlink.POSITION_TARGET_TYPEMASK_Y_IGNORE,
    mavlink.POSITION_TARGET_TYPEMASK_Z_IGNORE,
    mavlink.POSITION_TARGET_TYPEMASK_VX_IGNORE,
    mavlink.POSITION_TARGET_TYPEMASK_VY_IGNORE,
    mavlink.POSITION_TARGET_TYPEMASK_VZ_IGNORE,
    mavlink.POSITION_TARGET_TYPEMASK_AX_IGNORE,
    mavlink.POSITION_TARGET_TYPEMASK_AY_IGNORE,
    mavlink.POSITION_TARGET_TYPEMASK_AZ_IGNORE,
    mavlink.POSITION_TARGET_TYPEMASK_YAW_IGNORE,
)

# BatteryWarning (the commander's, from BAT_*_THR) -> BATTERY_STATUS.charge_state
_CHARGE_STATE = {
    BatteryWarning.NONE: mavlink.MAV_BATTERY_CHARGE_STATE_OK,
    BatteryWarning.LOW: mavlink.MAV_BATTERY_CHARGE_STATE_LOW,
    BatteryWarning.CRITICAL: mavlink.MAV_BATTERY_CHARGE_STATE_CRITICAL,
    BatteryWarning.EMERGENCY: mavlink.MAV_BATTERY_CHARGE_STATE_EMERGENCY,
}


# --------------------------------------------------------------------------- unit helpers


def clamp_int(x: float, lo: int, hi: int, invalid: int) -> int:
    """Round and clamp a value for an integer field; ``invalid`` for NaN/inf."""
    if not math.isfinite(x):
        return invalid
    v = int(round(x))
    return lo if v < lo else hi if v > hi else v


def cdeg_0_36000(angle_rad: float) -> int:
    """Heading/course in centidegrees 0..35999; UINT16_MAX if unknown."""
    if not math.isfinite(angle_rad):
        return UINT16_MAX
    return int(round((math.degrees(angle_rad) % 360.0) * 100.0)) % 36000


def floats(v: np.ndarray | Sequence[float]) -> list[float]:
    """A vector (an array or a sequence of numbers) as a list of Python floats, the same values."""
    return v.tolist() if type(v) is np.ndarray else [float(x) for x in v]


def time_boot_ms(now_us: int) -> int:
    """MAVLink's time_boot_ms (uint32, wraps): simulated milliseconds."""
    return (now_us // 1000) & 0xFFFFFFFF


def deg_e7(deg: float) -> int:
    """Degrees as degE7 (int32); 0 if unknown."""
    return clamp_int(deg * 1e7, -(2**31), INT32_MAX, 0)


# --------------------------------------------------------------------------- messages


def heartbeat(s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message:
    """HEARTBEAT as PX4 sends it: MAV_AUTOPILOT_PX4, PX4's base_mode flags and custom_mode."""
    return mavlink.MAVLink_heartbeat_message(
        s.mav_type, mavlink.MAV_AUTOPILOT_PX4, s.base_mode & 0xFF, s.custom_mode & 0xFFFFFFFF, s.system_status, 3
    )


def sys_status(s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message:
    """SYS_STATUS: sensor bits; battery voltage mV, current cA, remaining % (-1 / UINT16_MAX unknown)."""
    b = s.battery
    voltage_mv = clamp_int(b.voltage_v * 1000.0, 0, UINT16_MAX - 1, UINT16_MAX) if b.voltage_v > 0 else UINT16_MAX
    current_ca = clamp_int(b.current_a * 100.0, 0, INT16_MAX, -1) if b.current_a >= 0 else -1
    remaining = clamp_int(b.remaining_frac * 100.0, 0, 100, -1) if b.remaining_frac >= 0 else -1
    mask = 0xFFFFFFFF
    return mavlink.MAVLink_sys_status_message(
        s.sensors_present & mask, s.sensors_enabled & mask, s.sensors_health & mask,
        REPORTED_LOAD_PERMILLE, voltage_mv, current_ca, remaining, 0, 0, 0, 0, 0, 0,
    )  # fmt: skip


def extended_sys_state(s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message:
    """EXTENDED_SYS_STATE: the landed state (MAV_LANDED_STATE)."""
    return mavlink.MAVLink_extended_sys_state_message(mavlink.MAV_VTOL_STATE_UNDEFINED, int(s.landed_state))


def attitude(s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
    """ATTITUDE: roll, pitch, yaw (rad, FRD to NED) and body rates (rad/s)."""
    e = s.estimate
    if e is None:
        return None
    roll, pitch, yaw = to_euler(floats(e.q_wxyz))
    p, q, r = floats(e.rate_frd_rad_s)
    return mavlink.MAVLink_attitude_message(time_boot_ms(e.timestamp_us), roll, pitch, yaw, p, q, r)  # (PX4: its time)


def attitude_quaternion(s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
    """ATTITUDE_QUATERNION: q1..q4 = w, x, y, z (FRD to NED) and body rates (rad/s)."""
    e = s.estimate
    if e is None:
        return None
    w, x, y, z = floats(e.q_wxyz)
    p, q, r = floats(e.rate_frd_rad_s)
    return mavlink.MAVLink_attitude_quaternion_message(time_boot_ms(e.timestamp_us), w, x, y, z, p, q, r, [0.0] * 4)


def attitude_target(s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
    """The attitude, body-rate and collective-thrust setpoints of the cascade.  type_mask 0 (all valid, as PX4
    always sends) while an attitude is flown; while body rates are flown (ACRO, offboard rates) there is no
    attitude setpoint: ATTITUDE_IGNORE set and q the vehicle's own attitude (PX4 sends type_mask 0 and its last
    attitude setpoint, or zeros, then)."""
    c = s.control
    if c is None:
        return None
    q, mask = floats(c.q_sp_wxyz), 0
    if not all(math.isfinite(v) for v in q):
        mask = mavlink.ATTITUDE_TARGET_TYPEMASK_ATTITUDE_IGNORE
        q = floats(s.estimate.q_wxyz) if s.estimate is not None else [1.0, 0.0, 0.0, 0.0]
    p, q_rate, r = floats(c.rate_sp_frd_rad_s)
    thrust = min(max(c.thrust_frac, 0.0), 1.0) if math.isfinite(c.thrust_frac) else 0.0
    return mavlink.MAVLink_attitude_target_message(time_boot_ms(now_us), mask, q, p, q_rate, r, thrust)


def position_target_local_ned(s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
    """Position, velocity and acceleration setpoints (NED, estimator origin) and yaw; NaN parts flagged ignored."""
    c = s.control
    if c is None:
        return None
    values = [*floats(c.pos_ned_m), *floats(c.vel_ned_m_s), *floats(c.acc_ned_m_s2), float(c.yaw_rad)]
    mask = mavlink.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE  # no yaw-rate setpoint in NED
    for value, bit in zip(values, _POSITION_TARGET_IGNORE_BITS):
        if not math.isfinite(value):
            mask |= bit
    return mavlink.MAVLink_position_target_local_ned_message(
        time_boot_ms(now_us), mavlink.MAV_FRAME_LOCAL_NED, mask, *values, math.nan
    )


def position_target_global_int(s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
    """POSITION_TARGET_LOCAL_NED's setpoints with the position as lat/lon degE7 and altitude m AMSL
    (MAV_FRAME_GLOBAL_INT), from the estimator origin; NaN parts flagged ignored (sent as 0)."""
    local = position_target_local_ned(s, now_us)
    e = s.estimate
    if local is None or e is None:
        return None
    ned = [0.0 if math.isnan(v) else v for v in (local.x, local.y, local.z)]
    lat, lon, alt = ned_to_geodetic(ned, e.origin_lat_deg, e.origin_lon_deg, e.origin_alt_amsl_m)
    mask = local.type_mask
    return mavlink.MAVLink_position_target_global_int_message(
        local.time_boot_ms, mavlink.MAV_FRAME_GLOBAL_INT, mask,
        0 if mask & mavlink.POSITION_TARGET_TYPEMASK_X_IGNORE else deg_e7(lat),
        0 if mask & mavlink.POSITION_TARGET_TYPEMASK_Y_IGNORE else deg_e7(lon),
        0.0 if mask & mavlink.POSITION_TARGET_TYPEMASK_Z_IGNORE else alt,
        local.vx, local.vy, local.vz, local.afx, local.afy, local.afz, local.yaw, local.yaw_rate,
    )  # fmt: skip


def servo_output_raw(s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
    """Motor commands 0..1 as PWM microseconds (PWM_MIN_US..PWM_MAX_US; PWM_DISARMED_US when disarmed, but for
    a motor a motor test spins)."""
    if not s.motor_outputs:
        return None
    span = PWM_MAX_US - PWM_MIN_US
    pwm = [
        clamp_int(PWM_MIN_US + span * c, PWM_MIN_US, PWM_MAX_US, PWM_MIN_US) if s.armed or c > 0 else PWM_DISARMED_US
        for c in s.motor_outputs[:16]
    ]
    pwm += [0] * (16 - len(pwm))  # 0: output not used
    return mavlink.MAVLink_servo_output_raw_message(now_us & 0xFFFFFFFF, 0, *pwm)


def global_position_int(s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
    """GLOBAL_POSITION_INT: lat/lon degE7, alt AMSL and above home mm, velocity NED cm/s, heading cdeg."""
    e = s.estimate
    if e is None or not e.position_valid:
        return None
    pos = floats(e.pos_ned_m)
    lat, lon, alt = ned_to_geodetic(pos, e.origin_lat_deg, e.origin_lon_deg, e.origin_alt_amsl_m)
    rel_alt_m = float(s.home.pos_ned_m[2]) - pos[2] if s.home is not None else 0.0
    vn, ve, vd = [clamp_int(v * 100.0, -INT16_MAX - 1, INT16_MAX, 0) for v in floats(e.vel_ned_m_s)]
    yaw = to_euler(floats(e.q_wxyz))[2]
    return mavlink.MAVLink_global_position_int_message(
        time_boot_ms(e.timestamp_us), deg_e7(lat), deg_e7(lon), clamp_int(alt * 1000.0, *_INT32),
        clamp_int(rel_alt_m * 1000.0, *_INT32), vn, ve, vd, cdeg_0_36000(yaw),
    )  # fmt: skip


def local_position_ned(s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
    """LOCAL_POSITION_NED: position (m) and velocity (m/s) from the estimator origin."""
    e = s.estimate
    if e is None or not e.position_valid:
        return None
    x, y, z = floats(e.pos_ned_m)
    vx, vy, vz = floats(e.vel_ned_m_s)
    return mavlink.MAVLink_local_position_ned_message(time_boot_ms(e.timestamp_us), x, y, z, vx, vy, vz)


def gps_raw_int(s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
    """GPS_RAW_INT: the latest fix; eph/epv cm, speed cm/s, course cdeg, accuracies mm."""
    g = s.gps
    if g is None:
        return None
    vn, ve = float(g.vel_ned_m_s[0]), float(g.vel_ned_m_s[1])
    speed = math.hypot(vn, ve)

    def acc_cm(x_m: float) -> int:
        return clamp_int(x_m * 100.0, 0, UINT16_MAX - 1, UINT16_MAX) if x_m >= 0 else UINT16_MAX

    def acc_mm(x_m: float) -> int:
        return clamp_int(x_m * 1000.0, 0, 2**32 - 1, 0) if x_m >= 0 else 0

    return mavlink.MAVLink_gps_raw_int_message(
        g.timestamp_us, g.fix_type, deg_e7(g.lat_deg), deg_e7(g.lon_deg),
        clamp_int(g.alt_amsl_m * 1000.0, *_INT32), acc_cm(g.eph_m), acc_cm(g.epv_m),
        clamp_int(speed * 100.0, 0, UINT16_MAX - 1, UINT16_MAX), cdeg_0_36000(math.atan2(ve, vn)),
        clamp_int(g.satellites, 0, 255, 255), 0, acc_mm(g.eph_m), acc_mm(g.epv_m), 0, 0, 0,
    )  # fmt: skip


def estimator_status(s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
    """ESTIMATOR_STATUS: flags, test ratios and 1-sigma position accuracies (m)."""
    st = s.estimator_status
    if st is None:
        return None
    return mavlink.MAVLink_estimator_status_message(
        now_us,
        st.flags,
        st.vel_ratio,
        st.pos_horiz_ratio,
        st.pos_vert_ratio,
        st.mag_ratio,
        0.0,
        0.0,
        st.pos_horiz_accuracy_m,
        st.pos_vert_accuracy_m,
    )


def vfr_hud(s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
    """VFR_HUD: ground speed (m/s), heading (deg 0..359), throttle %, altitude AMSL (m), climb (m/s)."""
    e = s.estimate
    if e is None:
        return None
    vn, ve, vd = floats(e.vel_ned_m_s)
    speed = math.hypot(vn, ve)
    yaw = to_euler(floats(e.q_wxyz))[2]
    heading_deg = int(round(math.degrees(yaw) % 360.0)) % 360 if math.isfinite(yaw) else 0
    throttle = clamp_int(s.throttle_frac * 100.0, 0, 100, 0)
    return mavlink.MAVLink_vfr_hud_message(speed, speed, heading_deg, throttle, e.alt_amsl_m, -vd)


def home_position(s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message | None:
    """HOME_POSITION: lat/lon degE7, alt AMSL mm, local position (m NED) and heading as a quaternion."""
    h = s.home
    if h is None:
        return None
    x, y, z = (float(v) for v in h.pos_ned_m)
    q_yaw = [math.cos(h.yaw_rad / 2.0), 0.0, 0.0, math.sin(h.yaw_rad / 2.0)]  # as PX4: heading only
    return mavlink.MAVLink_home_position_message(
        deg_e7(h.lat_deg), deg_e7(h.lon_deg), clamp_int(h.alt_amsl_m * 1000.0, *_INT32),
        x, y, z, q_yaw, 0.0, 0.0, 0.0, now_us,
    )  # fmt: skip


def battery_status(s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message:
    """BATTERY_STATUS: cell voltages mV, current cA, consumed mAh, remaining %, charge state from the warning."""
    b = s.battery
    voltages = [UINT16_MAX] * 10
    if b.voltage_v > 0 and math.isfinite(b.voltage_v):
        cells = min(max(int(b.cell_count), 1), 10)
        cell_mv = clamp_int(b.voltage_v * 1000.0 / cells, 0, UINT16_MAX - 1, UINT16_MAX)
        voltages[:cells] = [cell_mv] * cells
    current_ca = clamp_int(b.current_a * 100.0, 0, INT16_MAX, -1) if b.current_a >= 0 else -1
    if b.remaining_frac >= 0:
        remaining = clamp_int(b.remaining_frac * 100.0, 0, 100, -1)
        charge_state = _CHARGE_STATE[s.battery_warning]
    else:
        remaining, charge_state = -1, mavlink.MAV_BATTERY_CHARGE_STATE_UNDEFINED
    return mavlink.MAVLink_battery_status_message(
        0, mavlink.MAV_BATTERY_FUNCTION_UNKNOWN, mavlink.MAV_BATTERY_TYPE_LIPO, INT16_MAX, voltages,
        current_ca, clamp_int(b.consumed_mah, 0, 2**31 - 1, -1) if b.consumed_mah >= 0 else -1, -1, remaining, 0,
        charge_state, [0, 0, 0, 0], 0, 0,
    )  # fmt: skip


Builder = Callable[[TelemetrySnapshot, int], "mavlink.MAVLink_message | None"]


# Message id -> builder: the messages the link can stream and send on REQUEST_MESSAGE.
def mission_current(s: TelemetrySnapshot, now_us: int) -> mavlink.MAVLink_message:
    """MISSION_CURRENT: the current item (== total once complete), total, MISSION_STATE and whether the vehicle
    is in mission mode (1) or the mission is suspended (2)."""
    m = s.mission
    mode = 1 if m.in_mission_mode else 2
    return mavlink.MAVLink_mission_current_message(max(m.seq, 0) & 0xFFFF, m.total & 0xFFFF, int(m.state), mode)


BUILDERS: dict[int, Builder] = {
    mavlink.MAVLINK_MSG_ID_HEARTBEAT: heartbeat,
    mavlink.MAVLINK_MSG_ID_SYS_STATUS: sys_status,
    mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: extended_sys_state,
    mavlink.MAVLINK_MSG_ID_ATTITUDE: attitude,
    mavlink.MAVLINK_MSG_ID_ATTITUDE_QUATERNION: attitude_quaternion,
    mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: global_position_int,
    mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED: local_position_ned,
    mavlink.MAVLINK_MSG_ID_GPS_RAW_INT: gps_raw_int,
    mavlink.MAVLINK_MSG_ID_VFR_HUD: vfr_hud,
    mavlink.MAVLINK_MSG_ID_HOME_POSITION: home_position,
    mavlink.MAVLINK_MSG_ID_BATTERY_STATUS: battery_status,
    mavlink.MAVLINK_MSG_ID_ATTITUDE_TARGET: attitude_target,
    mavlink.MAVLINK_MSG_ID_POSITION_TARGET_LOCAL_NED: position_target_local_ned,
    mavlink.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT: position_target_global_int,
    mavlink.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW: servo_output_raw,
    mavlink.MAVLINK_MSG_ID_ESTIMATOR_STATUS: estimator_status,
    mavlink.MAVLINK_MSG_ID_MISSION_CURRENT: mission_current,
}

# Telemetry streams sent on every endpoint, rate in Hz of simulated time.
DEFAULT_STREAM_RATES_HZ: dict[int, float] = {
    mavlink.MAVLINK_MSG_ID_HEARTBEAT: 1.0,
    mavlink.MAVLINK_MSG_ID_SYS_STATUS: 1.0,
    mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE: 1.0,
    mavlink.MAVLINK_MSG_ID_ATTITUDE: 20.0,
    mavlink.MAVLINK_MSG_ID_ATTITUDE_QUATERNION: 10.0,
    mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT: 5.0,
    mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED: 5.0,
    mavlink.MAVLINK_MSG_ID_GPS_RAW_INT: 2.0,
    mavlink.MAVLINK_MSG_ID_VFR_HUD: 4.0,
    mavlink.MAVLINK_MSG_ID_HOME_POSITION: 0.5,
    mavlink.MAVLINK_MSG_ID_BATTERY_STATUS: 0.5,
    # setpoint against actual while tuning: ATTITUDE_TARGET at ATTITUDE's rate (PX4 onboard profile: 10 Hz)
    mavlink.MAVLINK_MSG_ID_ATTITUDE_TARGET: 20.0,
    mavlink.MAVLINK_MSG_ID_POSITION_TARGET_LOCAL_NED: 10.0,
    mavlink.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT: 1.0,  # PX4's normal profile
    mavlink.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW: 5.0,  # motor outputs as PWM µs, as PX4 reports them
    mavlink.MAVLINK_MSG_ID_MISSION_CURRENT: 1.0,  # and at once when the item changes (the link)
    mavlink.MAVLINK_MSG_ID_ESTIMATOR_STATUS: 2.0,  # the EKF's health (PX4 normal profile)
}
