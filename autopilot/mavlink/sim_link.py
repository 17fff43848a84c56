"""The flight controller's side of the simulator link (PX4 simulator MAVLink API).

Connects over TCP to the simulator (4560 + instance), turns HIL_SENSOR and
HIL_GPS into :mod:`autopilot.topics` samples (SI units, FRD/NED as sent), and
answers each period with HIL_ACTUATOR_CONTROLS stamped with the same time.
"""

from __future__ import annotations

import socket
import time

import numpy as np
from pymavlink.dialects.v20 import common as mavlink

from autopilot.topics import BatteryState, GpsSample, ImuSample
from mavsim_core.sim_api_codec import MessageLayout, StreamParser
from mavsim_core.spin_receiver import SpinReceiver

UINT16_MAX = 65535
_ACTUATORS = MessageLayout(mavlink.MAVLink_hil_actuator_controls_message)
_ARMED = mavlink.MAV_MODE_FLAG_SAFETY_ARMED


def imu_from_msg(m) -> ImuSample:
    return ImuSample(
        timestamp_us=m.time_usec,
        accel_frd_m_s2=np.array([m.xacc, m.yacc, m.zacc]),
        gyro_frd_rad_s=np.array([m.xgyro, m.ygyro, m.zgyro]),
        mag_frd_gauss=np.array([m.xmag, m.ymag, m.zmag]),
        pressure_hpa=m.abs_pressure,
        temperature_c=m.temperature,
        fields_updated=m.fields_updated,
    )


def gps_from_msg(m) -> GpsSample:
    return GpsSample(
        timestamp_us=m.time_usec,
        fix_type=m.fix_type,
        lat_deg=m.lat * 1e-7,
        lon_deg=m.lon * 1e-7,
        alt_amsl_m=m.alt * 1e-3,
        vel_ned_m_s=np.array([m.vn, m.ve, m.vd]) * 0.01,
        eph_m=m.eph * 0.01 if m.eph != UINT16_MAX else float("nan"),
        epv_m=m.epv * 0.01 if m.epv != UINT16_MAX else float("nan"),
        satellites=m.satellites_visible,
    )


def battery_from_msg(m) -> BatteryState:
    cells = [v for v in m.voltages if v != UINT16_MAX]
    return BatteryState(
        voltage_v=sum(cells) / 1000.0 if cells else float("nan"),
        current_a=m.current_battery / 100.0 if m.current_battery >= 0 else -1.0,
        remaining_frac=m.battery_remaining / 100.0 if m.battery_remaining >= 0 else -1.0,
        cell_count=len(cells) or 4,
        consumed_mah=float(m.current_consumed) if m.current_consumed >= 0 else -1.0,
    )


class SimLink:
    def __init__(self, host: str, port: int, sysid: int = 1, compid: int = 1) -> None:
        self.addr = (host, port)
        self.sysid, self.compid = sysid, compid
        self.sock: socket.socket | None = None
        self.mav = mavlink.MAVLink(None, sysid, compid)  # we send the packed bytes ourselves
        self.mav.robust_parsing = True
        self.parser = StreamParser(self.mav, [mavlink.MAVLink_hil_sensor_message])
        self.pending: list = []

    def connect(self, retry_s: float = 0.2, on_wait=None) -> None:
        """Connect, retrying until the simulator listens; on_wait() is called between tries."""
        warned = False
        while True:
            try:
                s = socket.create_connection(self.addr, timeout=2.0)
                s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
                s.settimeout(None)
                self.sock = s
                self.receiver = SpinReceiver(s)
                self.mav = mavlink.MAVLink(None, self.sysid, self.compid)  # a new link: fresh parser state
                self.mav.robust_parsing = True
                self.parser = StreamParser(self.mav, [mavlink.MAVLink_hil_sensor_message])
                return
            except OSError:
                if not warned:
                    print(f"[autopilot] waiting for the simulator on TCP {self.addr[0]}:{self.addr[1]}", flush=True)
                    warned = True
                if on_wait:
                    on_wait()
                time.sleep(retry_s)

    def receive(self, timeout_s: float | None = None) -> list | None:
        """Messages received (possibly empty on timeout); None when the link closed."""
        if self.pending:
            out, self.pending = self.pending, []
            return out
        try:
            data = self.receiver.recv(65536, timeout_s)
        except socket.timeout:
            return []
        except OSError:
            return None
        if not data:
            return None
        return self.parser.parse(data)

    def send_actuators(self, time_us: int, commands: np.ndarray, armed: bool) -> None:
        controls = [0.0] * 16
        controls[: len(commands)] = commands.tolist()
        self.sock.sendall(_ACTUATORS.encode(self.mav, (time_us, controls, _ARMED if armed else 0, 0)))
