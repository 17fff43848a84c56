"""The estimators the controllers fly on: filter selection, the 50 Hz filter runs and the output predictor.

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

The selected filter runs at 50 Hz on the IMU increments summed since its last run, the
other at 10 Hz; in between, the output predictor carries the selected filter's attitude
forward on the bias-corrected gyro at 250 Hz.  In deferred mode (the flight controller's)
the 50 Hz run and GPS fusion wait for :meth:`Estimator.run_deferred`.  Also here: the
barometer's height (relative to its reading at the origin), the EKF's magnetometer fusion (10 Hz) and
its constant-position fusion when nothing aids it.  Beside this module:
:mod:`autopilot.estimation.gps_fusion` (origin, delayed fusion, glitch rejection, reset),
:mod:`autopilot.estimation.mag_health` (stuck, field strength, inconsistent heading),
:mod:`autopilot.estimation.sensor_checks` (accelerometer, gyro, barometer: no data, stale data; a
failed barometer is not fused, a failed accelerometer or gyro makes the attitude invalid),
:mod:`autopilot.estimation.height_sources` (the barometer against the GPS height; the GPS height
flown on while the barometer is failed) and
:mod:`autopilot.estimation.estimator_outputs` (the estimate, status flags and pre-arm failures
published from the filters' state).
"""

from __future__ import annotations

import math
from collections import deque

import numpy as np

from autopilot.estimation.attitude_matrix import LazyAttitudeMatrix
from autopilot.estimation.ekf import P_BARO_GATE, P_BARO_NOISE, P_HDG_GATE, P_HEAD_NOISE, P_NOAID_NOISE, ErrorStateEkf
from autopilot.estimation.estimator_outputs import ekf_prearm_failures, estimator_status, vehicle_estimate
from autopilot.estimation.gps_fusion import GPS_ACCEL_TAU_S, GpsFusion, finite3
from autopilot.estimation.height_sources import GpsHeight, HeightSources
from autopilot.estimation.imu_increments import ImuIncrements
from autopilot.estimation.mag_fusion import MAG_TYPE_AUTO, P_MAG_GATE, P_MAG_NOISE, fuse_mag_vector
from autopilot.estimation.mag_health import MagHealth, heading_from_mag, magnetic_field, magnetic_field_ned
from autopilot.estimation.mahony import MahonyFilter
from autopilot.estimation.position_kf import PositionVelocityFilter
from autopilot.estimation.sensor_checks import BARO, SensorChecks
from autopilot.parameters import ParamDef, ParameterStore, ParamType, param
from autopilot.topics import EstimatorStatus, GpsSample, ImuSample, VehicleEstimate
from mavsim_core import quaternion as quat
from mavsim_core.constants import GRAVITY_M_S2, LOCKSTEP_DT_S
from mavsim_core.floats import floats3
from mavsim_core.geodesy import geodetic_to_ned

_GRAVITY = np.array([0.0, 0.0, GRAVITY_M_S2])
BARO_PERIOD_US = 20_000  # barometer fused (and the EKF predicted) at 50 Hz
HEADING_PERIOD_US = 100_000  # magnetometer heading fused into the EKF at 10 Hz
MAG_PERIOD_US = 100_000  # three-axis magnetometer fusion (EKF2_MAG_TYPE 0), as the heading's
STANDBY_EVERY = 5  # the estimator the controllers do not use runs every 5th 50 Hz step (10 Hz)
FAKE_POS_PERIOD_US = 200_000  # constant-position fusion when nothing aids the filter
GROUND_FAKE_POS_NOISE_M = 0.5
GPS_ACCEL_LAG_US = 100_000  # a derivative between two 5 Hz fixes describes the middle of the interval

P_EST_GROUP = param(
    "SYS_MC_EST_GROUP",
    2,
    1,
    2,
    "",
    "Estimator the controllers fly on: 1 = Mahony attitude + linear position filter, 2 = EKF",
    ParamType.INT32,
)

