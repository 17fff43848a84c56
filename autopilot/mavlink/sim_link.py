"""The flight controller's side of the simulator link (PX4 simulator MAVLink API).

Connects over TCP to the simulator (4560 + instance), turns HIL_SENSOR and
HIL_GPS into :mod:`autopilot.topics` samples (SI units, FRD/NED as sent; a field whose
``fields_updated`` bit is clear is NaN: that sensor sent nothing), and answers each period with
HIL_ACTUATOR_CONTROLS stamped with the same time.  :meth:`SimLink.request` sends the simulator
another message (a PARAM_SET of the failure injection) and waits for its answer, keeping what else
arrives meanwhile for :meth:`SimLink.receive`.

Handshake: right after the TCP connection is made the flight controller sends a HEARTBEAT (the simulator
serves only a peer that has sent a valid MAVLink message, :mod:`sitl.peer_accept`), and with
``handshake_timeout_s`` it counts as connected only once the simulator's first valid message has
arrived within that time (wall clock); otherwise it closes the socket and connects again, so a port
held by something that accepts and stays silent never passes for the simulator.
"""

from __future__ import annotations

import socket
import time
from typing import Callable

import numpy as np
from pymavlink.dialects.v20 import common as mavlink

from autopilot.topics import BatteryState, GpsSample, ImuSample
from mavsim_core.sim_api_codec import MessageLayout, StreamParser
from mavsim_core.spin_receiver import SpinReceiver

UINT16_MAX = 65535
NAN3 = np.full(3, np.nan)
# HIL_SENSOR fields_updated bits (HIL_SENSOR_UPDATED_FLAGS) of each sensor
ACCEL_FIELDS, GYRO_FIELDS, MAG_FIELDS, PRESSURE_FIELD = 0x007, 0x038, 0x1C0, 0x200
_ACTUATORS = MessageLayout(mavlink.MAVLink_hil_actuator_controls_message)
_ARMED = mavlink.MAV_MODE_FLAG_SAFETY_ARMED
# What the simulator sends by the period, framed by the fast path (mavsim_core/sim_api_codec.py): its sensors, and
# in a landing world the gimbal's attitude (50 Hz) and the camera's LANDING_TARGET (up to 20 Hz), whose pymavlink
# parse cost 25 us a period on the flight controller's critical path (issue 38).  Everything else goes to pymavlink.
FAST_FROM_SIM = (
    mavlink.MAVLink_hil_sensor_message,
    mavlink.MAVLink_hil_gps_message,
    mavlink.MAVLink_battery_status_message,
    mavlink.MAVLink_landing_target_message,
    mavlink.MAVLink_gimbal_device_attitude_status_message,
)
CONNECT_RETRY_S = 0.05  # a refused connection costs microseconds; a stack starts both processes at once
# (gcs/launcher/stack.py), so the flight controller is usually waiting when the simulator begins to listen
WAIT_SLICE_S = 0.02  # while connecting, on_wait() (the ground-station link) runs at 50 Hz of wall time


