"""Client of the simulator's own MAVLink port: ground truth and ``SIM_*`` parameters.

The simulator sends ground truth (HIL_STATE_QUATERNION and LOCAL_POSITION_NED,
50 Hz of simulated time) and its heartbeat to UDP 14740 + instance (mavsim_core.ports.sim_component_port), and answers
parameter requests on the same link (component 51).  :class:`SimClient` binds
that port, keeps the truth in a background thread, and reads and sets ``SIM_*``
parameters with the MAVLink parameter protocol (C-cast encoding: the simulator
is not PX4, so an INT32 of 3 travels as 3.0), as MAVProxy would.  Truth is NED metres from the simulator's start point.

A simulator held at a simulated time (``SIM_HOLD_MS``, sitl/hold.py) says so with SYSTEM_TIME
(``time_boot_ms`` the hold time, ``time_unix_usec`` 0) after the truth at that time: :meth:`SimClient.wait_held`.
"""

from __future__ import annotations

import queue
import select
import socket
import threading
import time
from dataclasses import dataclass

from pymavlink.dialects.v20 import common as mavlink

from mavsim_core.udp_buffers import enlarge_receive_buffer

SIM_COMPONENT_ID = 51
UGV_COMPONENT_ID = 52  # the ground vehicle's truth (SIM_UGV_EN=1), same system and socket


class SimParamError(RuntimeError):
    """The simulator refused a parameter or did not answer."""


@dataclass(frozen=True)
class TruthSample:
    time_ms: int
    pos_ned_m: tuple[float, float, float]
    vel_ned_m_s: tuple[float, float, float]


@dataclass(frozen=True)
class UgvSample:
    """The UGV's truth: the marker's centre on its deck (NED m from the multicopter's start),
    velocity (NED m/s) and yaw (rad)."""

    time_ms: int
    pos_ned_m: tuple[float, float, float]
    vel_ned_m_s: tuple[float, float, float]
    yaw_rad: float


def _nearest(table: dict, time_ms: int, within_ms: int):
    """The entry of ``table`` (keyed by simulated ms) nearest ``time_ms``, if one is within ``within_ms``."""
    for dt in sorted(range(-within_ms, within_ms + 1), key=abs):
        if time_ms + dt in table:
            return table[time_ms + dt]
    return None


