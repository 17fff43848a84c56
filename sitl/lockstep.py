"""The simulator process loop: PX4's simulator MAVLink API over TCP, in lockstep.

The simulator listens on TCP (4560 + instance); the flight controller connects.
Each period the simulator sends HIL_SENSOR (and HIL_GPS at 10 Hz) stamped with
simulated time, waits for HIL_ACTUATOR_CONTROLS, and only then steps the physics,
so a run is deterministic for a seed.  ``speed`` paces simulated time to the wall
clock (1 = real time); ``None`` runs as fast as lockstep allows.  Ground truth
goes as HIL_STATE_QUATERNION and LOCAL_POSITION_NED to UDP (14560 + instance).
"""

from __future__ import annotations

import math
import socket
import sys
import time

import numpy as np
from pymavlink.dialects.v20 import common as mavlink

from autopilot.geodesy import ned_to_geodetic
from autopilot.socket_wait import SpinReceiver
from sitl.sensors import course_over_ground_deg
from sitl.simulation import LOCKSTEP_DT_S, Simulation

GPS_PERIOD_US = 100_000  # 10 Hz
TRUTH_PERIOD_US = 20_000  # 50 Hz
BATTERY_PERIOD_US = 1_000_000
HIL_SENSOR_ALL_FIELDS = 0x1FFF
SIM_SYSID, SIM_COMPID = 1, 51  # 51 = MAV_COMP_ID_USER27, our simulator component


def _log(text: str) -> None:
    print(f"[sitl] {text}", file=sys.stderr, flush=True)


class LockstepServer:
    def __init__(self, sim: Simulation, port: int, truth_addr: tuple[str, int] | None, speed: float | None) -> None:
        self.sim = sim
        self.port = port
        self.truth_addr = truth_addr
        self.speed = speed
        self.mav = mavlink.MAVLink(None, SIM_SYSID, SIM_COMPID)
        self.mav.robust_parsing = True
        self.truth_mav = mavlink.MAVLink(None, SIM_SYSID, SIM_COMPID)
        self.truth_sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM) if truth_addr else None
        if self.truth_sock:
            self.truth_sock.setblocking(False)
        self.listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
        self.listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        self.listener.bind(("0.0.0.0", port))
        self.listener.listen(1)
        self.conn: socket.socket | None = None
        self.motor_commands = np.zeros(sim.rotors.n)
        self.steps = 0

    # -- connection ---------------------------------------------------------------
    def _accept(self) -> None:
        _log(f"waiting for the flight controller on TCP port {self.port}")
        conn, addr = self.listener.accept()
        conn.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self.conn = conn
        self.receiver = SpinReceiver(conn)
        self.mav = mavlink.MAVLink(None, SIM_SYSID, SIM_COMPID)
        self.mav.robust_parsing = True
        _log(f"flight controller connected from {addr[0]}:{addr[1]}")

    def _send(self, msg) -> None:
        self.conn.sendall(msg.pack(self.mav))

    # -- one period --------------------------------------------------------------
    def _send_sensors(self) -> None:
        sim = self.sim
        t = sim.truth()
        imu = sim.sensors.imu(t.specific_force_frd_m_s2, t.rate_frd_rad_s, t.r_ned_frd, t.pos_ned_m)
        a, g, m = imu.accel_frd_m_s2, imu.gyro_frd_rad_s, imu.mag_frd_gauss
        out = []
        if t.time_us % GPS_PERIOD_US == 0:
            fix = sim.sensors.gps(t.pos_ned_m, t.vel_ned_m_s)
            v = fix.vel_ned_m_s
            out.append(mavlink.MAVLink_hil_gps_message(
                t.time_us, fix.fix_type, round(fix.lat_deg * 1e7), round(fix.lon_deg * 1e7),
                round(fix.alt_amsl_m * 1000), round(fix.eph_m * 100), round(fix.epv_m * 100),
                round(math.hypot(v[0], v[1]) * 100), round(v[0] * 100), round(v[1] * 100), round(v[2] * 100),
                round(course_over_ground_deg(v) * 100) % 36000, fix.satellites, 0, 0,
            ))
        if t.time_us % BATTERY_PERIOD_US == 0:
            b = sim.battery
            cells = [min(65534, round(b.voltage_v / b.cells * 1000))] * b.cells + [65535] * (10 - b.cells)
            out.append(mavlink.MAVLink_battery_status_message(
                0, mavlink.MAV_BATTERY_FUNCTION_ALL, mavlink.MAV_BATTERY_TYPE_LIPO, 32767, cells,
                round(b.current_a * 100), round(b.consumed_mah), -1, round(b.remaining_frac * 100),
            ))
        # HIL_SENSOR last: it closes the period and triggers the flight controller's step.
        out.append(mavlink.MAVLink_hil_sensor_message(
            t.time_us, a[0], a[1], a[2], g[0], g[1], g[2], m[0], m[1], m[2],
            imu.pressure_hpa, 0.0, sim.sensors.home[2] - t.pos_ned_m[2], imu.temperature_c,
            HIL_SENSOR_ALL_FIELDS, 0,
        ))
        self.conn.sendall(b"".join(msg.pack(self.mav) for msg in out))
        if self.truth_sock and t.time_us % TRUTH_PERIOD_US == 0:
            self._send_truth(t)

    def _send_truth(self, t) -> None:
        lat, lon, alt = ned_to_geodetic(t.pos_ned_m, *self.sim.sensors.home)
        a_mg = (t.accel_ned_m_s2 / 9.80665 * 1000).round().astype(int)
        msgs = [
            mavlink.MAVLink_hil_state_quaternion_message(
                t.time_us, [float(x) for x in t.q_ned_frd], *[float(x) for x in t.rate_frd_rad_s],
                round(lat * 1e7), round(lon * 1e7), round(alt * 1000),
                *[int(np.clip(round(x * 100), -32767, 32767)) for x in t.vel_ned_m_s],
                0, 0, *[int(np.clip(x, -32767, 32767)) for x in a_mg],
            ),
            mavlink.MAVLink_local_position_ned_message(
                t.time_us // 1000, *[float(x) for x in t.pos_ned_m], *[float(x) for x in t.vel_ned_m_s]),
        ]
        try:
            self.truth_sock.sendto(b"".join(m.pack(self.truth_mav) for m in msgs), self.truth_addr)
        except OSError:
            pass

    def _wait_actuators(self) -> bool:
        """Block until HIL_ACTUATOR_CONTROLS arrives; False if the link closed."""
        while True:
            data = self.receiver.recv(4096)
            if not data:
                return False
            got = False
            try:
                msgs = self.mav.parse_buffer(data) or []
            except mavlink.MAVError:
                msgs = []
            for msg in msgs:
                if msg.get_type() == "HIL_ACTUATOR_CONTROLS":
                    armed = bool(msg.mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)
                    n = self.sim.rotors.n
                    cmds = np.array(msg.controls[:n], dtype=float)
                    self.motor_commands = np.where(np.isfinite(cmds), cmds, 0.0) if armed else np.zeros(n)
                    got = True
            if got:
                return True

    def run(self, duration_s: float | None = None) -> None:
        self._accept()
        wall0 = time.monotonic()
        sim0 = self.sim.time_us
        while duration_s is None or self.sim.time_us < duration_s * 1e6:
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
                if ahead > 0.001:
                    time.sleep(ahead)