def imu_from_msg(m) -> ImuSample:
    """The sample of one HIL_SENSOR; the fields of a sensor whose ``fields_updated`` bits are clear are NaN."""
    f = m.fields_updated
    return ImuSample(
        timestamp_us=m.time_usec,
        accel_frd_m_s2=np.array([m.xacc, m.yacc, m.zacc]) if f & ACCEL_FIELDS == ACCEL_FIELDS else NAN3.copy(),
        gyro_frd_rad_s=np.array([m.xgyro, m.ygyro, m.zgyro]) if f & GYRO_FIELDS == GYRO_FIELDS else NAN3.copy(),
        mag_frd_gauss=np.array([m.xmag, m.ymag, m.zmag]) if f & MAG_FIELDS == MAG_FIELDS else NAN3.copy(),
        pressure_hpa=m.abs_pressure if f & PRESSURE_FIELD else float("nan"),
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
        self.parser = StreamParser(self.mav, FAST_FROM_SIM)
        self.pending: list = []  # received during a request(), for the next receive()
        self.closed = False  # the simulator closed the link (seen by a request()): receive() says so next
        self.outbox: list[bytes] = []  # queued messages (queue()), sent just before the next actuator controls
        # Messages of devices on this link (the gimbal's), by type: read by the lockstep loop (link_setup.py)
        self.device_handlers: dict[str, Callable[[mavlink.MAVLink_message], None]] = {}
        # What drives those devices, called with the simulated time (µs) at the ground-station link's scheduled
        # steps only (autopilot/lockstep_loop.py), so what it queues for them is the same in every run
        self.device_steps: list[Callable[[int], None]] = []

    def connect(self, retry_s: float = CONNECT_RETRY_S, on_wait=None, handshake_timeout_s: float | None = None) -> None:
        """Connect and send a HEARTBEAT, retrying until the simulator listens; on_wait() is called between
        tries and while waiting for the simulator's answer.  With ``handshake_timeout_s`` (wall seconds),
        return only once the simulator's first valid message has arrived (kept for :meth:`receive`)."""
        warned = False
        while True:
            try:
                self._open()
            except OSError:
                if not warned:
                    print(f"[autopilot] waiting for the simulator on TCP {self.addr[0]}:{self.addr[1]}", flush=True)
                    warned = True
                self._wait(retry_s, on_wait)
                continue
            if handshake_timeout_s is None or self._answered(handshake_timeout_s, on_wait):
                return
            print(
                f"[autopilot] no MAVLink from TCP {self.addr[0]}:{self.addr[1]} within {handshake_timeout_s:g} s: "
                "not the simulator, or busy; connecting again",
                flush=True,
            )
            self.close()

    @staticmethod
    def _wait(seconds: float, on_wait) -> None:
        """Sleep ``seconds``, calling on_wait() every WAIT_SLICE_S meanwhile (the ground-station link)."""
        end = time.monotonic() + seconds
        while True:
            if on_wait:
                on_wait()
            remaining = end - time.monotonic()
            if remaining <= 0:
                return
            time.sleep(min(WAIT_SLICE_S, remaining))

    def _open(self) -> None:
        """A new TCP connection, fresh parser state, and our HEARTBEAT on it (the simulator's handshake)."""
        s = socket.create_connection(self.addr, timeout=2.0)
        try:
            s.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
            s.settimeout(None)
            self.mav = mavlink.MAVLink(None, self.sysid, self.compid)
            self.mav.robust_parsing = True
            hb = mavlink.MAVLink_heartbeat_message(
                mavlink.MAV_TYPE_GENERIC, mavlink.MAV_AUTOPILOT_PX4, 0, 0, mavlink.MAV_STATE_BOOT, 3
            )
            s.sendall(hb.pack(self.mav))
            self.mav.seq = (self.mav.seq + 1) % 256
        except OSError:
            s.close()
            raise
        self.sock = s
        self.receiver = SpinReceiver(s)
        self.parser = StreamParser(self.mav, FAST_FROM_SIM)
        self.pending, self.closed = [], False

    def _answered(self, timeout_s: float, on_wait) -> bool:
        """Wait up to ``timeout_s`` for the simulator's first valid message (kept in ``pending``)."""
        deadline = time.monotonic() + timeout_s
        while (remaining := deadline - time.monotonic()) > 0:
            msgs = self.receive(timeout_s=min(remaining, WAIT_SLICE_S))
            if msgs is None:
                return False
            valid = [m for m in msgs if m.get_type() != "BAD_DATA"]
            if valid:
                self.pending = valid + self.pending
                return True
            if on_wait:
                on_wait()
        return False

    def close(self) -> None:
        """Close the connection (the next :meth:`receive` says the link closed)."""
        if self.sock is not None:
            self.sock.close()
        self.closed = True

    def receive(self, timeout_s: float | None = None) -> list | None:
        """Messages received (possibly empty on timeout); None when the link closed."""
        if self.pending:
            out, self.pending = self.pending, []
            return out
        if self.closed:
            return None
        try:
            data = self.receiver.recv(65536, timeout_s)
        except socket.timeout:
            return []
        except OSError:
            return None
        if not data:
            return None
        return self.parser.parse(data)

    def queue(self, msg: mavlink.MAVLink_message) -> None:
        """Send ``msg`` with the next actuator controls, just before them: the simulator reads it in the same
        wait for actuators, so it acts from the same step in every run (a gimbal setpoint)."""
        self.outbox.append(msg.pack(self.mav))
        self.mav.seq = (self.mav.seq + 1) % 256

    def send_actuators(self, time_us: int, commands: np.ndarray, armed: bool) -> None:
        """HIL_ACTUATOR_CONTROLS for ``time_us``, after what :meth:`queue` holds."""
        controls = [0.0] * 16
        controls[: len(commands)] = commands.tolist()
        data = _ACTUATORS.encode(self.mav, (time_us, controls, _ARMED if armed else 0, 0))
        if self.outbox:
            data, self.outbox = b"".join(self.outbox) + data, []
        assert self.sock is not None  # (connected before the first sensors)
        self.sock.sendall(data)

    def request(
        self, msg: mavlink.MAVLink_message, answer: Callable[[mavlink.MAVLink_message], bool], timeout_s: float
    ) -> mavlink.MAVLink_message | None:
        """Send ``msg`` to the simulator; the first message received for which ``answer(m)`` is true.

        None when it does not come within ``timeout_s`` (wall clock), or there is no link.  Everything
        else received meanwhile (the next HIL_SENSOR...) is kept, in order, for :meth:`receive`.  The
        simulator answers between two steps (``sitl/link_params.py``), so this takes at most the rest
        of its current step: the lockstep goes on as before.
        """
        if self.sock is None or self.closed:
            return None
        data = msg.pack(self.mav)
        self.mav.seq = (self.mav.seq + 1) % 256
        try:
            self.sock.sendall(data)
        except OSError:
            self.closed = True
            return None
        deadline = time.monotonic() + timeout_s
        while (remaining := deadline - time.monotonic()) > 0:
            try:
                data = self.receiver.recv(65536, remaining)
            except socket.timeout:
                return None
            except OSError:
                data = b""
            if not data:
                self.closed = True
                return None
            found = None
            for m in self.parser.parse(data):
                if found is None and answer(m):
                    found = m
                else:
                    self.pending.append(m)
            if found is not None:
                return found
        return None
