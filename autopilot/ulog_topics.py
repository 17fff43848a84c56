"""What the flight controller writes into a flight's ULog: PX4's topics, field names and units.

:class:`FlightULog` writes one file (:mod:`mavsim_core.ulog_writer`) from the records the flight
controller, the commander and the estimator publish, read after each control step (nothing in them changes).
The topics carry PX4's names so pyulog, Flight Review and PlotJuggler treat the file as a PX4
log; each holds the PX4 fields this flight controller can fill (others are left out, not faked).
Frames as PX4's: NED world, FRD body, quaternions (w, x, y, z) FRD -> NED; SI units; timestamps
in µs of simulated time (the lockstep clock).  Rates (simulated time):

===================================  =======  ==================================================
vehicle_attitude, vehicle_angular_    83 Hz   attitude estimate, bias-corrected body rates,
velocity, sensor_combined,                    raw IMU, attitude and body-rate setpoints
vehicle_attitude_setpoint,
vehicle_rates_setpoint
vehicle_local_position(_setpoint),    50 Hz   position estimate (from the estimator origin),
trajectory_setpoint, actuator_                position-controller setpoints, the flight task's
outputs, actuator_motors                      setpoint, motor commands 0..1
vehicle_global_position,              10 Hz   position as latitude/longitude, barometer,
vehicle_air_data, battery_status              battery
vehicle_gps_position                  each    every new GPS fix the commander used
vehicle_status, vehicle_land_         5 Hz    arming state, PX4 nav_state, landed state; PX4's
detected, flight_mode                         custom main and sub mode (our own topic: nav_state
                                              cannot tell every mode apart) (and at once on a
                                              change)
control_allocator_status             50 Hz   the collective thrust the mixer could not deliver
                                              (setpoint minus delivered, as PX4's)
landing_target_pose, precision_      50 Hz   a precision landing: the target relative to the
landing (our own topic)                       vehicle, the landing's phase, the measurements
                                              fused, the target's velocity over the ground
===================================  =======  ==================================================

Setpoint topics are written only while the cascade flies (as PX4 publishes them); the
STATUSTEXTs the vehicle sends become logged strings, parameter changes 'P' messages.  This file is
the flight controller's only flight log: ``gcs plot``, the replay and the benchmarks read it with
pyulog (:mod:`gcs.flight_logs`).
"""

from __future__ import annotations

import math
import time
from pathlib import Path

from autopilot.control.position_control import PositionSetpoint
from autopilot.estimation.estimator import pressure_to_altitude_m
from autopilot.mavlink.identity import running_commit
from autopilot.mavlink.telemetry import DEFAULT_FLIGHT_SW_VERSION
from autopilot.topics import ImuSample
from mavsim_core.constants import LOCKSTEP_DT_US
from mavsim_core.geodesy import ned_to_geodetic
from mavsim_core.param_types import ParamType
from mavsim_core.ulog_writer import (
    DEFAULT_CONFIGURATION,
    DEFAULT_SYSTEM,
    SubscriptionGroup,
    ULogFormat,
    ULogWriter,
)

SUFFIX = ".ulg"
FAST_US, POSITION_US, SLOW_US, STATUS_US = 12_000, 20_000, 100_000, 200_000  # logging intervals
SYNC_US = 1_000_000  # a sync marker, and the file flushed to disk (a download sees it), every second
SLACK_US = 1_000  # a step early counts as due (steps are 4 ms: 12 ms is every third step)
N_OUTPUTS, N_MOTORS = 16, 12  # actuator_outputs.output[16], actuator_motors.control[12]
R_AIR = 287.05  # J/(kg K), specific gas constant of dry air
THRUST_ACHIEVED = 1e-3  # control_allocator_status: the thrust setpoint delivered to this fraction of the maximum

