"""The simulator process loop: PX4's simulator MAVLink API over TCP, in lockstep.

The simulator listens on TCP (4560 + instance, loopback unless ``sitl --bind``); the flight
controller connects and is served once it has sent a valid MAVLink message (:mod:`sitl.peer_accept`).
Each period the simulator sends HIL_SENSOR (and HIL_GPS whenever the GPS model
produces a fix, BATTERY_STATUS at 5 Hz) stamped with simulated time, waits for
HIL_ACTUATOR_CONTROLS, and only then steps the physics, so a run is
deterministic for a seed.  ``speed`` paces simulated time to the wall clock
(1 = real time); ``None`` runs as fast as lockstep allows.

The simulator is also a MAVLink component on UDP (:mod:`sitl.param_server`):
ground truth (HIL_STATE_QUATERNION, LOCAL_POSITION_NED at 50 Hz of simulated time)
goes to 127.0.0.1:(14740 + instance) and to whoever talks to it, and the same
socket serves the ``SIM_*`` parameters, so a ground station or a test changes
wind, sensor errors and failures in flight.  It is polled every 50 Hz period and
while the simulator waits for the flight controller.  Scenario events
(:mod:`sitl.scenario`) are applied at the first 50 Hz period at or after their time.
The flight controller may also set ``SIM_*`` parameters on the TCP link itself (its failure
injection): :mod:`sitl.link_params` answers them while the simulator waits for the actuator controls.
A sensor that is off (:mod:`sitl.sensor_faults`) has its HIL_SENSOR ``fields_updated`` bits cleared.
"""

from __future__ import annotations

import math
import socket
import sys
import time
from typing import Sequence

import numpy as np
from pymavlink.dialects.v20 import common as mavlink

from mavsim_core.constants import GRAVITY_M_S2
from mavsim_core.geodesy import ned_to_geodetic
from mavsim_core.sim_api_codec import MessageLayout, StreamParser
from mavsim_core.spin_receiver import SpinReceiver
from sitl.gimbal_link import GimbalDeviceLink
from sitl.hold import HOLD_PARAM, SimHold
from sitl.link_params import LinkParams
from sitl.param_server import SIM_COMPID, SIM_SYSID, UGV_COMPID, SimParamServer
from sitl.peer_accept import accept_peer, listen
from sitl.scenario import EventSchedule, ScenarioEvent
from sitl.sensor_faults import hil_sensor_fields, pressure_altitude_m
from sitl.sensor_messages import battery_status_message, hil_gps_message
from sitl.sim_params import SimParameters, format_value
from sitl.simulation import LOCKSTEP_DT_S, SensorTruth, Simulation, Truth
from sitl.ugv_world import ugv_truth_messages

TRUTH_PERIOD_US = 20_000  # 50 Hz: ground truth, parameter service, scenario events
BATTERY_PERIOD_US = 200_000  # 5 Hz
# A paced run (``speed``) steps on until it is this far ahead of the wall clock, then sleeps it off: steps in
# bursts, not a sleep every step.  Idling on the ground, both processes' CPU per wall second at 5x fell from
# 0.48 to 0.39 s (1 ms before), at 1x from 0.17 to 0.11 s; a ground station's command waits at most this
# much longer for its answer (the flight controller serves its link between steps).
PACE_AHEAD_S = 0.02
_HIL_SENSOR = MessageLayout(mavlink.MAVLink_hil_sensor_message)
_HIL_STATE_QUATERNION = MessageLayout(mavlink.MAVLink_hil_state_quaternion_message)
_LOCAL_POSITION_NED = MessageLayout(mavlink.MAVLink_local_position_ned_message)
_ACTUATOR_CONTROLS = MessageLayout(mavlink.MAVLink_hil_actuator_controls_message)
_CONTROLS_AT = _ACTUATOR_CONTROLS.field_index("controls")  # in the tuple the fast parser gives (wire order)
_MODE_AT = _ACTUATOR_CONTROLS.field_index("mode")
_ARMED = mavlink.MAV_MODE_FLAG_SAFETY_ARMED
_MG_PER_M_S2 = 1000.0 / GRAVITY_M_S2


