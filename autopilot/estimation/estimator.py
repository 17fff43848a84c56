"""The estimators the controllers fly on: the EKF, and the Mahony filter with a linear position filter.

Input: IMU samples (HIL_SENSOR: gyro, accelerometer, magnetometer, barometer) and
GPS fixes (HIL_GPS).  Output: :class:`autopilot.topics.VehicleEstimate` in
NED/FRD, and :class:`autopilot.topics.EstimatorStatus` for ground stations.

Both estimators run on every sample:

* ``SYS_MC_EST_GROUP = 2`` (default): the error-state EKF
  (:mod:`autopilot.estimation.ekf`) gives attitude, position and velocity;
* ``SYS_MC_EST_GROUP = 1``: the Mahony filter (:mod:`autopilot.estimation.mahony`)
  gives attitude and the linear filter (:mod:`autopilot.estimation.position_kf`)
  position and velocity -- PX4's attitude_estimator_q + local_position_estimator
  group.  The parameter acts at once (both are always up to date).

The local origin is set at the first good GPS fix (latitude, longitude, GPS
altitude); the barometer gives height relative to its reading at that moment.

Health, as PX4's EKF2 reports it: innovation test ratios of GPS position and
velocity, barometer height and magnetometer heading.  A GPS position that fails
its gate is rejected; if GPS velocity keeps passing while position is rejected
for ``GPS_RESET_S``, the position is reset to GPS (the jump is published as a reset
delta so the position setpoint moves with it and the vehicle does not).  A
magnetometer whose field strength is far from the World Magnetic Model's, whose
readings repeat exactly, or whose heading keeps failing its gate is declared
faulty and no longer fused.
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from mavsim_core import quaternion as quat
from autopilot.estimation.ekf import (
    P_BARO_GATE, P_BARO_NOISE, P_GPS_P_GATE, P_GPS_P_NOISE, P_GPS_V_GATE, P_GPS_V_NOISE, P_HDG_GATE, P_HEAD_NOISE,
    P_NOAID_NOISE, ErrorStateEkf, nearest_state,
)
from autopilot.estimation.mahony import MahonyFilter
from autopilot.estimation.position_kf import P_GPS_DELAY, PositionVelocityFilter
from mavsim_core.geodesy import geodetic_to_ned
from autopilot.parameters import ParamDef, ParameterStore, ParamType, param
from autopilot.topics import EstimatorStatus, GpsSample, ImuSample, VehicleEstimate
from mavsim_core.constants import GRAVITY_M_S2, LOCKSTEP_DT_S, MAGNETIC_MODEL_EPOCH_YEAR

_GRAVITY = np.array([0.0, 0.0, GRAVITY_M_S2])
ALIGN_TIME_S = 3.0  # attitude must have run this long before it is trusted
BARO_PERIOD_US = 20_000  # barometer fused (and the EKF predicted) at 50 Hz
POSITION_SETTLE_S = 3.0  # GPS must have been fused this long before position is trusted
MAX_H_STD_M = 0.5
MAX_V_STD_M = 0.5
MAX_TILT_STD_RAD = math.radians(1.5)  # the EKF's roll/pitch must be this certain to arm
MAX_YAW_STD_RAD = math.radians(5.0)
HEADING_PERIOD_US = 100_000  # magnetometer heading fused into the EKF at 10 Hz
STANDBY_EVERY = 5  # the estimator the controllers do not use runs every 5th 50 Hz step (10 Hz)
GPS_MIN_SATS = 6
GPS_TIMEOUT_US = 500_000
GPS_RESET_S = 7.0  # GPS position rejected this long (velocity passing): reset to GPS (PX4: 7 s)
FAKE_POS_PERIOD_US = 200_000  # constant-position fusion when nothing aids the filter
GROUND_FAKE_POS_NOISE_M = 0.5
GPS_ACCEL_TAU_S = 0.5  # low-pass of the GPS velocity derivative given to the Mahony filter
GPS_ACCEL_LAG_US = 100_000  # a derivative between two 5 Hz fixes describes the middle of the interval
MAG_FIELD_TOL = 0.35  # |B| more than this fraction from the model's strength: magnetometer fault
MAG_STUCK_SAMPLES = 50  # identical readings in a row (0.2 s at 250 Hz): magnetometer stuck
MAG_REJECT_FAULT_S = 2.0  # heading failing its gate this long: magnetometer fault
MAG_RECOVER_S = 5.0  # healthy this long: fused again

P_EST_GROUP = param("SYS_MC_EST_GROUP", 2, 1, 2, "",
                      "Estimator the controllers fly on: 1 = Mahony attitude + linear position filter, 2 = EKF",
                      ParamType.INT32)

# The parameters this module reads (listed in autopilot/param_catalogue.py).
PARAMS: tuple[ParamDef, ...] = (
    P_EST_GROUP,
)

# ESTIMATOR_STATUS_FLAGS (MAVLink common).
FLAG_ATTITUDE, FLAG_VEL_HORIZ, FLAG_VEL_VERT = 1, 2, 4
FLAG_POS_HORIZ_REL, FLAG_POS_HORIZ_ABS, FLAG_POS_VERT_ABS = 8, 16, 32
FLAG_CONST_POS_MODE, FLAG_GPS_GLITCH = 128, 1024


def _finite(v: np.ndarray) -> bool:
    """All three components finite (cheaper than np.all(np.isfinite(v)) on a 3-vector)."""
    return math.isfinite(float(v[0]) + float(v[1]) + float(v[2]))


def pressure_to_altitude_m(pressure_hpa: float) -> float:
    """ISA barometric altitude (m) from static pressure (hPa)."""
    return (1.0 - (pressure_hpa / 1013.25) ** (1.0 / 5.25588)) / 2.25577e-5


def heading_from_mag(roll: float, pitch: float, mag_frd: np.ndarray, declination_rad: float) -> float:
    """True heading (rad) from a magnetometer reading (any unit), tilt-compensated."""
    cr, sr, cp, sp = math.cos(roll), math.sin(roll), math.cos(pitch), math.sin(pitch)
    mx = mag_frd[0] * cp + mag_frd[1] * sr * sp + mag_frd[2] * cr * sp
    my = mag_frd[1] * cr - mag_frd[2] * sr
    return math.atan2(-my, mx) + declination_rad


class Estimator:
    def __init__(self, params: ParameterStore | None = None) -> None:
        self.params = params
        self.attitude = MahonyFilter()
        self.attitude.correct_every = 1  # fed once per 20 ms with the interval's mean rate and force
        self.position = PositionVelocityFilter()
        self.ekf = ErrorStateEkf()
        self.use_ekf = True
        self.rate_frd = np.zeros(3)
        self.accel_ned = np.zeros(3)
        self.last_imu_us: int | None = None
        self.last_gps_us: int | None = None
        self.first_gps_us: int | None = None
        self.origin: tuple[float, float, float] | None = None
        self.baro_offset_m = 0.0
        self.last_baro_alt_m: float | None = None
        self.r_ned_frd = np.eye(3)  # attitude of the selected estimator (FRD -> NED), refreshed each sample
        self.q = np.array([1.0, 0.0, 0.0, 0.0])
        # IMU increments since the filters last ran: delta angle (rad) and delta velocity (m/s), FRD.
        self._dth = np.zeros(3)
        self._dvel = np.zeros(3)
        self._acc_dt = 0.0
        # The same, summed for each estimator since it last ran: [delta angle, delta velocity, seconds].
        self._ekf_acc: list = [np.zeros(3), np.zeros(3), 0.0]
        self._comp_acc: list = [np.zeros(3), np.zeros(3), 0.0]
        self._comp_accel_ned = np.zeros(3)
        self._am_lp = np.zeros(3)  # low-passed accelerometer NED acceleration (Mahony attitude), m/s^2
        self._am_history: deque[tuple[int, np.ndarray]] = deque(maxlen=50)
        self._slow_count = 0
        self._last_heading_us = -HEADING_PERIOD_US
        self.gps_delay_us = int(P_GPS_DELAY.default * 1000)
        self.gps_accel_ned = np.zeros(3)
        self._gps_vels: deque[tuple[int, np.ndarray]] = deque(maxlen=2)
        self._history: deque[tuple[int, np.ndarray, np.ndarray]] = deque(maxlen=32)
        self._mag: np.ndarray | None = None
        # EKF health and aiding.
        self.declination_rad = 0.0
        self.mag_strength_gauss: float | None = None  # World Magnetic Model total intensity at the origin
        self.mag_fault = False
        self.mag_fault_reason = ""
        self._mag_repeat = 0
        self._mag_bad_since_us: int | None = None
        self._mag_good_since_us: int | None = None
        self.last_pos_fused_us: int | None = None
        self.pos_rejected_since_us: int | None = None
        self.gps_glitch = False
        self.reset_count = 0
        self.reset_delta_ned_m = np.zeros(3)  # the latest position reset's jump
        self._fake_pos: np.ndarray | None = None
        self._last_fake_us = 0
        self.events: list[tuple[str, str]] = []  # (severity name, text), drained by the flight controller
        self._in_air = False
        # Deferred mode (the flight controller's): the 50 Hz filter run and GPS fusion wait for
        # run_deferred(), which the flight controller calls after it has sent the motor commands,
        # so that work overlaps the simulator's physics step.  The output predictor carries the
        # attitude meanwhile; the correction reaches it one sample (4 ms) later.
        self.defer_filters = False
        self._deferred_filters: tuple[int, np.ndarray | None, float | None] | None = None
        self._deferred_gps: list[GpsSample] = []
        if params is not None:
            self._load_params()
            params.subscribe(lambda name, value: self._load_params()
                             if name.startswith(("EKF2_", "ATT_", "SYS_MC_EST")) else None)

    def _load_params(self) -> None:
        g = self.params.get
        self.use_ekf = int(g("SYS_MC_EST_GROUP")) == 2
        self.gps_delay_us = int(g("EKF2_GPS_DELAY") * 1000)
        e = self.ekf
        e.gyr_noise, e.acc_noise = g("EKF2_GYR_NOISE"), g("EKF2_ACC_NOISE")
        e.gyr_b_noise, e.acc_b_noise = g("EKF2_GYR_B_NOISE"), g("EKF2_ACC_B_NOISE")
        m = self.attitude
        m.kp, m.ki, m.k_mag = g("ATT_MAHONY_KP"), g("ATT_MAHONY_KI"), g("ATT_MAHONY_KMAG")
        lkf = self.position
        lkf.gps_p_noise, lkf.gps_v_noise = g("EKF2_GPS_P_NOISE"), g("EKF2_GPS_V_NOISE")
        lkf.baro_noise, lkf.gate = g("EKF2_BARO_NOISE"), g("EKF2_GPS_P_GATE")

    def _p(self, d) -> float:
        return d.default if self.params is None else self.params.get(d.name)

    def set_in_air(self, in_air: bool) -> None:
        """The commander's landed state: decides the noise of constant-position fusion."""
        self._in_air = in_air

    # -- inputs ---------------------------------------------------------------------
    def update_imu(self, s: ImuSample) -> None:
        """One IMU sample (250 Hz): carry the attitude forward; every 20 ms run the filters."""
        if self._deferred_filters is not None or self._deferred_gps:
            self.run_deferred()  # never skipped, and always before this sample's increments
        dt = LOCKSTEP_DT_S if self.last_imu_us is None else (s.timestamp_us - self.last_imu_us) * 1e-6
        self.last_imu_us = s.timestamp_us
        if not 0.0 < dt < 0.1 or not _finite(s.accel_frd_m_s2) or not _finite(s.gyro_frd_rad_s):
            return  # NaN never reaches the filters
        self._dth += s.gyro_frd_rad_s * dt
        self._dvel += s.accel_frd_m_s2 * dt
        self._acc_dt += dt
        # Output predictor: the selected filter's attitude carried forward by the bias-corrected gyro.
        bias = self.ekf.bg if self.use_ekf and self.ekf.initialised else self.attitude.gyro_bias
        self.rate_frd = rate = s.gyro_frd_rad_s - bias
        self.q = quat.integrate(self.q, rate, dt)
        if s.timestamp_us % BARO_PERIOD_US >= 4000:
            self.r_ned_frd = quat.to_matrix(self.q)
            return
        mag = s.mag_frd_gauss if _finite(s.mag_frd_gauss) else None
        baro = None
        if math.isfinite(s.pressure_hpa) and s.pressure_hpa > 0:
            self.last_baro_alt_m = pressure_to_altitude_m(s.pressure_hpa)
            if self.origin is not None:
                baro = -(self.last_baro_alt_m - self.baro_offset_m)
        if self.defer_filters:
            self._deferred_filters = (s.timestamp_us, mag, baro)
            self.r_ned_frd = quat.to_matrix(self.q)
            return
        self._filters(s.timestamp_us, mag, baro)
        self.r_ned_frd = quat.to_matrix(self.q)

    def run_deferred(self) -> None:
        """In deferred mode: the filter run and the GPS fusion the latest samples asked for, in order."""
        pending, self._deferred_filters = self._deferred_filters, None
        if pending is not None:
            self._filters(*pending)
            self.r_ned_frd = quat.to_matrix(self.q)
        gps, self._deferred_gps = self._deferred_gps, []
        for g in gps:
            self._fuse_gps(g)

    def _filters(self, now_us: int, mag: np.ndarray | None, baro_down_m: float | None) -> None:
        """Both estimators over the IMU data since they last ran, then their corrections.

        The selected estimator runs at 50 Hz; the other (kept ready and comparable) at
        10 Hz on the summed increments of 100 ms, which costs a fifth as much."""
        t = self._acc_dt
        if t <= 0.0:
            return
        self._slow_count += 1
        self._check_mag(now_us, mag)
        for group in (self._ekf_acc, self._comp_acc):
            group[0] += self._dth
            group[1] += self._dvel
            group[2] += t
        self._dth[:] = 0.0
        self._dvel[:] = 0.0
        self._acc_dt = 0.0
        standby_due = self._slow_count % STANDBY_EVERY == 0 or not self.ekf.initialised
        if self.use_ekf or standby_due:
            self._run_ekf(now_us, mag, baro_down_m)
        if not self.use_ekf or standby_due:
            self._run_complementary(now_us, mag, baro_down_m)
        if self.use_ekf and self.ekf.initialised:
            self.q = self.ekf.q.copy()
            self.accel_ned = self.ekf.accel_ned
        else:
            self.q = self.attitude.q.copy()
            self.accel_ned = self._comp_accel_ned

    def _run_complementary(self, now_us: int, mag: np.ndarray | None, baro_down_m: float | None) -> None:
        """Mahony on the interval's mean rate and specific force, then the linear position filter."""
        dth, dvel, t = self._comp_acc
        self._comp_acc = [np.zeros(3), np.zeros(3), 0.0]
        m = self.attitude
        m.update(dth / t, dvel / t, mag, t, self._mahony_reference(now_us, dvel / t, t))
        accel_ned = quat.to_matrix(m.q) @ (dvel / t) + _GRAVITY
        self.position.predict(accel_ned, t)
        self._comp_accel_ned = accel_ned - self.position.accel_bias_ned
        x = self.position.x
        self._history.append((now_us, x[:, 0].copy(), x[:, 1].copy()))
        if baro_down_m is not None:
            self.position.fuse_height(baro_down_m)

    def _mahony_reference(self, now_us: int, force_frd: np.ndarray, t: float) -> np.ndarray | None:
        """Kinematic acceleration (NED, m/s^2) for the Mahony filter's gravity correction.

        The accelerometer's own NED acceleration (with Mahony's attitude) minus its slow
        disagreement with GPS: both low-passed alike (GPS_ACCEL_TAU_S) and compared at the
        time the GPS velocities describe.  A tilt error makes the accelerometer's NED
        acceleration differ from GPS by g x error; that is what remains for the correction,
        while the vehicle's own accelerations cancel out."""
        a_m = quat.to_matrix(self.attitude.q) @ force_frd + _GRAVITY
        self._am_lp += t / (t + GPS_ACCEL_TAU_S) * (a_m - self._am_lp)
        self._am_history.append((now_us, self._am_lp.copy()))
        if self.last_gps_us is None or len(self._gps_vels) < 2:
            return None  # no GPS yet: at rest, gravity alone
        then = self.last_gps_us - self.gps_delay_us - GPS_ACCEL_LAG_US
        lp_then = min(self._am_history, key=lambda item: abs(item[0] - then))[1]
        return a_m - (lp_then - self.gps_accel_ned)

    def _run_ekf(self, now_us: int, mag: np.ndarray | None, baro_down_m: float | None) -> None:
        dth, dvel, t = self._ekf_acc
        self._ekf_acc = [np.zeros(3), np.zeros(3), 0.0]
        ekf = self.ekf
        if not ekf.initialised:
            if self.attitude.initialised:
                ekf.initialise(self.attitude.q)  # levelled from gravity and the magnetometer, as Mahony was
            return
        ekf.predict(dth, dvel, t, now_us)
        self._ekf_corrections(now_us, baro_down_m, mag)

    def _ekf_corrections(self, now_us: int, baro_down_m: float | None, mag: np.ndarray | None) -> None:
        """The EKF's 50 Hz corrections: barometer, heading, constant position when unaided."""
        ekf = self.ekf
        if baro_down_m is not None:
            ekf.fuse_state(2, baro_down_m - float(ekf.p[2]), self._p(P_BARO_NOISE) ** 2, self._p(P_BARO_GATE), "hgt")
        if mag is not None and not self.mag_fault and now_us - self._last_heading_us >= HEADING_PERIOD_US:
            self._last_heading_us = now_us
            r = ekf.r_ned_frd
            roll = math.atan2(r[2, 1], r[2, 2])
            pitch = -math.asin(max(-1.0, min(1.0, r[2, 0])))
            yaw = math.atan2(r[1, 0], r[0, 0])
            innov = quat.wrap_pi(heading_from_mag(roll, pitch, mag, self.declination_rad) - yaw)
            ok = ekf.fuse(ekf.heading_jacobian(), innov, self._p(P_HEAD_NOISE) ** 2, self._p(P_HDG_GATE), "mag")
            self._mag_gate_result(now_us, ok)
        aided = self.origin is not None and self.gps_ok(now_us)
        if aided:
            self._fake_pos = None
        elif now_us - self._last_fake_us >= FAKE_POS_PERIOD_US:
            # Nothing aids the filter: hold it to where it was (PX4's fake position fusion).
            self._last_fake_us = now_us
            if self._fake_pos is None:
                self._fake_pos = ekf.p.copy()
            noise = self._p(P_NOAID_NOISE) if self._in_air else GROUND_FAKE_POS_NOISE_M
            axes = 2 if self.origin is not None else 3  # the baro holds height once there is an origin
            for i in range(axes):
                ekf.fuse_state(i, float(self._fake_pos[i] - ekf.p[i]), noise * noise, 5.0)

    # -- magnetometer health ----------------------------------------------------------------
    def _check_mag(self, now_us: int, mag: np.ndarray | None) -> None:
        reason = ""
        if mag is None:
            reason = "no magnetometer data"
        else:
            if self._mag is not None and np.array_equal(mag, self._mag):
                self._mag_repeat += 1
            else:
                self._mag_repeat = 0
            self._mag = mag
            if self._mag_repeat >= MAG_STUCK_SAMPLES:
                reason = "magnetometer stuck (readings repeat)"
            elif self.mag_strength_gauss:
                strength = math.sqrt(float(mag @ mag))
                if abs(strength / self.mag_strength_gauss - 1.0) > MAG_FIELD_TOL:
                    reason = f"magnetometer field {strength:.2f} G, expected {self.mag_strength_gauss:.2f} G"
        if reason:
            self._mag_good_since_us = None
            if not self.mag_fault:
                self._declare_mag_fault(reason)
        elif self.mag_fault and self._mag_bad_since_us is None:
            if self._mag_good_since_us is None:
                self._mag_good_since_us = now_us
            elif now_us - self._mag_good_since_us >= MAG_RECOVER_S * 1e6:
                self.mag_fault, self.mag_fault_reason = False, ""
                self.events.append(("INFO", "EKF: magnetometer healthy again, heading fusion resumed"))

    def _mag_gate_result(self, now_us: int, ok: bool) -> None:
        if ok:
            self._mag_bad_since_us = None
            return
        if self._mag_bad_since_us is None:
            self._mag_bad_since_us = now_us
        elif now_us - self._mag_bad_since_us >= MAG_REJECT_FAULT_S * 1e6:
            self._declare_mag_fault("heading inconsistent with the gyros")
            self._mag_bad_since_us = None

    def _declare_mag_fault(self, reason: str) -> None:
        self.mag_fault, self.mag_fault_reason = True, reason
        self._mag_good_since_us = None
        self.events.append(("WARNING", f"EKF: {reason}: heading fusion stopped"))

    # -- GPS ------------------------------------------------------------------------------
    def _estimate_at(self, time_us: int) -> tuple[np.ndarray, np.ndarray] | tuple[None, None]:
        """The linear filter's position and velocity nearest to an earlier time."""
        return nearest_state(self._history, time_us)

    def update_gps(self, g: GpsSample) -> None:
        """A GPS fix: fused now, or (deferred mode) by the next run_deferred()."""
        if self.defer_filters:
            self._deferred_gps.append(g)
        else:
            self._fuse_gps(g)

    def _fuse_gps(self, g: GpsSample) -> None:
        if g.fix_type < 3 or g.satellites < GPS_MIN_SATS:
            return
        self.last_gps_us = g.timestamp_us
        vel = np.asarray(g.vel_ned_m_s, dtype=float)
        self._update_gps_accel(g.timestamp_us, vel)
        if self.origin is None:
            if self.last_baro_alt_m is None or not self.ekf.initialised or not self.attitude.initialised:
                return
            self.origin = (g.lat_deg, g.lon_deg, g.alt_amsl_m)
            self.baro_offset_m = self.last_baro_alt_m
            self.first_gps_us = g.timestamp_us
            self.position.reset(np.zeros(3), vel)
            self.ekf.reset_position(np.zeros(3), self._p(P_GPS_P_NOISE) ** 2)
            self.ekf.reset_velocity(vel, self._p(P_GPS_V_NOISE) ** 2)
            self.last_pos_fused_us = g.timestamp_us
            self._set_declination(g.lat_deg, g.lon_deg, g.alt_amsl_m)
            return
        pos = geodetic_to_ned(g.lat_deg, g.lon_deg, g.alt_amsl_m, *self.origin)
        then_us = g.timestamp_us - self.gps_delay_us
        pos_then, vel_then = self._estimate_at(then_us)
        self.position.fuse_gps(pos, vel, pos_then, vel_then)
        self._ekf_gps(g, pos, vel, then_us)

    def _ekf_gps(self, g: GpsSample, pos: np.ndarray, vel: np.ndarray, then_us: int) -> None:
        ekf = self.ekf
        pos_then, vel_then = ekf.state_at(then_us)
        if pos_then is None:
            pos_then, vel_then = ekf.p, ekf.v
        vn = max(self._p(P_GPS_V_NOISE), 0.0)
        ekf.fuse_vector(3, vel, vel_then, vn * vn, self._p(P_GPS_V_GATE), "vel")
        pn = max(self._p(P_GPS_P_NOISE), g.eph_m if math.isfinite(g.eph_m) else 0.0)
        rejected = ekf.fuse_vector(0, pos[:2], pos_then[:2], pn * pn, self._p(P_GPS_P_GATE), "pos")
        now = g.timestamp_us
        if rejected == 0:
            self.last_pos_fused_us = now
            self.pos_rejected_since_us = None
            if self.gps_glitch:
                self.gps_glitch = False
                self.events.append(("INFO", "EKF: GPS position consistent again"))
            return
        if self.pos_rejected_since_us is None:
            self.pos_rejected_since_us = now
        if not self.gps_glitch:
            self.gps_glitch = True
            jump = math.hypot(*(pos[:2] - pos_then[:2]))
            self.events.append(("WARNING", f"EKF: GPS position rejected ({jump:.1f} m from the estimate)"))
        if now - self.pos_rejected_since_us >= GPS_RESET_S * 1e6 and ekf.ratio["vel"] <= 1.0:
            # GPS has disagreed for long while its velocity agrees: believe it (a persistent glitch).
            target = ekf.p.copy()
            target[:2] += pos[:2] - pos_then[:2]
            delta = ekf.reset_position(target, pn * pn, slice(0, 2))
            self.position.x[:2, 0] += delta[:2]
            for _, p, _ in self._history:
                p[:2] += delta[:2]
            self.reset_count += 1
            self.reset_delta_ned_m = delta
            self.pos_rejected_since_us = None
            self.last_pos_fused_us = now
            self.gps_glitch = False
            self.events.append(("WARNING", f"EKF: position reset to GPS ({math.hypot(delta[0], delta[1]):.1f} m)"))

    def _update_gps_accel(self, time_us: int, vel_ned: np.ndarray) -> None:
        """Low-pass (GPS_ACCEL_TAU_S) the derivative of GPS velocity between fixes."""
        if not _finite(vel_ned):
            return
        last = self._gps_vels[-1] if self._gps_vels else None
        self._gps_vels.append((time_us, vel_ned))
        if last is None:
            return
        dt = (time_us - last[0]) * 1e-6
        if 0.0 < dt < 1.0:
            accel = (vel_ned - last[1]) / dt
            self.gps_accel_ned += dt / (dt + GPS_ACCEL_TAU_S) * (accel - self.gps_accel_ned)
        else:
            self.gps_accel_ned[:] = 0.0

    def _set_declination(self, lat: float, lon: float, alt: float) -> None:
        """Magnetic declination and field strength at the origin, from the World Magnetic Model."""
        from pygeomag import GeoMag

        res = GeoMag().calculate(glat=lat, glon=lon, alt=alt / 1000.0, time=MAGNETIC_MODEL_EPOCH_YEAR)
        self.declination_rad = d = math.radians(res.d)
        self.mag_strength_gauss = res.f / 1e5  # nT -> gauss
        self.attitude.declination_rad = d
        # Re-align the heading now that declination is known.
        roll, pitch, yaw = quat.to_euler(self.attitude.q)
        self.attitude.q = quat.from_euler(roll, pitch, yaw + d)
        self.ekf.rotate_yaw(d)

    # -- output ---------------------------------------------------------------------
    def gps_ok(self, now_us: int) -> bool:
        return self.last_gps_us is not None and now_us - self.last_gps_us < GPS_TIMEOUT_US

    def _ekf_position_ok(self, now: int) -> bool:
        e = self.ekf
        return (self.origin is not None and self.last_pos_fused_us is not None
                and now - self.last_pos_fused_us < GPS_RESET_S * 1e6 and self.gps_ok(now)
                and e.horizontal_pos_std_m() < MAX_H_STD_M and e.vertical_pos_std_m() < MAX_V_STD_M)

    def estimate(self) -> VehicleEstimate:
        now = self.last_imu_us if self.last_imu_us is not None else 0
        settled = self.first_gps_us is not None and now - self.first_gps_us >= POSITION_SETTLE_S * 1e6
        if self.use_ekf:
            e = self.ekf
            q, pos, vel = e.q, e.p.copy(), e.v.copy()
            att_ok = e.initialised and e.time_aligned_s >= ALIGN_TIME_S and e.tilt_std_rad() < 5 * MAX_TILT_STD_RAD
            pos_ok = settled and self._ekf_position_ok(now)
        else:
            q, pos, vel = self.attitude.q, self.position.pos_ned_m, self.position.vel_ned_m_s
            att_ok = self.attitude.initialised and self.attitude.time_aligned_s >= ALIGN_TIME_S
            pos_ok = (settled and self.gps_ok(now) and self.position.horizontal_std_m() < MAX_H_STD_M
                      and self.position.vertical_std_m() < MAX_V_STD_M)
        roll, pitch, yaw = quat.to_euler(q)
        o = self.origin or (math.nan, math.nan, math.nan)
        return VehicleEstimate(
            timestamp_us=now, q_wxyz=q.copy(), rate_frd_rad_s=self.rate_frd.copy(),
            accel_ned_m_s2=self.accel_ned.copy(), pos_ned_m=pos, vel_ned_m_s=vel,
            attitude_valid=att_ok, position_valid=pos_ok, height_valid=self.origin is not None,
            origin_lat_deg=o[0], origin_lon_deg=o[1], origin_alt_amsl_m=o[2],
            roll_rad=roll, pitch_rad=pitch, yaw_rad=yaw, reset_count=self.reset_count,
            reset_delta_ned_m=self.reset_delta_ned_m.copy(),
        )

    def status(self) -> EstimatorStatus:
        """The EKF's health, for ESTIMATOR_STATUS and SYS_STATUS."""
        e = self.ekf
        now = self.last_imu_us or 0
        flags = 0
        if e.initialised and e.time_aligned_s >= ALIGN_TIME_S:
            flags |= FLAG_ATTITUDE
        pos_ok = self._ekf_position_ok(now)
        if pos_ok:
            flags |= FLAG_VEL_HORIZ | FLAG_VEL_VERT | FLAG_POS_HORIZ_REL | FLAG_POS_HORIZ_ABS
        if self.origin is not None:
            flags |= FLAG_POS_VERT_ABS
        if self._fake_pos is not None:
            flags |= FLAG_CONST_POS_MODE
        if self.gps_glitch:
            flags |= FLAG_GPS_GLITCH
        r = e.ratio
        return EstimatorStatus(
            timestamp_us=now, flags=flags, vel_ratio=r["vel"], pos_horiz_ratio=r["pos"], pos_vert_ratio=r["hgt"],
            mag_ratio=r["mag"], pos_horiz_accuracy_m=e.horizontal_pos_std_m(), pos_vert_accuracy_m=e.vertical_pos_std_m(),
            tilt_std_rad=e.tilt_std_rad(), yaw_std_rad=e.yaw_std_rad(), mag_fault=self.mag_fault,
            gps_glitch=self.gps_glitch, position_ok=pos_ok,
        )

    def prearm_failures(self) -> list[str]:
        """Why the EKF is not yet fit to fly on (empty when converged and consistent)."""
        e = self.ekf
        out = []
        if not e.initialised or e.time_aligned_s < ALIGN_TIME_S:
            return ["EKF attitude not aligned"]
        if e.tilt_std_rad() > MAX_TILT_STD_RAD:
            out.append(f"EKF not converged (tilt uncertainty {math.degrees(e.tilt_std_rad()):.1f} deg)")
        if not self.mag_fault and e.yaw_std_rad() > MAX_YAW_STD_RAD:
            out.append(f"EKF not converged (heading uncertainty {math.degrees(e.yaw_std_rad()):.1f} deg)")
        if self.mag_fault:
            out.append(f"EKF: {self.mag_fault_reason}")
        for kind, label in (("pos", "GPS position"), ("vel", "GPS velocity"), ("hgt", "height"), ("mag", "heading")):
            if e.ratio[kind] > 1.0:
                out.append(f"EKF {label} inconsistent (test ratio {e.ratio[kind]:.1f})")
        return out