# PX4's vehicle_status.nav_state for our (main, sub) modes (PX4's vehicle_status.msg)
NAV_STATE: dict[tuple[int, int], int] = {
    (1, 0): 0, (2, 0): 1, (3, 0): 2, (3, 1): 21, (4, 1): 4, (4, 2): 17, (4, 3): 4, (4, 4): 3, (4, 5): 5,
    (4, 6): 18, (4, 8): 19, (4, 9): 20, (5, 0): 10, (6, 0): 14, (7, 0): 15,
}  # fmt: skip
ARMING_STATE_DISARMED, ARMING_STATE_ARMED = 1, 2
VEHICLE_TYPE_ROTARY_WING = 1

_T = "uint64_t timestamp"
_TS = "uint64_t timestamp_sample"
FORMATS: tuple[ULogFormat, ...] = (
    ULogFormat("vehicle_attitude", (_T, _TS, "float[4] q", "float[4] delta_q_reset", "uint8_t quat_reset_counter")),
    ULogFormat("vehicle_angular_velocity", (_T, _TS, "float[3] xyz")),
    ULogFormat("sensor_combined", (
        _T, "float[3] gyro_rad", "uint32_t gyro_integral_dt", "int32_t accelerometer_timestamp_relative",
        "float[3] accelerometer_m_s2", "uint32_t accelerometer_integral_dt")),
    ULogFormat("vehicle_attitude_setpoint", (_T, "float[4] q_d", "float[3] thrust_body")),
    ULogFormat("vehicle_rates_setpoint", (_T, "float roll", "float pitch", "float yaw", "float[3] thrust_body")),
    ULogFormat("vehicle_local_position", (
        _T, _TS, "bool xy_valid", "bool z_valid", "bool v_xy_valid", "bool v_z_valid", "float x", "float y",
        "float z", "float vx", "float vy", "float vz", "float ax", "float ay", "float az", "float heading",
        "uint8_t xy_reset_counter", "uint8_t z_reset_counter", "bool xy_global", "bool z_global",
        "double ref_lat", "double ref_lon", "float ref_alt")),
    ULogFormat("vehicle_local_position_setpoint", (
        _T, "float x", "float y", "float z", "float vx", "float vy", "float vz", "float[3] acceleration",
        "float[3] thrust", "float yaw", "float yawspeed")),
    ULogFormat("trajectory_setpoint", (
        _T, "float[3] position", "float[3] velocity", "float[3] acceleration", "float[3] jerk", "float yaw",
        "float yawspeed")),
    ULogFormat("actuator_outputs", (_T, "uint32_t noutputs", f"float[{N_OUTPUTS}] output")),
    ULogFormat("actuator_motors", (_T, _TS, "uint16_t reversible_flags", f"float[{N_MOTORS}] control")),
    ULogFormat("vehicle_global_position", (
        _T, _TS, "double lat", "double lon", "float alt", "bool lat_lon_valid", "bool alt_valid")),
    ULogFormat("vehicle_gps_position", (
        _T, _TS, "double latitude_deg", "double longitude_deg", "double altitude_msl_m", "uint8_t fix_type",
        "float eph", "float epv", "float vel_m_s", "float vel_n_m_s", "float vel_e_m_s", "float vel_d_m_s",
        "float cog_rad", "bool vel_ned_valid", "uint64_t time_utc_usec", "uint8_t satellites_used")),
    ULogFormat("vehicle_air_data", (
        _T, _TS, "float baro_alt_meter", "float baro_temp_celcius", "float baro_pressure_pa", "float rho")),
    ULogFormat("battery_status", (
        _T, "bool connected", "float voltage_v", "float voltage_filtered_v", "float current_a",
        "float current_filtered_a", "float discharged_mah", "float remaining", "uint8_t cell_count",
        "uint8_t warning")),
    ULogFormat("vehicle_status", (
        _T, "uint64_t armed_time", "uint64_t takeoff_time", "uint64_t nav_state_timestamp", "uint8_t arming_state",
        "uint8_t nav_state", "uint8_t vehicle_type", "bool failsafe", "uint8_t system_type", "uint8_t system_id",
        "uint8_t component_id", "bool rc_signal_lost", "bool gcs_connection_lost")),
    ULogFormat("vehicle_land_detected", (_T, "bool ground_contact", "bool maybe_landed", "bool landed")),
    ULogFormat("flight_mode", (_T, "uint8_t main_mode", "uint8_t sub_mode")),  # ours: PX4's custom_mode halves
    ULogFormat("control_allocator_status", (_T, "bool thrust_setpoint_achieved", "float[3] unallocated_thrust")),
    ULogFormat("landing_target_pose", (
        _T, "bool is_static", "bool rel_pos_valid", "bool rel_vel_valid", "float x_rel", "float y_rel", "float z_rel",
        "float vx_rel", "float vy_rel", "float cov_x_rel", "float cov_y_rel", "bool abs_pos_valid", "float x_abs",
        "float y_abs", "float z_abs")),
    ULogFormat("precision_landing", (  # ours: PX4 logs no precision-landing state
        _T, "uint8_t phase", "uint32_t measurements", "float target_vx", "float target_vy")),
)  # fmt: skip
# precision_landing.phase: 1..8 in this order; 0 none
PRECLAND_PHASES = ("preparation", "tracking", "approaching", "docking", "search", "fallback", "done", "touchdown")
_NAN3 = (math.nan,) * 3
_NO_RESET = (0.0, 0.0, 0.0, 0.0, 0)  # delta_q_reset[4], quat_reset_counter