def _int16(x: float) -> int:
    """Rounded and clamped to a MAVLink int16 field (plain Python: numpy's scalar clip costs ~10 us)."""
    return max(-32767, min(32767, round(x)))


def _log(text: str) -> None:
    print(f"[sitl] {text}", file=sys.stderr, flush=True)


def _log_param_set(name: str, value: int | float, addr: tuple[str, int]) -> None:
    if name == HOLD_PARAM:  # moved every slice of a stepped run (sitl/hold.py): not worth a line each
        return
    _log(f"{name} = {value:g} (PARAM_SET from {addr[0]}:{addr[1]})")


class LockstepServer:
    """The simulator process: lockstep TCP link to the flight controller, UDP truth and SIM_* parameters.

    ``truth_addr``: default peer of the UDP component (None: no truth, no parameter
    service).  ``truth_bind``: its local address (port 0: chosen by the OS).  ``bind_host``: the
    address the TCP port listens on.  Both are loopback by default: nobody else on the network reaches
    the vehicle's sensors, motors or ``SIM_*`` parameters (``sitl --bind`` widens them).
    ``events``: scenario events, applied when simulated time reaches them.
    ``sysid``: the vehicle's MAVLink system id (1 + instance), which the simulator's components share.
    """

    def __init__(
        self,
        sim: Simulation,
        port: int,
        truth_addr: tuple[str, int] | None,
        speed: float | None,
        *,
        truth_bind: tuple[str, int] = ("127.0.0.1", 0),
        bind_host: str = "127.0.0.1",
        events: Sequence[ScenarioEvent] = (),
        sysid: int = SIM_SYSID,
    ) -> None:
        self.sim = sim
        self.sysid = sysid  # the vehicle's system id (1 + instance): the simulator is one of its components
        self.port = port
        self.truth_addr = truth_addr
        self.speed = speed
        self.mav = mavlink.MAVLink(None, sysid, SIM_COMPID)
        self.mav.robust_parsing = True
        # The settings objects the models read on every step; a set acts on the next step.
        self.params = SimParameters(
            sim.wind_settings, sim.sensors.settings, sim.motor_settings, sim.ugv_settings, sim.camera_settings
        )
        self._said_no_ugv = False
        self.companion = None  # sitl.companion.LockstepCompanion: camera + vision, when the world has the UGV
        self.camera = None  # sitl.camera_component.CameraComponent: the companion's camera as MAVLink component 100
        # The camera's gimbal, when the vehicle has one: driven and reported on this link (sitl/gimbal_link.py)
        gimbal = getattr(getattr(sim, "vehicle", None), "gimbal", None)
        self.gimbal_link = GimbalDeviceLink(gimbal) if gimbal is not None else None
        self.params.started = True  # start-only parameters (SIM_UGV_EN) are refused from now on
        self.events = EventSchedule(events)
        # SIM_* parameters set by the flight controller on the TCP link (its failure injection)
        self.link_params = LinkParams(
            self.params, sysid, on_change=lambda n, v: _log(f"{n} = {v:g} (PARAM_SET from the flight controller)"),
            on_refused=lambda reason: _log(f"refused the flight controller's request: {reason}"),
        )  # fmt: skip
        self.param_server: SimParamServer | None = None
        self.conn: socket.socket | None = None
        if truth_addr:
            self.param_server = SimParamServer(
                self.params, bind=truth_bind, default_peer=truth_addr, sysid=sysid, on_param_set=_log_param_set
            )
            self.param_server.on_manual_control = self._on_manual_control
        self.listener: socket.socket | None = None
        self.truth_log = None  # sitl.truth_log.TruthRecorder (sitl --log-dir): fed every period
        self.ugv_radio = None  # sitl.ugv_broadcast.UgvRadio: the UGV's FOLLOW_TARGET (SIM_UGV_FLW), when it exists
        try:
            self.listener = listen(bind_host, port)
        except OSError:
            self.close()  # reads ugv_radio: set before
            raise
        self.motor_commands = np.zeros(sim.rotors.n)
        self.hold = SimHold()  # SIM_HOLD_MS: the world's hold (sitl/hold.py)
        self.steps = 0
        self.prepares = True  # _send_sensors ends with the world's prepare_step (a world of several does it itself)
        self.armed = False  # the flight controller's HIL_ACTUATOR_CONTROLS mode flag

    def close(self) -> None:
        if self.companion is not None:
            self.companion.close()
            self.companion = None
        if self.camera is not None:
            self.camera.close()
            self.camera = None
        if self.ugv_radio is not None:
            self.ugv_radio.close()
        for s in (self.conn, self.listener):
            if s is not None:
                s.close()
        if self.param_server is not None:
            self.param_server.close()

    # -- connection ---------------------------------------------------------------
    def _accept(self, others: Sequence[LockstepServer] = ()) -> None:
        """Wait for the flight controller (a peer that passes the handshake of :mod:`sitl.peer_accept`),
        serving SIM_* parameters meanwhile (``others``: the other vehicles' of a world too)."""
        _log(f"waiting for the flight controller on TCP port {self.port}")
        servers = [s.param_server for s in (self, *others) if s.param_server is not None]
        assert self.listener is not None

        def serve() -> None:
            now = time.monotonic()
            for server in servers:
                server.poll(now)

        watched = [server.sock for server in servers]
        conn, addr = accept_peer(self.listener, serve, watched, _log)
        conn.settimeout(None)
        conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.conn = conn
        self.receiver = SpinReceiver(conn)
        self.mav = mavlink.MAVLink(None, self.sysid, SIM_COMPID)
        self.mav.robust_parsing = True
        self.parser = StreamParser(self.mav, [_ACTUATOR_CONTROLS.cls])
        _log(f"flight controller connected from {addr[0]}:{addr[1]}")

    def send_heartbeat(self, state: int, time_us: int) -> None:
        """A HEARTBEAT on the lockstep link (``custom_mode``: ``time_us`` in ms) in place of the next sensors:
        ``MAV_STATE_STANDBY``, the world holds there (:mod:`sitl.hold`); ``MAV_STATE_ACTIVE``, it steps on but waits
        for something of its own first, the camera's frame (:meth:`busy_keepalive`).  Either way the flight
        controller knows the simulator is alive (autopilot/sim_link_watch.py)."""
        if self.conn is None:
            return
        hb = mavlink.MAVLink_heartbeat_message(
            mavlink.MAV_TYPE_GENERIC, mavlink.MAV_AUTOPILOT_INVALID, 0, time_us // 1000, state, 3
        )
        try:
            self.conn.sendall(self._pack(hb))
        except OSError:
            pass  # closed: the loop (or the hold's serve) finds out

    def busy_keepalive(self) -> None:
        """ "Alive, stepping, waiting for the camera" to the flight controller, which neither declares the link lost
        nor holds.  A world of several vehicles sends it on every vehicle's link (sitl/__main__.py)."""
        self.send_heartbeat(mavlink.MAV_STATE_ACTIVE, self.sim.time_us)

    def _pack(self, msg) -> bytes:
        """A message packed for the flight controller, its sequence number advanced (as mav.send does)."""
        data = msg.pack(self.mav)
        self.mav.seq = (self.mav.seq + 1) % 256
        return data

    # -- one period --------------------------------------------------------------
    def _send_sensors(self) -> None:
        """The period's sensor messages: HIL_GPS when a fix is due, BATTERY_STATUS at 5 Hz, then HIL_SENSOR."""
        sim = self.sim
        sensors = sim.sensors
        t = sim.sensor_truth()  # plain floats; the full truth is built only at 50 Hz for the truth port
        time_us = sim.time_us
        imu = sensors.imu(
            t.specific_force_frd_m_s2,
            t.rate_frd_rad_s,
            t.r_ned_frd,
            t.pos_ned_m,
            dt_s=LOCKSTEP_DT_S,
            current_a=sim.battery.current_a,
        )
        a, g, m = imu.accel_frd_m_s2, imu.gyro_frd_rad_s, imu.mag_frd_gauss
        out = b""
        # Every period: the GPS model decides when a fix is due (SIM_GPS_HZ) and what delayed
        # state it describes (SIM_GPS_LAG_MS); it is sent stamped with the current time.
        fix = sensors.gps(time_us, t.pos_ned_m, t.vel_ned_m_s)
        if fix is not None:
            out += self._pack(hil_gps_message(time_us, fix))
        if time_us % BATTERY_PERIOD_US == 0:
            out += self._pack(battery_status_message(sim.battery, sim.motor_settings.battery_empty))
        if self.companion is not None:  # LANDING_TARGET whose simulated latency has passed
            out += self.companion.step(sim.data, time_us)
        if self.camera is not None:  # the camera protocol on the flight controller's payload link (UDP)
            self.camera.step(time_us)
        if self.gimbal_link is not None:  # GIMBAL_DEVICE_ATTITUDE_STATUS at 50 Hz
            out += self.gimbal_link.status(time_us, sim.data, t.r_ned_frd, self.mav)
        if self.ugv_radio is not None and time_us % TRUTH_PERIOD_US == 0:
            # The UGV's FOLLOW_TARGET (UDP) before the sensors (TCP): on loopback it is in the flight controller's
            # socket when the HIL_SENSOR starting its step arrives, so the same step reads it in every run.
            self.ugv_radio.step(time_us, sim.ugv_truth)
        # HIL_SENSOR last: it closes the period and triggers the flight controller's step.
        out += _HIL_SENSOR.encode(
            self.mav,
            (
                time_us,
                a[0],
                a[1],
                a[2],
                g[0],
                g[1],
                g[2],
                m[0],
                m[1],
                m[2],
                imu.pressure_hpa,
                0.0,
                pressure_altitude_m(imu.pressure_hpa),
                imu.temperature_c,
                hil_sensor_fields(a[0], g[0], m[0], imu.pressure_hpa),
                0,
            ),
        )
        self.conn.sendall(out)
        if self.truth_log is not None:  # while the flight controller computes its step
            self.truth_log.record(time_us, t, self.armed, self.motor_commands, self.sim.ugv_truth)
        if time_us % TRUTH_PERIOD_US == 0:
            self._every_truth_period(time_us, t)
        if self.prepares:  # the next step's ground-vehicle commands, while the flight controller computes its step
            sim.world.prepare_step()

    def _every_truth_period(self, time_us: int, t: SensorTruth | None = None) -> None:
        """50 Hz of simulated time: scenario events, ground truth, parameter service.  ``t``: the period's sensor
        truth, which gives the truth port's position, velocity and rate (None: all from ``sim.truth()``)."""
        if time_us >= self.events.next_us:
            self._apply_events(time_us)
        server = self.param_server
        if server is not None:
            if t is None:
                self._send_truth(self.sim.truth())
            else:  # the same numbers without building the full Truth's arrays
                q, accel = self.sim.attitude_truth()
                self._send_truth_values(time_us, q, t.pos_ned_m, t.vel_ned_m_s, t.rate_frd_rad_s, accel)
            server.poll(time.monotonic())

    def _apply_events(self, time_us: int) -> None:
        for event in self.events.pop_due(time_us):
            self.params.set_many(event.values)  # checked when the scenario was loaded
            changes = ", ".join(
                f"{name} = {format_value(v, self.params.param(name).type)}" for name, v in event.values.items()
            )
            _log(f"t = {time_us / 1e6:.3f} s: scenario event: {changes}")

    def _send_truth(self, t: Truth) -> None:
        """HIL_STATE_QUATERNION and LOCAL_POSITION_NED of a :class:`sitl.multicopter.Truth` (and the UGV's truth)."""
        self._send_truth_values(
            t.time_us,
            t.q_ned_frd.tolist(),
            t.pos_ned_m.tolist(),
            t.vel_ned_m_s.tolist(),
            t.rate_frd_rad_s.tolist(),
            t.accel_ned_m_s2.tolist(),
        )

    def _send_truth_values(
        self, time_us: int, q_ned_frd, pos_ned_m, vel_ned_m_s, rate_frd_rad_s, accel_ned_m_s2
    ) -> None:
        """:meth:`_send_truth` from floats: quaternion (w, x, y, z) FRD -> NED, m, m/s, rad/s FRD, m/s^2 NED."""
        x, y, z = pos_ned_m
        lat, lon, alt = ned_to_geodetic(pos_ned_m, *self.sim.sensors.home)
        vn, ve, vd = vel_ned_m_s
        ax, ay, az = [a * _MG_PER_M_S2 for a in accel_ned_m_s2]  # mG (as numpy's a * k: the same bits)
        p, q, r = rate_frd_rad_s
        server = self.param_server
        mav = server.mav  # the component's own encoder: its sequence numbers go on
        state = (time_us, q_ned_frd, p, q, r, round(lat * 1e7), round(lon * 1e7), round(alt * 1000))
        state += (_int16(vn * 100), _int16(ve * 100), _int16(vd * 100), 0, 0, _int16(ax), _int16(ay), _int16(az))
        out = _HIL_STATE_QUATERNION.encode(mav, state)
        out += _LOCAL_POSITION_NED.encode(mav, (time_us // 1000, x, y, z, vn, ve, vd))
        ugv = self.sim.ugv_truth()
        if ugv is not None:  # the ground vehicle, as its own component (UGV_COMPID)
            out += server.encode(ugv_truth_messages(ugv), compid=UGV_COMPID)
        if self.gimbal_link is not None:  # the camera's attitude from the joints, in the earth frame (tests' truth)
            truth_q = self.gimbal_link.earth_attitude(self.sim.data, q_ned_frd)
            out += server.encode([truth_q], compid=mavlink.MAV_COMP_ID_GIMBAL)
        server.send(out)  # one datagram to each peer (each sendto costs 10-50 us: issue 38)

    def _on_manual_control(self, msg) -> None:
        """MANUAL_CONTROL to the simulator's component: the UGV's joystick ([F 2.2]); x forward, r yaw."""
        ugv = self.sim.ugv
        if ugv is None:
            if not self._said_no_ugv:
                self._said_no_ugv = True
                self.param_server.send_statustext(
                    mavlink.MAV_SEVERITY_WARNING, "MANUAL_CONTROL ignored: no UGV (start with SIM_UGV_EN=1)"
                )
            return
        ugv.manual(float(msg.x), float(msg.r), self.sim.time_us * 1e-6)

    def _wait_actuators(self) -> bool:
        """Block until HIL_ACTUATOR_CONTROLS arrives; False if the link closed."""
        while True:
            data = self.receiver.recv(4096)
            if not data:
                return False
            got = False
            n = self.sim.rotors.n
            for msg in self.parser.parse(data, raw=True):
                if type(msg) is tuple:  # HIL_ACTUATOR_CONTROLS by the fast path: (msgid, its fields in wire order)
                    values = msg[1]
                    mode, controls = values[_MODE_AT], values[_CONTROLS_AT : _CONTROLS_AT + min(n, 16)]
                elif msg.get_type() == "HIL_ACTUATOR_CONTROLS":  # (pymavlink's parser, after damaged bytes)
                    mode, controls = msg.mode, msg.controls[:n]
                elif self.gimbal_link is not None and self.gimbal_link.handle(msg):  # the gimbal's setpoint
                    continue
                else:  # between two steps: SIM_* parameter requests
                    replies = self.link_params.handle(msg)
                    if replies:
                        self.conn.sendall(b"".join(self._pack(r) for r in replies))
                    continue
                armed = self.armed = bool(mode & _ARMED)
                self.motor_commands = [c if math.isfinite(c) else 0.0 for c in controls] if armed else [0.0] * n
                got = True
            if got:
                return True

    def run(self, duration_s: float | None = None) -> None:
        self._accept()
        wall0 = time.monotonic()
        sim0 = self.sim.time_us
        while duration_s is None or self.sim.time_us < duration_s * 1e6:
            # The hold (SIM_HOLD_MS), before a period's sensors.  A world of several vehicles calls it the same way
            # before its period, with every vehicle's server: hold.wait(servers, world time); pacing shifts by it.
            if self.hold.reached(self.sim.time_us):
                wall0 += self.hold.wait([self], self.sim.time_us)
            try:
                self._send_sensors()
                alive = self._wait_actuators()
            except OSError:
                alive = False
            if not alive:
                _log("flight controller disconnected; simulation paused")
                self.conn.close()
                self._accept()
                wall0, sim0 = time.monotonic(), self.sim.time_us
                continue
            self.sim.step(self.motor_commands)
            self.steps += 1
            if self.speed is not None:
                ahead = (self.sim.time_us - sim0) / 1e6 / self.speed - (time.monotonic() - wall0)
                if ahead > PACE_AHEAD_S:
                    time.sleep(ahead)