# The parameters this module reads (listed in autopilot/param_catalogue.py).
PARAMS: tuple[ParamDef, ...] = (P_EST_GROUP,)


def pressure_to_altitude_m(pressure_hpa: float) -> float:
    """ISA barometric altitude (m) from static pressure (hPa)."""
    return (1.0 - (pressure_hpa / 1013.25) ** (1.0 / 5.25588)) / 2.25577e-5


class Estimator(LazyAttitudeMatrix):
    def __init__(self, params: ParameterStore | None = None) -> None:
        self.params = params
        self.attitude = MahonyFilter()
        self.attitude.correct_every = 1  # fed once per 20 ms with the interval's mean rate and force
        self.position = PositionVelocityFilter()
        self.ekf = ErrorStateEkf()
        self.use_ekf = True
        self._mag_type = MAG_TYPE_AUTO
        self.events: list[tuple[str, str]] = []  # (severity name, text), drained by the flight controller
        self.gps = GpsFusion(self.ekf, self.position, self.events, self._p)
        self.mag = MagHealth(self.events)
        self.sensor_checks = SensorChecks(self.events)
        self.heights = HeightSources(self.events, self._p)  # barometer vs GPS height, the GPS fallback
        self.rate_frd = np.zeros(3)
        self.accel_ned = np.zeros(3)
        self._r_ned_frd: np.ndarray | None = None  # to_matrix(q), made when first asked for (r_ned_frd)
        self.last_imu_us: int | None = None
        # A sample stamped t holds over [t, t + dt] (the simulator steps on from it), so the filter's state
        # after summing it describes t + dt: its history is stamped so, for fusion at the GPS's true delay.
        self._sample_dt_us = int(LOCKSTEP_DT_S * 1e6)
        self.last_baro_alt_m: float | None = None
        self.q = np.array([1.0, 0.0, 0.0, 0.0])  # attitude of the selected estimator (FRD -> NED)
        self._inc = ImuIncrements()  # since the filters last ran
        self._ekf_acc, self._comp_acc = ImuIncrements(), ImuIncrements()  # the same, per estimator since it ran
        self._comp_accel_ned = np.zeros(3)
        self._am_lp = np.zeros(3)  # low-passed accelerometer NED acceleration (Mahony attitude), m/s^2
        self._am_history: deque[tuple[int, np.ndarray]] = deque(maxlen=50)
        self._slow_count = 0
        self._last_mag_us = -HEADING_PERIOD_US
        self.declination_rad = 0.0
        self._fake_pos: np.ndarray | None = None
        self._last_fake_us = 0
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
            params.subscribe(
                lambda name, value: self._load_params() if name.startswith(("EKF2_", "ATT_", "SYS_MC_EST")) else None
            )

    def restart(self) -> None:
        """Start again as at power-on (a reboot), keeping the parameter store, its one subscription and the
        deferred mode."""
        params, defer = self.params, self.defer_filters
        Estimator.__init__(self, None)  # fresh state, no second subscription
        self.params, self.defer_filters = params, defer
        if params is not None:
            self._load_params()

    def _load_params(self) -> None:
        assert self.params is not None
        g = self.params.get
        self.use_ekf = int(g("SYS_MC_EST_GROUP")) == 2
        self._mag_type = int(g("EKF2_MAG_TYPE"))
        self.gps.delay_us = int(g("EKF2_GPS_DELAY") * 1000)
        e = self.ekf
        e.gyr_noise, e.acc_noise = g("EKF2_GYR_NOISE"), g("EKF2_ACC_NOISE")
        e.gyr_b_noise, e.acc_b_noise = g("EKF2_GYR_B_NOISE"), g("EKF2_ACC_B_NOISE")
        m = self.attitude
        m.kp, m.ki, m.k_mag = g("ATT_MAHONY_KP"), g("ATT_MAHONY_KI"), g("ATT_MAHONY_KMAG")
        lkf = self.position
        lkf.gps_p_noise, lkf.gps_v_noise = g("EKF2_GPS_P_NOISE"), g("EKF2_GPS_V_NOISE")
        lkf.baro_noise, lkf.gate = g("EKF2_BARO_NOISE"), g("EKF2_GPS_P_GATE")

    def _p(self, d: ParamDef) -> float:
        return d.default if self.params is None else self.params.get(d.name)

    # Magnetometer health, as earlier versions of this class had it.
    @property
    def mag_fault(self) -> bool:
        return self.mag.fault

    @property
    def mag_fault_reason(self) -> str:
        return self.mag.fault_reason

    @property
    def _mag(self) -> np.ndarray | None:
        return self.mag.last

    @property
    def const_pos_mode(self) -> bool:
        """Nothing aids the EKF: it is being held to where it was (constant-position fusion)."""
        return self._fake_pos is not None

    def set_in_air(self, in_air: bool) -> None:
        """The commander's landed state: decides the noise of constant-position fusion."""
        self._in_air = in_air

    # -- inputs ---------------------------------------------------------------------
    def update_imu(self, s: ImuSample) -> None:
        """One IMU sample (250 Hz): carry the attitude forward; every 20 ms run the filters.

        Plain floats on this per-sample path (the NumPy calls on 3-vectors cost more than their arithmetic)."""
        if self._deferred_filters is not None or self._deferred_gps:
            self.run_deferred()  # never skipped, and always before this sample's increments
        now = s.timestamp_us
        filter_due = now % BARO_PERIOD_US < 4000
        if filter_due:
            self.sensor_checks.update(s)  # at 50 Hz: data stopped or stale
        dt = LOCKSTEP_DT_S if self.last_imu_us is None else (now - self.last_imu_us) * 1e-6
        self.last_imu_us = now
        if not 0.0 < dt < 0.1:
            return  # NaN never reaches the filters
        self._sample_dt_us = int(dt * 1e6)
        acc, gyro = s.accel_frd_m_s2, s.gyro_frd_rad_s
        ax, ay, az = floats3(acc)
        gx, gy, gz = floats3(gyro)
        if not math.isfinite(ax + ay + az) or not math.isfinite(gx + gy + gz):
            return
        self._inc.add_sample(gx, gy, gz, ax, ay, az, dt)
        # Output predictor: the selected filter's attitude carried forward by the bias-corrected gyro.
        bias = self.ekf.bg if self.use_ekf and self.ekf.initialised else self.attitude.gyro_bias
        bx, by, bz = bias.tolist()
        rx, ry, rz = gx - bx, gy - by, gz - bz
        self.rate_frd = np.array((rx, ry, rz))
        qw, qx, qy, qz = self._q.tolist()
        self._q = np.array(quat.integrate_floats(qw, qx, qy, qz, rx, ry, rz, dt))
        self._r_ned_frd = None  # (the q setter's work, inline)
        if not filter_due:
            return
        self._filter_sample(s)

    def _filter_sample(self, s: ImuSample) -> None:
        """The 50 Hz part of :meth:`update_imu`: the barometer's height, then the filters (now or deferred)."""
        mag = s.mag_frd_gauss if finite3(s.mag_frd_gauss) else None
        baro = None
        if math.isfinite(s.pressure_hpa) and s.pressure_hpa > 0 and self.sensor_checks.ok(BARO):
            self.last_baro_alt_m = pressure_to_altitude_m(s.pressure_hpa)
            if self.gps.origin is not None:
                baro = -(self.last_baro_alt_m - self.gps.baro_offset_m)
                self.heights.on_baro(s.timestamp_us, baro)
                baro = baro if self.heights.baro_ok else None  # inconsistent with the GPS height: not fused
        if self.defer_filters:
            self._deferred_filters = (s.timestamp_us, mag, baro)
            return
        self._filters(s.timestamp_us, mag, baro)

    def update_gps(self, g: GpsSample) -> None:
        """A GPS fix: fused now, or (deferred mode) by the next run_deferred()."""
        if self.defer_filters:
            self._deferred_gps.append(g)
        else:
            self._fuse_gps(g)

    def run_deferred(self) -> None:
        """In deferred mode: the filter run and the GPS fusion the latest samples asked for, in order."""
        pending, self._deferred_filters = self._deferred_filters, None
        if pending is not None:
            self._filters(*pending)
        gps, self._deferred_gps = self._deferred_gps, []
        for g in gps:
            self._fuse_gps(g)

    # -- the filters ----------------------------------------------------------------
    def _filters(self, now_us: int, mag: np.ndarray | None, baro_down_m: float | None) -> None:
        """Both estimators over the IMU data since they last ran, then their corrections.

        The selected estimator runs at 50 Hz; the other (kept ready and comparable) at
        10 Hz on the summed increments of 100 ms, which costs a fifth as much."""
        if self._inc.t <= 0.0:
            return
        self._slow_count += 1
        self.mag.check(now_us, mag)
        inc = self._inc.take()
        self._ekf_acc.add(*inc)
        self._comp_acc.add(*inc)
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
        dth_list, dvel_list, t = self._comp_acc.take()
        dth, dvel = np.array(dth_list), np.array(dvel_list)
        m = self.attitude
        m.update(dth / t, dvel / t, mag, t, self._mahony_reference(now_us, dvel / t, t))
        accel_ned = quat.to_matrix(m.q) @ (dvel / t) + _GRAVITY
        self.position.predict(accel_ned, t)
        self._comp_accel_ned = accel_ned - self.position.accel_bias_ned
        x = self.position.x
        self.gps.history.append((now_us, x[:, 0].copy(), x[:, 1].copy()))
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
        gps = self.gps
        if gps.last_us is None or gps.velocities_known() < 2:
            return None  # no GPS yet: at rest, gravity alone
        then = gps.last_us - gps.delay_us - GPS_ACCEL_LAG_US
        lp_then = min(self._am_history, key=lambda item: abs(item[0] - then))[1]
        return a_m - (lp_then - gps.accel_ned)

    def _run_ekf(self, now_us: int, mag: np.ndarray | None, baro_down_m: float | None) -> None:
        dth, dvel, t = self._ekf_acc.take()
        ekf = self.ekf
        if not ekf.initialised:
            if self.attitude.initialised:
                ekf.initialise(self.attitude.q)  # levelled from gravity and the magnetometer, as Mahony was
            return
        ekf.predict(dth, dvel, t, now_us + self._sample_dt_us)
        self._ekf_corrections(now_us, baro_down_m, mag)

    def _ekf_corrections(self, now_us: int, baro_down_m: float | None, mag: np.ndarray | None) -> None:
        """The EKF's 50 Hz corrections: barometer, heading, constant position when unaided."""
        ekf = self.ekf
        if baro_down_m is not None:
            ekf.fuse_state(2, baro_down_m - float(ekf.p[2]), self._p(P_BARO_NOISE) ** 2, self._p(P_BARO_GATE), "hgt")
        if mag is not None and not self.mag.fault:
            self._fuse_mag(now_us, mag)
        aided = self.gps.origin is not None and self.gps.ok(now_us)
        if aided:
            self._fake_pos = None
        elif now_us - self._last_fake_us >= FAKE_POS_PERIOD_US:
            # Nothing aids the filter: hold it to where it was (PX4's fake position fusion).
            self._last_fake_us = now_us
            if self._fake_pos is None:
                self._fake_pos = ekf.p.copy()
            noise = self._p(P_NOAID_NOISE) if self._in_air else GROUND_FAKE_POS_NOISE_M
            axes = 2 if self.gps.origin is not None else 3  # the baro holds height once there is an origin
            for i in range(axes):
                ekf.fuse_state(i, float(self._fake_pos[i] - ekf.p[i]), noise * noise, 5.0)

    def _fuse_mag(self, now_us: int, mag: np.ndarray) -> None:
        """The magnetometer: all three axes against the model's field (EKF2_MAG_TYPE 0, once the origin and
        so the field are known), else the heading alone; each at 10 Hz (MAG_PERIOD_US, HEADING_PERIOD_US)."""
        ekf, field = self.ekf, self.mag.field_ned_gauss
        if field is not None and self._mag_type == MAG_TYPE_AUTO:
            if now_us - self._last_mag_us < MAG_PERIOD_US:
                return
            self._last_mag_us = now_us
            since = self.rate_frd * (self._sample_dt_us * 1e-6)
            ok = fuse_mag_vector(ekf, mag, field, self._p(P_MAG_NOISE), self._p(P_MAG_GATE), since)
            self.mag.gate_result(now_us, ok)
            return
        if now_us - self._last_mag_us < HEADING_PERIOD_US:
            return
        self._last_mag_us = now_us
        r = ekf.r_ned_frd
        roll = math.atan2(r[2, 1], r[2, 2])
        pitch = -math.asin(max(-1.0, min(1.0, r[2, 0])))
        yaw = math.atan2(r[1, 0], r[0, 0])
        innov = quat.wrap_pi(heading_from_mag(roll, pitch, mag, self.declination_rad) - yaw)
        ok = ekf.fuse(ekf.heading_jacobian(), innov, self._p(P_HEAD_NOISE) ** 2, self._p(P_HDG_GATE), "mag")
        self.mag.gate_result(now_us, ok)

    def _fuse_gps(self, g: GpsSample) -> None:
        if not self.gps.fuse(g, self.last_baro_alt_m, self.ekf.initialised and self.attitude.initialised):
            if self.gps.origin is not None and self.gps.last_us == g.timestamp_us:  # a good fix: the heights
                down = float(geodetic_to_ned(g.lat_deg, g.lon_deg, g.alt_amsl_m, *self.gps.origin)[2])
                fix = GpsHeight(g.timestamp_us - self.gps.delay_us, down, float(g.vel_ned_m_s[2]), g.epv_m)
                lkf = (self.position, self.gps.history)
                self.heights.on_gps(fix, self.sensor_checks.ok(BARO), self.ekf, lkf)
            return
        # This fix set the origin: magnetic declination and field strength there (World Magnetic
        # Model), and the heading re-aligned now that declination is known.
        d, self.mag.strength_gauss = magnetic_field(g.lat_deg, g.lon_deg, g.alt_amsl_m)
        self.mag.field_ned_gauss = magnetic_field_ned(g.lat_deg, g.lon_deg, g.alt_amsl_m)
        self.declination_rad = self.attitude.declination_rad = d
        roll, pitch, yaw = quat.to_euler(self.attitude.q)
        self.attitude.q = quat.from_euler(roll, pitch, yaw + d)
        self.ekf.rotate_yaw(d)

    # -- output (autopilot.estimation.estimator_outputs) ---------------------------------
    def gps_ok(self, now_us: int) -> bool:
        """GPS fixes are arriving and usable at ``now_us`` (simulated µs)."""
        return self.gps.ok(now_us)

    def estimate(self) -> VehicleEstimate:
        """The selected estimator's state (NED m, m/s; FRD -> NED attitude) and validity, now."""
        return vehicle_estimate(self)

    def status(self) -> EstimatorStatus:
        """The EKF's health, for ESTIMATOR_STATUS and SYS_STATUS."""
        return estimator_status(self)

    def prearm_failures(self) -> list[str]:
        """Why the EKF is not yet fit to fly on (empty when converged and consistent)."""
        return ekf_prearm_failures(self)