def write_parameters(w: ULogWriter, params) -> None:
    """Every parameter's value ('P'), and the default of each one that differs from it ('Q')."""
    for name in params.names():
        is_int = params.definition(name).ptype == ParamType.INT32
        w.add_parameter(name, params.get(name), is_int)
    for name in params.changed():
        is_int = params.definition(name).ptype == ParamType.INT32
        w.add_default_parameter(name, params.default(name), is_int, DEFAULT_SYSTEM | DEFAULT_CONFIGURATION)


class FlightULog:
    """One flight's ULog: call :meth:`record` after every control step, :meth:`close` at the end.

    ``start_us`` is the simulated time logging starts; ``utc_start_us`` the wall-clock UTC (µs since
    the epoch) taken for that instant (for the GPS topic's ``time_utc_usec``).
    """

    def __init__(
        self, path: str | Path, fc, start_us: int, utc_start_us: int, sysid: int, compid: int = 1, sys_uuid: str = ""
    ) -> None:
        self.fc = fc
        self.start_us = start_us
        self.utc_offset_us = utc_start_us - start_us
        self.sysid, self.compid = sysid, compid
        w = self.writer = ULogWriter(path, start_us)
        for fmt in FORMATS:
            w.add_format(fmt)
        w.add_info("sys_name", "PX4")
        w.add_info("ver_hw", "MAVSIM_SITL")
        w.add_info("ver_sw_release", DEFAULT_FLIGHT_SW_VERSION, "uint32_t")
        commit = running_commit()  # the running code's git commit, as PX4 logs its own (none if installed)
        if commit is not None:
            w.add_info("ver_sw", commit)
        w.add_info("sys_os_name", "Linux")
        w.add_info("sys_toolchain", "CPython")
        w.add_info("sys_uuid", sys_uuid or f"{sysid:024x}")
        w.add_info("time_ref_utc", time.localtime(utc_start_us / 1e6).tm_gmtoff, "int32_t")
        write_parameters(w, fc.params)
        self.subs = {fmt.name: w.subscribe(fmt.name) for fmt in FORMATS}
        self._groups: dict[tuple[str, ...], SubscriptionGroup] = {}  # the topics a step writes together
        self._header = {name: sub.header for name, sub in self.subs.items()}  # each topic's message header
        self._due = [start_us] * 4  # fast, position, slow, status
        self._next_sync_us = start_us + SYNC_US
        self._last_us = start_us
        self._gps = None  # the GPS sample last logged
        self._status_key: tuple | None = None
        self._status_seen = None  # the commander's status record last looked at
        self._nav_state_us = start_us
        self._armed_us = 0
        self._takeoff_us = 0
        self._chunks: dict[int, list[str]] = {}  # STATUSTEXT id -> the chunks so far

    @property
    def path(self) -> Path:
        return self.writer.path

    def record(self, imu: ImuSample | None = None) -> None:
        """Log what is due after the step that just ran (``imu``: that step's raw sample, if known)."""
        now = self.fc.last_us or 0
        due = self._due
        if now < self._last_us:  # the simulated clock restarted (the simulator reconnected): schedules too
            due[:] = [now] * 4
            self._next_sync_us = now + SYNC_US
        self._last_us = now
        if now >= due[0]:
            due[0] = now + FAST_US - SLACK_US
            self._fast(now, imu)
        if now >= due[1]:
            due[1] = now + POSITION_US - SLACK_US
            self._position(now)
        if now >= due[2]:
            due[2] = now + SLOW_US - SLACK_US
            self._slow(now, imu)
        status = self.fc.commander.status
        if status is not self._status_seen or now >= due[3]:  # (the commander publishes a new record on a change)
            self._status(now, status)
        if now >= self._next_sync_us:
            self._next_sync_us = now + SYNC_US
            self.writer.sync()
            self.writer.flush()

    # -- topics ---------------------------------------------------------------------
    def _write(self, topics: tuple[str, ...], values: list) -> None:
        """One sample of each of ``topics`` (``values``: for each its message header, then its fields), packed
        together."""
        group = self._groups.get(topics)
        if group is None:
            group = self._groups[topics] = self.writer.group(*(self.subs[t] for t in topics))
        self.writer.write_group(group, *values)

    def _fast(self, now: int, imu: ImuSample | None) -> None:
        fc, h = self.fc, self._header
        est = fc.estimator
        topics: tuple[str, ...] = ("vehicle_attitude", "vehicle_angular_velocity")
        values = [*h["vehicle_attitude"], now, now, *est.q.tolist(), *_NO_RESET,
                  *h["vehicle_angular_velocity"], now, now, *est.rate_frd.tolist()]  # fmt: skip
        if imu is not None:
            dt = LOCKSTEP_DT_US  # each sample integrates one lockstep period
            topics += ("sensor_combined",)
            gyro, accel = imu.gyro_frd_rad_s.tolist(), imu.accel_frd_m_s2.tolist()
            values += (*h["sensor_combined"], now, *gyro, dt, 0, *accel, dt)
        if fc.setpoint is not None and fc.commander.status.armed:
            x, y, z = fc.thrust_vec.tolist()
            thrust = (0.0, 0.0, -math.hypot(x, y, z) / fc.max_thrust_n)
            if fc.rate_override is None:
                topics += ("vehicle_attitude_setpoint",)
                values += (*h["vehicle_attitude_setpoint"], now, *fc.q_sp.tolist(), *thrust)
            topics += ("vehicle_rates_setpoint",)
            values += (*h["vehicle_rates_setpoint"], now, *fc.rate_sp.tolist(), *thrust)
        self._write(topics, values)

    def _position(self, now: int) -> None:
        fc, h = self.fc, self._header
        status = fc.commander.status
        e = status.estimate
        topics: tuple[str, ...] = ("actuator_outputs", "actuator_motors")
        values: list = []
        if e is not None:
            ok = e.position_valid
            ref_ok = math.isfinite(e.origin_lat_deg)
            resets = e.reset_count & 0xFF
            topics = ("vehicle_local_position", *topics)
            values += (*h["vehicle_local_position"], now, e.timestamp_us, ok, e.height_valid, ok, e.height_valid,
                       *e.pos_ned_m.tolist(), *e.vel_ned_m_s.tolist(), *e.accel_ned_m_s2.tolist(), e.yaw_rad, resets,
                       resets, ref_ok, ref_ok, e.origin_lat_deg, e.origin_lon_deg, e.origin_alt_amsl_m)  # fmt: skip
        motors = fc.actuators.motor_outputs[:N_MOTORS]
        n = len(motors)
        values += (*h["actuator_outputs"], now, n, *motors, *((0.0,) * (N_OUTPUTS - n)),
                   *h["actuator_motors"], now, now, 0, *motors, *((math.nan,) * (N_MOTORS - n)))  # fmt: skip
        sp = fc.setpoint
        if sp is not None and status.armed:
            mt = fc.max_thrust_n
            x, y, z = fc.thrust_vec.tolist()
            thrust = (x / mt, y / mt, z / mt)
            missing = fc.actuators.throttle_frac - math.hypot(*thrust)  # unallocated: setpoint - delivered, z down
            topics += ("control_allocator_status",)
            values += (*h["control_allocator_status"], now, abs(missing) < THRUST_ACHIEVED, 0.0, 0.0, missing)
            if isinstance(sp, PositionSetpoint):
                pos, yaw = sp.pos_ned_m.tolist(), sp.yaw_rad
                acc_ff = sp.acc_ned_m_s2.tolist() if sp.acc_ned_m_s2 is not None else _NAN3
                pc = fc.position_control
                topics += ("trajectory_setpoint", "vehicle_local_position_setpoint")
                values += (*h["trajectory_setpoint"], now, *pos, *sp.vel_ned_m_s.tolist(), *acc_ff, *_NAN3, yaw,
                           math.nan, *h["vehicle_local_position_setpoint"], now, *pos, *pc.vel_sp.tolist(),
                           *pc.acc_sp.tolist(), *thrust, yaw, math.nan)  # fmt: skip
            else:  # attitude or body rates flown: no position, velocity or acceleration setpoint
                topics += ("vehicle_local_position_setpoint",)
                values += (*h["vehicle_local_position_setpoint"], now, *_NAN3, *_NAN3, *_NAN3, *thrust, math.nan,
                           math.nan)  # fmt: skip
        self._write(topics, values)
        self._landing(now)

    def _landing(self, now: int) -> None:
        """landing_target_pose while the target is estimated, precision_landing while a precision landing runs."""
        fc, w, s = self.fc, self.writer, self.subs
        lt = fc.landing_target
        e = lt.estimate
        phase = getattr(fc.commander.task, "phase", None)
        code = PRECLAND_PHASES.index(phase.value) + 1 if phase is not None and phase.value in PRECLAND_PHASES else 0
        valid = e is not None and e.valid
        if valid:
            rel, rel_v = e.rel_pos_ned_m.tolist(), e.rel_vel_ned_m_s.tolist()
            var = e.rel_pos_var_m2.tolist()
            est = fc.commander.status.estimate
            pos = est.pos_ned_m.tolist() if est is not None else _NAN3
            w.write(s["landing_target_pose"], now, bool(e.is_static), True, True, *rel, rel_v[0], rel_v[1], var[0],
                    var[1], est is not None, pos[0] + rel[0], pos[1] + rel[1], pos[2] + rel[2])  # fmt: skip
        if code or valid:
            tv = e.target_vel_ned_m_s.tolist() if valid and e.target_vel_ned_m_s is not None else _NAN3
            w.write(s["precision_landing"], now, code, lt.accepted, tv[0], tv[1])

    def _slow(self, now: int, imu: ImuSample | None) -> None:
        fc, w, s = self.fc, self.writer, self.subs
        status = fc.commander.status
        e = status.estimate
        if e is not None and e.position_valid:
            lat, lon, alt = ned_to_geodetic(e.pos_ned_m, e.origin_lat_deg, e.origin_lon_deg, e.origin_alt_amsl_m)
            w.write(s["vehicle_global_position"], now, e.timestamp_us, lat, lon, alt, True, e.height_valid)
        if imu is not None and math.isfinite(imu.pressure_hpa) and imu.pressure_hpa > 0:
            p_pa, temp_c = imu.pressure_hpa * 100.0, imu.temperature_c
            rho = p_pa / (R_AIR * (temp_c + 273.15)) if math.isfinite(temp_c) else math.nan
            w.write(s["vehicle_air_data"], now, now, pressure_to_altitude_m(imu.pressure_hpa), temp_c, p_pa, rho)
        b = status.battery
        if math.isfinite(b.voltage_v):  # a battery reading has arrived
            mah = b.consumed_mah if b.consumed_mah >= 0 else math.nan
            w.write(s["battery_status"], now, True, b.voltage_v, b.voltage_v, b.current_a, b.current_a, mah,
                    b.remaining_frac, b.cell_count, int(status.battery_warning))  # fmt: skip
        g = status.gps
        if g is not None and g is not self._gps:
            self._gps = g
            vn, ve, vd = g.vel_ned_m_s.tolist()
            utc = g.timestamp_us + self.utc_offset_us
            w.write(s["vehicle_gps_position"], now, g.timestamp_us, g.lat_deg, g.lon_deg, g.alt_amsl_m, g.fix_type,
                    g.eph_m, g.epv_m, math.hypot(vn, ve), vn, ve, vd, math.atan2(ve, vn), True, utc,
                    g.satellites)  # fmt: skip

    def _status(self, now: int, status) -> None:
        """vehicle_status and vehicle_land_detected every STATUS_US, and at once when one changes (``status``: the
        commander's, a record not looked at yet or the interval is over)."""
        self._status_seen = status
        fs = status.failsafe
        key = (status.armed, status.mode, status.in_air, status.ground_contact, fs.action_in_force)
        if key == self._status_key and now < self._due[3]:
            return
        if self._status_key is None or key[1] != self._status_key[1]:
            self._nav_state_us = now
        if status.armed and not self._armed_us:
            self._armed_us = now
        if status.in_air and not self._takeoff_us:
            self._takeoff_us = now
        self._status_key = key
        self._due[3] = now + STATUS_US - SLACK_US
        w, s = self.writer, self.subs
        arming = ARMING_STATE_ARMED if status.armed else ARMING_STATE_DISARMED
        w.write(s["vehicle_status"], now, self._armed_us, self._takeoff_us, self._nav_state_us, arming,
                NAV_STATE.get(status.mode.value, 4), VEHICLE_TYPE_ROTARY_WING, fs.action_in_force, status.mav_type,
                self.sysid, self.compid, fs.rc_lost, fs.gcs_lost)  # fmt: skip
        landed = not status.in_air
        w.write(s["vehicle_land_detected"], now, status.ground_contact, landed, landed)
        w.write(s["flight_mode"], now, *status.mode.value)

    # -- events ---------------------------------------------------------------------
    def statustext(self, now_us: int, payload: bytes) -> None:
        """A STATUSTEXT the vehicle sent (its MAVLink payload): a logged string at its severity, chunks
        joined (a chunk of 50 bytes with a non-zero id announces more)."""
        p = payload.ljust(54, b"\0")  # MAVLink 2 trims trailing zeros
        raw, text_id = p[1:51], p[51] | p[52] << 8
        text = raw.split(b"\0", 1)[0].decode("utf-8", "replace")
        if text_id:
            parts = self._chunks.setdefault(text_id, [])
            parts.append(text)
            if b"\0" not in raw and len(parts) < 64:  # a full chunk: more to come
                return
            text = "".join(self._chunks.pop(text_id))
        severity = min(p[0], 7)
        self.writer.log(severity, now_us, text)

    def parameter_changed(self, name: str, value: float) -> None:
        """A parameter's new value ('P' in the data section: pyulog stamps it with the latest data time)."""
        self.writer.add_parameter(name, value, self.fc.params.definition(name).ptype == ParamType.INT32)

    def flush(self) -> None:
        self.writer.flush()

    def close(self) -> None:
        self.writer.close()
