"""Telemetry messages as pure functions of the vehicle's state (autopilot.mavlink.telemetry), no socket.

Each message is built from a TelemetrySnapshot, packed as MAVLink 2 and parsed back,
and the test reads the fields a ground station reads, in MAVLink's units: degE7, mm,
cm/s, centidegrees, mV, cA, %, PWM µs, PX4's custom_mode.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink

from autopilot.commander import health
from autopilot.mavlink import identity, telemetry
from autopilot.mavlink.vehicle_interface import telemetry_snapshot
from autopilot.topics import (
    ActuatorStatus,
    BatteryState,
    BatteryWarning,
    CommanderStatus,
    ControlSetpoints,
    EstimatorStatus,
    GpsSample,
    HomePosition,
    LandedState,
    TelemetrySnapshot,
    VehicleEstimate,
)
from mavsim_core.geodesy import ned_to_geodetic
from mavsim_core.px4_modes import Mode
from mavsim_core.quaternion import from_euler

ORIGIN = (47.397742, 8.545594, 488.0)
NOW_US = 123_456_789


def _estimate(**kw) -> VehicleEstimate:
    fields = dict(
        timestamp_us=NOW_US, q_wxyz=from_euler(0.1, -0.2, math.radians(250.0)),
        rate_frd_rad_s=np.array([0.01, -0.02, 0.03]), accel_ned_m_s2=np.zeros(3),
        pos_ned_m=np.array([10.0, -20.0, -5.0]), vel_ned_m_s=np.array([1.5, -2.0, -0.4]),
        attitude_valid=True, position_valid=True,
        origin_lat_deg=ORIGIN[0], origin_lon_deg=ORIGIN[1], origin_alt_amsl_m=ORIGIN[2],
    )  # fmt: skip
    fields.update(kw)
    return VehicleEstimate(**fields)


def _snapshot(**kw) -> TelemetrySnapshot:
    mode = Mode.AUTO_LOITER
    fields = dict(
        timestamp_us=NOW_US, mav_type=mavlink.MAV_TYPE_HEXAROTOR, armed=True, base_mode=mode.base_mode_flags(True),
        custom_mode=mode.custom_mode, system_status=mavlink.MAV_STATE_ACTIVE, landed_state=LandedState.IN_AIR,
        estimate=_estimate(),
        gps=GpsSample(NOW_US - 50_000, 3, 47.3978, 8.5458, 493.25, np.array([0.0, 2.0, 0.1]), 0.85, 1.3, 14),
        home=HomePosition(ORIGIN[0], ORIGIN[1], ORIGIN[2], np.array([0.0, 0.0, -0.5]), math.pi / 2),
        battery=BatteryState(voltage_v=15.2, current_a=12.34, remaining_frac=0.62, cell_count=4, consumed_mah=850.4),
        throttle_frac=0.555, sensors_present=health.SENSORS_PRESENT, sensors_enabled=health.SENSORS_PRESENT,
        sensors_health=health.SENSORS_PRESENT & ~mavlink.MAV_SYS_STATUS_SENSOR_GPS, prearm_ok=True,
        motor_outputs=(0.0, 0.25, 0.5, 1.0, 1.2, -0.1),
    )  # fmt: skip
    fields.update(kw)
    return TelemetrySnapshot(**fields)


def _wire(msg: mavlink.MAVLink_message) -> mavlink.MAVLink_message:
    """Pack as the flight controller (sysid 1, compid 1) and parse as a ground station."""
    data = msg.pack(mavlink.MAVLink(None, 1, 1))
    (back,) = mavlink.MAVLink(None).parse_buffer(data)
    assert back.get_type() == msg.get_type()
    return back


def _build(mid: int, snap: TelemetrySnapshot) -> mavlink.MAVLink_message:
    return _wire(telemetry.BUILDERS[mid](snap, NOW_US))


# --------------------------------------------------------------------------- identity and status


def test_heartbeat_px4_identity_and_custom_mode():
    hb = _build(mavlink.MAVLINK_MSG_ID_HEARTBEAT, _snapshot())
    assert hb.autopilot == mavlink.MAV_AUTOPILOT_PX4 and hb.type == mavlink.MAV_TYPE_HEXAROTOR
    assert hb.custom_mode == 4 << 16 | 3 << 24  # AUTO (4), LOITER (3)
    assert hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    assert hb.base_mode & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED
    assert hb.system_status == mavlink.MAV_STATE_ACTIVE and hb.mavlink_version == 3


def test_sys_status_battery_units_and_sensor_bits():
    st = _build(mavlink.MAVLINK_MSG_ID_SYS_STATUS, _snapshot())
    assert (st.voltage_battery, st.current_battery, st.battery_remaining) == (15200, 1234, 62)  # mV, cA, %
    assert st.onboard_control_sensors_present == health.SENSORS_PRESENT
    assert not st.onboard_control_sensors_health & mavlink.MAV_SYS_STATUS_SENSOR_GPS
    unknown = _build(mavlink.MAVLINK_MSG_ID_SYS_STATUS, _snapshot(battery=BatteryState(math.nan, -1.0, -1.0)))
    assert (unknown.voltage_battery, unknown.current_battery, unknown.battery_remaining) == (65535, -1, -1)


def test_extended_sys_state_landed_state():
    for state in LandedState:
        assert _build(mavlink.MAVLINK_MSG_ID_EXTENDED_SYS_STATE, _snapshot(landed_state=state)).landed_state == state


# --------------------------------------------------------------------------- attitude and position


def test_attitude_radians_and_quaternion():
    snap = _snapshot()
    att = _build(mavlink.MAVLINK_MSG_ID_ATTITUDE, snap)
    assert (att.roll, att.pitch) == pytest.approx((0.1, -0.2), abs=1e-6)
    assert att.yaw == pytest.approx(math.radians(250.0) - 2 * math.pi, abs=1e-6)  # -pi..pi
    assert (att.rollspeed, att.pitchspeed, att.yawspeed) == pytest.approx((0.01, -0.02, 0.03))
    assert att.time_boot_ms == NOW_US // 1000
    aq = _build(mavlink.MAVLINK_MSG_ID_ATTITUDE_QUATERNION, snap)
    assert [aq.q1, aq.q2, aq.q3, aq.q4] == pytest.approx(list(snap.estimate.q_wxyz), abs=1e-7)


def test_global_position_int_dege7_mm_cm_s_cdeg():
    gpi = _build(mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, _snapshot())
    lat, lon, alt = ned_to_geodetic([10.0, -20.0, -5.0], *ORIGIN)
    assert (gpi.lat, gpi.lon) == (round(lat * 1e7), round(lon * 1e7))
    assert gpi.alt == 493000  # mm AMSL
    assert gpi.relative_alt == 4500  # mm above home (home is 0.5 m up)
    assert (gpi.vx, gpi.vy, gpi.vz) == (150, -200, -40)  # cm/s NED
    assert gpi.hdg == 25000  # centidegrees 0..35999


def test_local_position_ned_metres():
    lpn = _build(mavlink.MAVLINK_MSG_ID_LOCAL_POSITION_NED, _snapshot())
    assert (lpn.x, lpn.y, lpn.z, lpn.vx, lpn.vy, lpn.vz) == pytest.approx((10.0, -20.0, -5.0, 1.5, -2.0, -0.4))


def test_no_position_no_position_messages():
    snap = _snapshot(estimate=_estimate(position_valid=False))
    assert telemetry.global_position_int(snap, NOW_US) is None
    assert telemetry.local_position_ned(snap, NOW_US) is None
    none = _snapshot(estimate=None, gps=None, home=None)
    for builder in (
        telemetry.attitude,
        telemetry.attitude_quaternion,
        telemetry.vfr_hud,
        telemetry.gps_raw_int,
        telemetry.home_position,
        telemetry.attitude_target,
        telemetry.estimator_status,
    ):
        assert builder(none, NOW_US) is None


def test_gps_raw_int_units():
    gps = _build(mavlink.MAVLINK_MSG_ID_GPS_RAW_INT, _snapshot())
    assert (gps.lat, gps.lon, gps.alt) == (473978000, 85458000, 493250)  # degE7, mm
    assert (gps.eph, gps.epv, gps.h_acc, gps.v_acc) == (85, 130, 850, 1300)  # cm, cm, mm, mm
    assert (gps.vel, gps.cog) == (200, 9000)  # cm/s, cdeg (due east)
    assert (gps.fix_type, gps.satellites_visible, gps.time_usec) == (3, 14, NOW_US - 50_000)


def test_vfr_hud():
    hud = _build(mavlink.MAVLINK_MSG_ID_VFR_HUD, _snapshot())
    assert hud.heading == 250 and hud.throttle == 56  # degrees, percent (rounded)
    assert hud.groundspeed == pytest.approx(2.5) and hud.climb == pytest.approx(0.4)
    assert hud.alt == pytest.approx(493.0)


def test_home_position():
    home = _build(mavlink.MAVLINK_MSG_ID_HOME_POSITION, _snapshot())
    assert (home.latitude, home.longitude, home.altitude) == (473977420, 85455940, 488000)
    assert (home.x, home.y, home.z) == pytest.approx((0.0, 0.0, -0.5))
    assert list(home.q) == pytest.approx([math.cos(math.pi / 4), 0.0, 0.0, math.sin(math.pi / 4)])  # heading east


# --------------------------------------------------------------------------- battery


@pytest.mark.parametrize(
    "warning, charge_state",
    [
        (BatteryWarning.NONE, mavlink.MAV_BATTERY_CHARGE_STATE_OK),
        (BatteryWarning.LOW, mavlink.MAV_BATTERY_CHARGE_STATE_LOW),
        (BatteryWarning.CRITICAL, mavlink.MAV_BATTERY_CHARGE_STATE_CRITICAL),
        (BatteryWarning.EMERGENCY, mavlink.MAV_BATTERY_CHARGE_STATE_EMERGENCY),
    ],
)
def test_battery_status_cells_and_charge_state(warning, charge_state):
    bat = _build(mavlink.MAVLINK_MSG_ID_BATTERY_STATUS, _snapshot(battery_warning=warning))
    assert list(bat.voltages) == [3800] * 4 + [65535] * 6  # mV per cell
    assert (bat.current_battery, bat.current_consumed, bat.battery_remaining) == (1234, 850, 62)  # cA, mAh, %
    assert bat.charge_state == charge_state and bat.type == mavlink.MAV_BATTERY_TYPE_LIPO


def test_battery_status_unknown_charge():
    bat = _build(mavlink.MAVLINK_MSG_ID_BATTERY_STATUS, _snapshot(battery=BatteryState(math.nan, -1.0, -1.0)))
    assert list(bat.voltages) == [65535] * 10
    assert (bat.current_battery, bat.current_consumed, bat.battery_remaining) == (-1, -1, -1)
    assert bat.charge_state == mavlink.MAV_BATTERY_CHARGE_STATE_UNDEFINED


# --------------------------------------------------------------------------- setpoints and outputs


def test_servo_output_raw_pwm():
    out = _build(mavlink.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW, _snapshot())
    pwm = [getattr(out, f"servo{i}_raw") for i in range(1, 17)]
    assert pwm == [1000, 1250, 1500, 2000, 2000, 1000] + [0] * 10  # clamped to 1000..2000, unused 0
    disarmed = _build(mavlink.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW, _snapshot(armed=False, motor_outputs=(0.0,) * 6))
    assert [getattr(disarmed, f"servo{i}_raw") for i in range(1, 7)] == [900] * 6
    motor_test = _build(mavlink.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW, _snapshot(armed=False, motor_outputs=(0, 0.2, 0)))
    assert [getattr(motor_test, f"servo{i}_raw") for i in range(1, 4)] == [900, 1200, 900]  # DO_MOTOR_TEST
    assert telemetry.servo_output_raw(_snapshot(motor_outputs=()), NOW_US) is None


def test_attitude_and_position_targets():
    control = ControlSetpoints(
        timestamp_us=NOW_US,
        pos_ned_m=np.array([1.0, 2.0, math.nan]),
        vel_ned_m_s=np.array([0.1, 0.2, -0.5]),
        acc_ned_m_s2=np.array([0.0, 0.3, -0.1]),
        yaw_rad=1.0,
        q_sp_wxyz=from_euler(0.1, 0.0, 1.0),
        rate_sp_frd_rad_s=np.array([0.2, -0.1, 0.05]),
        thrust_frac=1.7,
    )
    snap = _snapshot(control=control)
    at = _build(mavlink.MAVLINK_MSG_ID_ATTITUDE_TARGET, snap)
    assert at.type_mask == 0 and at.thrust == 1.0  # clamped to 0..1
    assert list(at.q) == pytest.approx(list(control.q_sp_wxyz), abs=1e-7)
    pt = _build(mavlink.MAVLINK_MSG_ID_POSITION_TARGET_LOCAL_NED, snap)
    assert pt.coordinate_frame == mavlink.MAV_FRAME_LOCAL_NED
    assert pt.type_mask & mavlink.POSITION_TARGET_TYPEMASK_Z_IGNORE  # NaN: not controlled
    assert not pt.type_mask & mavlink.POSITION_TARGET_TYPEMASK_X_IGNORE
    assert (pt.x, pt.y, pt.vz, pt.afy, pt.yaw) == pytest.approx((1.0, 2.0, -0.5, 0.3, 1.0))


def test_estimator_status():
    st = EstimatorStatus(NOW_US, 0x1F, 0.1, 0.2, 0.3, 0.4, 0.8, 1.2, 0.01, 0.05, False, False, True)
    es = _build(mavlink.MAVLINK_MSG_ID_ESTIMATOR_STATUS, _snapshot(estimator_status=st))
    assert es.flags == 0x1F and es.time_usec == NOW_US
    assert (es.vel_ratio, es.pos_horiz_ratio, es.pos_vert_ratio, es.mag_ratio) == pytest.approx((0.1, 0.2, 0.3, 0.4))
    assert (es.pos_horiz_accuracy, es.pos_vert_accuracy) == pytest.approx((0.8, 1.2))


def test_autopilot_version():
    v = _wire(identity.autopilot_version(identity.Identity(flight_custom_version=b"mavsim", uid=42)))
    assert v.capabilities & mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE
    assert v.flight_sw_version >> 24 == 1 and (v.flight_sw_version >> 16) & 0xFF == 14  # PX4 1.14
    assert bytes(v.flight_custom_version) == b"mavsim\x00\x00" and v.uid == 42


def test_nan_never_raises():
    nan3 = np.full(3, math.nan)
    snap = _snapshot(
        estimate=_estimate(q_wxyz=np.full(4, math.nan), rate_frd_rad_s=nan3, pos_ned_m=nan3, vel_ned_m_s=nan3),
        throttle_frac=math.nan,
        battery=BatteryState(math.nan, math.nan, math.nan),
    )
    for mid, builder in telemetry.BUILDERS.items():
        msg = builder(snap, NOW_US)
        if msg is not None:
            _wire(msg)
    gpi = _build(mavlink.MAVLINK_MSG_ID_GLOBAL_POSITION_INT, snap)
    assert (gpi.lat, gpi.vx, gpi.hdg) == (0, 0, 65535)


# --------------------------------------------------------------------------- records -> snapshot


def _status(**kw) -> CommanderStatus:
    fields = dict(
        timestamp_us=NOW_US, mav_type=mavlink.MAV_TYPE_QUADROTOR, armed=False, mode=Mode.POSCTL,
        landed_state=LandedState.ON_GROUND, in_air=False, ground_contact=True, home=None, estimate=_estimate(),
        gps=None, gps_ok=True, battery=BatteryState(16.0, 1.0, 0.1), battery_warning=BatteryWarning.LOW,
        prearm_failures=("battery low (10%)",), position_setpoint_ned_m=None,
    )  # fmt: skip
    fields.update(kw)
    return CommanderStatus(**fields)


def test_snapshot_from_the_published_records():
    actuators = ActuatorStatus(NOW_US, (0.15,) * 4, 3.0, 0.15, 0.2)
    est_status = EstimatorStatus(NOW_US, 0, 0.1, 0.2, 0.3, 0.4, 0.8, 1.2, 0.01, 0.05, True, False, True)
    snap = telemetry_snapshot(_status(), actuators, None, est_status, True)
    hb = _wire(telemetry.heartbeat(snap, NOW_US))
    assert hb.custom_mode == 3 << 16 and not hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    assert hb.system_status == mavlink.MAV_STATE_STANDBY
    bits = snap.sensors_health
    assert not bits & mavlink.MAV_SYS_STATUS_PREARM_CHECK  # a pre-arm check fails
    assert not bits & mavlink.MAV_SYS_STATUS_SENSOR_3D_MAG  # the EKF reports a magnetometer fault
    assert not bits & mavlink.MAV_SYS_STATUS_AHRS  # the EKF's attitude flag is not set
    assert bits & mavlink.MAV_SYS_STATUS_SENSOR_GPS and not snap.prearm_ok
    assert snap.throttle_frac == 0.15 and snap.motor_outputs == (0.15,) * 4
    assert _wire(telemetry.battery_status(snap, NOW_US)).charge_state == mavlink.MAV_BATTERY_CHARGE_STATE_LOW
    armed = telemetry_snapshot(replace(_status(), armed=True, prearm_failures=()), actuators, None, None, False)
    assert armed.prearm_ok and armed.sensors_health & mavlink.MAV_SYS_STATUS_PREARM_CHECK
    assert _wire(telemetry.heartbeat(armed, NOW_US)).system_status == mavlink.MAV_STATE_ACTIVE
    booting = telemetry_snapshot(_status(estimate=None), actuators, None, None, False)
    assert booting.system_status == mavlink.MAV_STATE_BOOT
