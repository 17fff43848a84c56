"""One control iteration per IMU sample: estimate -> commander -> cascade -> mixer.

Pure: no sockets, no clock.  :meth:`FlightController.step` takes the sensor
samples of one lockstep period and returns motor commands 0..1 (estimator and
the 250 Hz attitude and rate loops); :meth:`FlightController.after_step` runs the
estimator's 50 Hz filter work and GPS fusion (its output predictor carries the
attitude in between) and the 50 Hz outer loops (commander, navigator, position
control), whose results the inner loops use from the next period on.  The process loop
(``autopilot.lockstep_loop``) calls ``after_step`` after sending the motor commands,
so that work overlaps the simulator's physics step instead of delaying it.

The parts exchange frozen records (:mod:`autopilot.topics`), not attribute writes: the
flight controller publishes ``actuators`` (:class:`ActuatorStatus`) after every step and
hands the estimate, its own outputs and the estimator's pre-arm failures to
:meth:`Commander.update`; the commander publishes ``commander.status``
(:class:`CommanderStatus`), which the loops here, the flight log and the telemetry read.

Sensor time must go on: a sample not later than the previous one, or more than MAX_SENSOR_GAP_US later,
comes from another world (a restarted simulator), so the estimator, the controllers and the commander
start again as at a reboot and an armed vehicle is disarmed (no flight on state that cannot be trusted).
The process loop reports a lost simulator link (:meth:`on_sim_link_lost`, HEARTBEAT MAV_STATE_CRITICAL
while it lasts).  Home is set automatically only while the vehicle is at rest (:mod:`autopilot.estimation.
rest_detector`); moving while disarmed before that (a restart in the air: the vehicle falls) is reported.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from pymavlink.dialects.v20 import common as S

from autopilot.commander import Commander
from autopilot.commander.external_inputs import ExternalInputs
from autopilot.control.attitude_control import with_yaw_rate
from autopilot.control.gains_from_params import GainsFromParams
from autopilot.control.mixer import Mixer
from autopilot.control.position_control import PositionSetpoint, attitude_from_thrust
from autopilot.estimation.estimator import Estimator
from autopilot.estimation.rest_detector import RestDetector
from autopilot.landing_target_input import LandingTargetInput
from autopilot.parameters import ParamDef, ParameterStore, param
from autopilot.topics import NO_ACTUATORS, ActuatorStatus, AttitudeSetpoint, ControlSetpoints, GpsSample, ImuSample
from autopilot.tuning.authority import hover_authority
from autopilot.tuning.autotune import Autotune
from mavsim_core import quaternion as quat
from mavsim_core.constants import GRAVITY_M_S2, LOCKSTEP_DT_S
from params.vehicle import VehicleSpec

OUTER_PERIOD_US = 20_000  # commander, navigator and position control run at 50 Hz
# ... in the 4 ms period 1 of each 20 ms: the estimator's filters run after period 0 and the
# ground-station link after period 2 (autopilot.lockstep_loop), so no two heavy jobs share a period.
OUTER_OFFSET_US = 4_000
# Consecutive IMU samples are one lockstep period apart; a sample that is not later than the previous one,
# or more than this later, means the sensor data restarted (a new simulator): the state is not kept.
MAX_SENSOR_GAP_US = 500_000


# The autotune's message severities (autopilot/tuning says them by name: it imports no MAVLink)
_SEVERITY = {"INFO": S.MAV_SEVERITY_INFO, "WARNING": S.MAV_SEVERITY_WARNING, "CRITICAL": S.MAV_SEVERITY_CRITICAL}

# The parameters this module reads (listed in autopilot/param_catalogue.py).
PARAMS: tuple[ParamDef, ...] = (
    param("MPC_IDLE_CMD", 0.15, 0.0, 0.4, "norm", "Motor command while armed on the ground (idle spin)"),
)


class FlightController:
    def __init__(self, spec: VehicleSpec, params: ParameterStore, sysid: int = 1) -> None:
        self.spec = spec
        self.params = params
        self.estimator = Estimator(params)
        self.estimator.defer_filters = True  # its 50 Hz work runs in after_step, off the critical path
        self.commander = Commander(params, spec.mav_type)
        params.armed = lambda: self.commander.armed  # the gains' floors while armed (parameters.FLIGHT_FLOORS)
        self.commander.feet_below_m = max(p[2] for p in spec.leg_positions_frd_m) + spec.leg_size_m[2] / 2
        self.max_thrust_n = len(spec.rotors) * spec.max_thrust_per_rotor_n  # all rotors at full thrust, N
        self.commander.hover_thrust_frac = spec.mass_kg * GRAVITY_M_S2 / self.max_thrust_n
        self.wall_s: float | None = None  # wall clock (time.monotonic) the process loop stamps: input-loss timers
        self.inertia = spec.inertia_kg_m2
        self.weight_n = spec.mass_kg * GRAVITY_M_S2
        self.mixer = Mixer(spec)
        # The controllers take gain records; the one adapter builds them from the parameters and
        # hands each controller new ones when its parameters change (live tuning).
        self.gains = GainsFromParams(params)
        self.position_control = self.gains.position_control(spec.mass_kg, self.max_thrust_n)
        self.disturbance = self.gains.disturbance_feed_forward(spec.mass_kg, spec.time_constant_up_s)  # wind fed fwd
        self.attitude_control = self.gains.attitude_control()
        self.rate_control = self.gains.rate_control()
        self.gyro_filter = self.gains.gyro_filter()
        self.sat_pos: tuple[bool, ...] = (False, False, False)  # the mixer's per-axis saturation flags
        self.sat_neg: tuple[bool, ...] = (False, False, False)
        self.last_us: int | None = None
        self.last_imu: ImuSample | None = None  # the sample of the latest step (HIGHRES_IMU)
        self.q_sp = np.array([1.0, 0.0, 0.0, 0.0])
        self.yaw_rate_ff = 0.0  # rad/s about NED down, fed forward with q_sp (PositionSetpoint.yaw_rate_rad_s)
        self.rate_sp = np.zeros(3)
        self.thrust_vec = np.zeros(3)  # wanted thrust vector, N NED (position or attitude setpoints)
        self.rate_override: np.ndarray | None = None  # body rates flown directly (ACRO, offboard rates), rad/s FRD
        self.collective_n = 0.0  # collective thrust while flying body rates, N
        self._outputs: tuple[int, tuple[float, ...], float] = (0, (), 0.0)  # the latest step's, for `actuators`
        self._actuators: ActuatorStatus | None = NO_ACTUATORS
        self.setpoint: PositionSetpoint | AttitudeSetpoint | None = None
        self.last_outer_us: int | None = None
        self._gps_pending: GpsSample | None = None  # the latest fix, for the next outer loop
        self._outer_slot: int | None = None  # the 20 ms slot the outer loops last ran in
        # LANDING_TARGET from a companion computer -> the landing target estimate (precision landing)
        self.landing_target = LandingTargetInput(params, own_sysid=sysid)  # a companion of this system only
        self._pos_ned_m = np.zeros(3)  # the latest outer-loop position estimate (for the target's history)
        self._vel_ned_m_s = np.zeros(3)
        self._pos_us = 0
        self._height_m = float("nan")
        self.rest = RestDetector()  # raw IMU and GPS: home is set only at rest
        self._to_record: tuple | None = None  # the latest step's inputs for the rest detector and target history
        self._said_moving = False
        self.sim_link_lost = False  # the simulator link is down (the process loop sets it): MAV_STATE_CRITICAL
        # Autotune (MAV_CMD_DO_AUTOTUNE_ENABLE, autopilot/tuning): the commander routes the command, step() feeds it.
        authority = hover_authority(self.mixer, self.inertia, self.weight_n)  # the excitation stays inside it
        self.autotune = Autotune(
            params, LOCKSTEP_DT_S, lambda sev, txt: self.commander.say(_SEVERITY[sev], txt), authority
        )
        self.commander.autotune = self.autotune

    def _reset_controllers(self) -> None:
        self.position_control.reset()
        self.rate_control.reset()
        self.sat_pos = self.sat_neg = (False, False, False)  # (the mixer's per-axis flags: a tuple each)

    def _restart(self) -> None:
        """A reboot: the estimator starts again as at power-on (in place, so its parameter subscription is
        the same one), the controllers' states too; parameters, gains and the vehicle are kept."""
        self.estimator.restart()
        self._reset_controllers()
        self.setpoint, self.rate_override, self._gps_pending = None, None, None
        self.commander.reboot_pending = False

    # -- the simulator link (issue 18) ----------------------------------------------------------
    def on_sim_link_lost(self) -> None:
        """The process loop lost the simulator (closed, or silent): say so; HEARTBEAT MAV_STATE_CRITICAL."""
        self.sim_link_lost = True
        c = self.commander
        c.say(S.MAV_SEVERITY_CRITICAL, "Simulator link lost" + (" in flight: no sensor data" if c.armed else ""))
        # No arming on the state of before (as PX4 refuses with a sensor missing), until the next update.
        c.estimator_checks = (*c.estimator_checks, "no sensor data (simulator link lost)")
        c._publish()

    def on_sim_link_regained(self) -> None:
        """Sensor data again; whether the state is still good is the next step's to judge (its time)."""
        self.sim_link_lost = False
        self.commander.say(S.MAV_SEVERITY_WARNING, "Simulator link regained")

    def _sensor_time_restarted(self, jump_us: int) -> None:
        """The sensor clock went back (or jumped ahead): the world is another one (a restarted simulator).
        Nothing measured before fits it, so the flight controller starts again as at a reboot (parameters,
        plans and a flight termination kept) and, as PX4 would after losing its sensors in flight, does not
        stay armed: it disarms.  Home is set again once the vehicle is at rest."""
        c = self.commander
        was_armed, terminated = c.armed, c.terminated
        if was_armed:
            c._disarm("sensor data restarted")
        said = c.pop_events()
        c.reboot()
        c.events = said  # (without the reboot's own message)
        c.terminated = terminated
        ExternalInputs.__init__(c.inputs)  # in place (services hold it): its times are of the old clock
        c.say(
            S.MAV_SEVERITY_CRITICAL,
            f"Sensor time jumped {jump_us / 1e6:+.1f} s: state reset" + (", disarmed" if was_armed else ""),
        )  # (one STATUSTEXT: under 50 characters)
        self._restart()
        self.gyro_filter.set_gains(self.gyro_filter.settings)
        self.last_us = self.last_outer_us = self._outer_slot = None
        self._pos_ned_m, self._vel_ned_m_s, self._pos_us = np.zeros(3), np.zeros(3), 0
        self.rest, self._said_moving = RestDetector(), False

    def step(self, imu: ImuSample, gps: GpsSample | None) -> np.ndarray:
        """Run one iteration; return motor commands (0..1, one per rotor)."""
        now = imu.timestamp_us
        if self.last_us is not None and not 0 < now - self.last_us <= MAX_SENSOR_GAP_US:
            self._sensor_time_restarted(now - self.last_us)
        if self.commander.reboot_pending:  # PREFLIGHT_REBOOT_SHUTDOWN: the commander restarted itself
            self._restart()
        dt = LOCKSTEP_DT_S if self.last_us is None else (now - self.last_us) * 1e-6
        self.last_us, self.last_imu = now, imu
        self.estimator.update_imu(imu)
        if gps is not None:
            self.estimator.update_gps(gps)
        self._to_record = (imu, gps, self.estimator.q)  # for _record_step, after the motor commands are out
        rate = self.gyro_filter.apply(self.estimator.rate_frd)  # every sample, so its state stays current
        self._gps_pending = gps or self._gps_pending
        if self.last_outer_us is None:
            self.after_step()
        status = self.commander.status
        tune = self.autotune  # (its excitation, or None: nothing to add; it aborts on a mode change or disarm)
        excite = tune.update(now, status.mode, status.armed, status.in_air) if tune.busy else None
        if not status.armed:
            n = len(self.spec.rotors)
            self._reset_controllers()
            test = self.commander.motor_test_output(now, n)  # DO_MOTOR_TEST: one motor, disarmed, for a while
            out = np.zeros(n) if test is None else test
            self._publish(out, 0.0)
            return out
        if self.setpoint is None:
            self._reset_controllers()
            idle = np.full(len(self.spec.rotors), self.params.get("MPC_IDLE_CMD"))
            self._publish(idle, 0.0)
            return idle
        # Inner loops at the IMU rate, on the selected estimator's latest attitude (on Python floats: numpy's
        # per-call cost on 3-vectors would be most of the work; the published setpoints stay arrays).
        est = self.estimator
        w, x, y, z = q = est.q.tolist()  # FRD -> NED
        sp: Sequence[float]  # the body-rate setpoint, rad/s FRD
        if self.rate_override is None:
            sp = self.attitude_control.update_floats(q, self.q_sp.tolist())
            if self.yaw_rate_ff != 0.0:  # the yaw setpoint's own rate, about NED down
                sp = with_yaw_rate(sp, q, self.yaw_rate_ff)
            rate_sp = self.rate_sp = np.array(sp)
        else:
            rate_sp = self.rate_sp = self.rate_override
            sp = rate_sp.tolist()
        if excite is not None:
            self.rate_sp = rate_sp + excite
            sp = self.rate_sp.tolist()
        alpha = self.rate_control.update_floats(
            rate, sp, dt, self.sat_pos, self.sat_neg, integrate=not status.ground_contact
        )
        if excite is not None:
            tune.record(np.array(alpha), est.rate_frd, now)
        # Collective thrust: the part of the wanted thrust vector along the current body -z axis.
        if self.rate_override is None:
            # Body z axis in NED: the third column of quat.to_matrix(q) (not made here: off the critical path).
            ux, uy, uz = 2.0 * (x * z + w * y), 2.0 * (y * z - w * x), w * w - x * x - y * y + z * z
            tx, ty, tz = self.thrust_vec.tolist()
            thrust_n = max(-(tx * ux + ty * uy + tz * uz), 0.0)
        else:
            thrust_n = self.collective_n
        jx, jy, jz = self.inertia.tolist()
        commands, thrusts, self.sat_pos, self.sat_neg, _ = self.mixer.mix_floats(
            jx * alpha[0], jy * alpha[1], jz * alpha[2], thrust_n
        )
        collective_n = sum(thrusts)
        self.disturbance.motors(collective_n, dt)
        self._publish(commands, collective_n)
        return np.array(commands)

    def after_step(self) -> None:
        """The estimator's deferred filter work, then the outer loops once per OUTER_PERIOD_US slot."""
        now = self.last_us
        if now is None:
            return
        if self._to_record is not None:
            self._record_step(*self._to_record)
        self.estimator.run_deferred()
        slot = (now - OUTER_OFFSET_US) // OUTER_PERIOD_US
        if slot != self._outer_slot:
            self._outer_slot = slot
            gps, self._gps_pending = self._gps_pending, None
            self._outer_loop(now, gps)

    def _record_step(self, imu: ImuSample, gps: GpsSample | None, q: np.ndarray) -> None:
        """The step's inputs to the rest detector and the landing target's history (``q``: the attitude the
        step flew).  Run first in :meth:`after_step`: off the lockstep's critical path, before anything reads them."""
        self._to_record = None
        now = imu.timestamp_us
        self.rest.update_imu(now, imu.accel_frd_m_s2, imu.gyro_frd_rad_s)
        if gps is not None:
            self.rest.update_gps(now, gps.vel_ned_m_s)
        # The outer loop's position, carried on at its velocity to this step (the target's history needs
        # where the vehicle was at each capture: 20 ms of staleness is 2 cm at 1 m/s).
        since_s = (now - self._pos_us) * 1e-6
        pos = self._pos_ned_m + self._vel_ned_m_s * since_s if 0.0 < since_s < 0.1 else self._pos_ned_m
        self.landing_target.record_state(now, q, pos, self._height_m)

    def _outer_loop(self, now: int, gps: GpsSample | None) -> None:
        """Commander, navigator and position control (50 Hz and on each GPS fix)."""
        dt = 0.02 if self.last_outer_us is None else (now - self.last_outer_us) * 1e-6
        self.last_outer_us = now
        estimator = self.estimator
        for severity, text in estimator.events:
            self.commander.say(getattr(S, "MAV_SEVERITY_" + severity), text)
        estimator.events.clear()
        estimator.set_in_air(self.commander.status.in_air)
        est = estimator.estimate()
        commander = self.commander
        self._pos_ned_m, self._vel_ned_m_s, self._pos_us = est.pos_ned_m, est.vel_ned_m_s, now
        home = commander.home
        self._height_m = float(home.pos_ned_m[2] - est.pos_ned_m[2]) if home is not None else float("nan")
        commander.landing_target = self.landing_target.update(now, est)
        for reason in self.landing_target.pop_events():
            commander.say(S.MAV_SEVERITY_WARNING, reason)
        checks = tuple(estimator.prearm_failures()) if estimator.use_ekf and not self.commander.status.armed else ()
        self._check_rest()
        sp = self.commander.update(now, est, gps, estimator.gps_ok(now), self.actuators, checks, self.wall_s)
        self.commander.vel_sp_down_m_s = math.nan  # (set again below when the position loop runs)
        if isinstance(sp, AttitudeSetpoint) and self.commander.status.armed:
            self._fly_attitude(sp)
            return
        self.rate_override = None
        if sp is None or isinstance(sp, AttitudeSetpoint) or not est.attitude_valid or not self.commander.status.armed:
            self.setpoint = None  # (an attitude setpoint is flown above when armed: here it is not)
            return
        self.setpoint = sp
        flying = self.commander.status.in_air and not self.commander.status.ground_contact
        dist = self.disturbance.update(est.accel_ned_m_s2, estimator.r_ned_frd, flying, dt)
        self.commander.contact_push = self.disturbance.observer.in_contact
        out = self.position_control.control(est.pos_ned_m, est.vel_ned_m_s, sp, dt, dist)
        self.thrust_vec = out.thrust_ned_n
        self.commander.vel_sp_down_m_s = float(out.vel_sp_ned_m_s[2])
        self.q_sp = quat.from_matrix(attitude_from_thrust(self.thrust_vec, sp.yaw_rad))
        self.yaw_rate_ff = float(sp.yaw_rate_rad_s) if math.isfinite(sp.yaw_rate_rad_s) else 0.0

    def _check_rest(self) -> None:
        """Tell the commander whether the vehicle is at rest (home waits for it); report a vehicle moving
        while disarmed before home is set, once: a flight controller restarted in the air (it comes up
        disarmed and the vehicle falls; PX4 does the same) or a vehicle carried about."""
        c = self.commander
        c.at_rest = self.rest.at_rest
        if self.rest.moving and not c.armed and c.home is None and not self._said_moving:
            self._said_moving = True
            c.say(S.MAV_SEVERITY_CRITICAL, "Moving while disarmed: restarted in flight?")

    def _fly_attitude(self, sp: AttitudeSetpoint) -> None:
        """An attitude or body-rate setpoint: the position loop is bypassed (and reset)."""
        self.setpoint = sp
        self.position_control.reset()
        self.yaw_rate_ff = 0.0
        thrust_n = min(max(sp.thrust_frac, 0.0), 1.0) * self.max_thrust_n
        if sp.q_wxyz is None:
            self.rate_override = np.asarray(sp.body_rate_frd_rad_s, dtype=float).copy()
            self.collective_n = thrust_n
            self.thrust_vec = quat.to_matrix(self.estimator.q) @ np.array([0.0, 0.0, -thrust_n])
            return
        self.rate_override = None
        self.q_sp = np.asarray(sp.q_wxyz, dtype=float).copy()
        self.thrust_vec = quat.to_matrix(self.q_sp) @ np.array([0.0, 0.0, -thrust_n])

    def on_landing_target(self, msg, src_sysid: int) -> None:
        """A LANDING_TARGET received from the simulator link or a ground/companion link (any sender)."""
        self.landing_target.on_message(msg, src_sysid, self.last_us or 0)

    def _publish(self, commands: np.ndarray | list[float], thrust_n: float) -> None:
        """Keep the step's outputs (motor commands 0..1, collective thrust N); the :attr:`actuators` record is
        built when first read, after the commands have gone out (off the lockstep's critical path)."""
        motors = commands.tolist() if isinstance(commands, np.ndarray) else commands
        self._outputs = (self.last_us or 0, tuple(motors), thrust_n)
        self._actuators = None

    @property
    def actuators(self) -> ActuatorStatus:
        """What the latest step sent to the motors (the record the commander, the log and the telemetry read)."""
        if self._actuators is None:
            time_us, motors, thrust_n = self._outputs
            self._actuators = ActuatorStatus(
                time_us, motors, thrust_n, thrust_n / self.max_thrust_n, thrust_n / self.weight_n
            )
        return self._actuators

    @actuators.setter
    def actuators(self, record: ActuatorStatus) -> None:
        """Publish a record in place of the latest step's (tests that pretend a flight)."""
        self._actuators = record

    # -- telemetry (read-only view of the controllers' setpoints) --------------------------------
    def control_setpoints(self) -> ControlSetpoints | None:
        """The setpoints the cascade is flying now, or None while it is not (disarmed, idle on the ground)."""
        sp = self.setpoint
        if sp is None or not self.commander.status.armed:
            return None
        pc = self.position_control
        if isinstance(sp, AttitudeSetpoint):
            nan3 = np.full(3, np.nan)
            pos, vel, acc, yaw = nan3, nan3, nan3, float("nan")
        else:
            pos, vel, acc, yaw = sp.pos_ned_m.copy(), pc.vel_sp.copy(), pc.acc_sp.copy(), sp.yaw_rad
        thrust_frac = float(np.linalg.norm(self.thrust_vec)) / self.max_thrust_n
        return ControlSetpoints(
            timestamp_us=self.last_us or 0,
            pos_ned_m=pos,
            vel_ned_m_s=vel,
            acc_ned_m_s2=acc,
            yaw_rad=yaw,
            q_sp_wxyz=self.q_sp.copy() if self.rate_override is None else np.full(4, np.nan),  # rates: no attitude
            rate_sp_frd_rad_s=self.rate_sp.copy(),
            thrust_frac=thrust_frac,
        )