class SimClient:
    """Ground truth and SIM_* parameters of one simulator instance."""

    def __init__(self, port: int, host: str = "127.0.0.1") -> None:
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind((host, port))
        enlarge_receive_buffer(self.sock)  # 50 Hz truth at full speed: nothing lost while the reader is busy
        self.sock.settimeout(0.2)
        self.mav = mavlink.MAVLink(None, 254, 190)
        self.mav.robust_parsing = True
        self.sim_addr: tuple[str, int] | None = None
        self.positions: dict[int, TruthSample] = {}
        self.latest_state = None  # HIL_STATE_QUATERNION
        self.gimbal_truth = None  # GIMBAL_DEVICE_ATTITUDE_STATUS: the camera's attitude -> NED (a gimballed camera)
        self.states: dict[int, object] = {}  # HIL_STATE_QUATERNION by simulated time, ms
        self.lock = threading.Lock()
        self.param_values: queue.Queue = queue.Queue()
        self.statustexts: list[str] = []
        self.ugv: dict[int, UgvSample] = {}  # the ground vehicle's truth by simulated time, ms
        self._ugv_yaw = 0.0
        self._types: dict[str, int] = {}
        self.held_ms: int | None = None  # the latest "held at" report (SYSTEM_TIME), simulated ms
        self._drained = 0  # how many times the reader found its socket empty after reading (caught_up)
        self._held = threading.Condition(self.lock)
        self._stop = threading.Event()
        self.thread = threading.Thread(target=self._run, name="sim-client", daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            if not select.select([self.sock], [], [], 0)[0]:  # nothing waiting: what has come is read
                with self._held:
                    self._drained += 1
                    self._held.notify_all()
            try:
                data, addr = self.sock.recvfrom(65536)
            except OSError:
                continue
            try:
                msgs = self.mav.parse_buffer(data) or []
            except mavlink.MAVError:
                continue
            for msg in msgs:
                if msg.get_srcComponent() == UGV_COMPONENT_ID:
                    self._on_ugv(msg)
                    continue
                if msg.get_type() == "GIMBAL_DEVICE_ATTITUDE_STATUS":  # the camera's true attitude (earth frame)
                    self.gimbal_truth = msg
                    continue
                if msg.get_srcComponent() != SIM_COMPONENT_ID:
                    continue
                self.sim_addr = addr
                kind = msg.get_type()
                if kind == "LOCAL_POSITION_NED":
                    with self.lock:
                        self.positions[msg.time_boot_ms] = TruthSample(
                            msg.time_boot_ms, (msg.x, msg.y, msg.z), (msg.vx, msg.vy, msg.vz)
                        )
                elif kind == "HIL_STATE_QUATERNION":
                    with self.lock:
                        self.latest_state = msg
                        self.states[msg.time_usec // 1000] = msg
                elif kind == "PARAM_VALUE":
                    self.param_values.put(msg)
                elif kind == "SYSTEM_TIME" and msg.time_unix_usec == 0:  # held at this time (sitl/hold.py)
                    with self._held:
                        self.held_ms = msg.time_boot_ms
                        self._held.notify_all()
                elif kind == "STATUSTEXT":
                    self.statustexts.append(msg.text)

    def _on_ugv(self, msg) -> None:
        kind = msg.get_type()
        if kind == "ATTITUDE":
            self._ugv_yaw = msg.yaw
        elif kind == "LOCAL_POSITION_NED":
            sample = UgvSample(msg.time_boot_ms, (msg.x, msg.y, msg.z), (msg.vx, msg.vy, msg.vz), self._ugv_yaw)
            with self.lock:
                self.ugv[msg.time_boot_ms] = sample

    def ugv_latest(self) -> UgvSample | None:
        """The UGV's latest truth (None: no UGV in the world, or nothing received yet)."""
        with self.lock:
            return self.ugv[max(self.ugv)] if self.ugv else None

    def ugv_at(self, time_ms: int, within_ms: int = 10) -> UgvSample | None:
        """The UGV's truth nearest this simulated time, if one is within ``within_ms``."""
        with self.lock:
            return _nearest(self.ugv, time_ms, within_ms)

    # -- truth -------------------------------------------------------------------------
    def at(self, time_ms: int, within_ms: int = 10) -> TruthSample | None:
        """The truth sample nearest this simulated time, if one is within ``within_ms``."""
        with self.lock:
            return _nearest(self.positions, time_ms, within_ms)

    def state_at(self, time_ms: int, within_ms: int = 10):
        """The HIL_STATE_QUATERNION nearest this simulated time (attitude quaternion FRD->NED, body rates)."""
        with self.lock:
            return _nearest(self.states, time_ms, within_ms)

    def latest(self) -> TruthSample | None:
        with self.lock:
            return self.positions[max(self.positions)] if self.positions else None

    def since(self, time_ms: int) -> list[TruthSample]:
        """Truth samples from this simulated time on, in time order."""
        with self.lock:
            return [self.positions[t] for t in sorted(self.positions) if t >= time_ms]

    def wait_held(self, at_least_ms: int, timeout_s: float) -> int:
        """Wait until the simulator reports it holds at ``at_least_ms`` (simulated ms) or later; that time.
        Its truth at that time has arrived by then (sent before the report).  SimParamError on timeout."""
        deadline = time.monotonic() + timeout_s
        with self._held:
            while self.held_ms is None or self.held_ms < at_least_ms:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    raise SimParamError(f"the simulator did not hold at t = {at_least_ms / 1000:g} s")
                self._held.wait(remaining)
            return self.held_ms

    def caught_up(self, timeout_s: float = 60.0) -> int:
        """The latest truth time (simulated ms) once the reader has read everything that had arrived when this
        was called.  On a loaded machine the reader can be seconds of simulated time behind what the simulator
        sent (its socket holds them), so ``latest()`` is not "now": a wait of simulated time counted from it
        could end before a command sent just now had any effect.  SimParamError after ``timeout_s``."""
        deadline = time.monotonic() + timeout_s
        with self._held:
            seen = self._drained + 1  # (the next one may come from a look at the socket made before this call)
            while self._drained <= seen:
                remaining = deadline - time.monotonic()
                if remaining <= 0:
                    raise SimParamError("the truth reader did not catch up")
                self._held.wait(remaining)
        sample = self.latest()
        return sample.time_ms if sample is not None else 0

    def now(self, timeout_s: float = 60.0) -> TruthSample | None:
        """The latest truth sample once the reader has caught up (:meth:`caught_up`): the state "now", after an
        event a client saw (landed, disarmed), where ``latest()`` may still be from before it."""
        self.caught_up(timeout_s)
        return self.latest()

    # -- parameters ----------------------------------------------------------------------
    def _send(self, msg) -> None:
        if self.sim_addr is None:
            raise SimParamError("no heartbeat or truth from the simulator yet")
        self.sock.sendto(msg.pack(self.mav), self.sim_addr)

    def _wait_value(self, name: str, timeout_s: float):
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline:
            try:
                msg = self.param_values.get(timeout=max(0.01, deadline - time.monotonic()))
            except queue.Empty:
                break
            if msg.param_id == name:
                self._types[name] = msg.param_type
                return msg
        raise SimParamError(f"no PARAM_VALUE for {name} from the simulator")

    @staticmethod
    def _value(msg) -> int | float:
        """A PARAM_VALUE's value: int for integer types, float for REAL32 (C-cast encoding)."""
        return msg.param_value if msg.param_type == mavlink.MAV_PARAM_TYPE_REAL32 else int(msg.param_value)

    def wait_connected(self, timeout_s: float = 30.0) -> None:
        deadline = time.monotonic() + timeout_s
        while self.sim_addr is None:
            if time.monotonic() > deadline:
                raise SimParamError("no message from the simulator")
            time.sleep(0.05)

    def get(self, name: str, timeout_s: float = 5.0) -> int | float:
        """Read a parameter (PARAM_REQUEST_READ by name)."""
        for _ in range(3):
            self._send(mavlink.MAVLink_param_request_read_message(0, SIM_COMPONENT_ID, name.encode(), -1))
            try:
                msg = self._wait_value(name, timeout_s / 3)
            except SimParamError:
                continue
            return self._value(msg)
        raise SimParamError(f"no answer reading {name}")

    def set(self, name: str, value: float, timeout_s: float = 5.0) -> int | float:
        """Set a parameter; return the value the simulator now holds; raise if it refused."""
        if name not in self._types:
            self.get(name, timeout_s)
        ptype = self._types[name]
        self._send(mavlink.MAVLink_param_set_message(0, SIM_COMPONENT_ID, name.encode(), float(value), ptype))
        msg = self._wait_value(name, timeout_s)
        got = self._value(msg)
        if abs(float(got) - float(value)) > 1e-6 * max(1.0, abs(float(value))):
            reason = self.statustexts[-1] if self.statustexts else "no reason given"
            raise SimParamError(f"{name} = {value} refused (still {got}): {reason}")
        return got

    def close(self) -> None:
        self._stop.set()
        self.thread.join(timeout=2)
        self.sock.close()

    def __enter__(self) -> "SimClient":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
