"""A hostile sender on the network: junk datagrams at a paced rate to a flight controller's UDP port.

Used by ``tests/test_e2e_link_abuse.py`` and ``benchmarks/flood_benchmark.py``.  The junk
(:func:`junk_datagrams`) is what anyone on the network can send, one MAVLink packet (or none) per
datagram, in five kinds taken in turn:

* ``random``: random bytes (not MAVLink: damage);
* ``foreign``: CRC-valid COMMAND_LONG (arm), SET_MODE and PARAM_SET addressed to another system;
* ``heartbeat``: CRC-valid HEARTBEATs of ground stations with other system ids;
* ``param_read``: CRC-valid PARAM_REQUEST_READs addressed to the vehicle (each one is answered);
* ``command``: CRC-valid COMMAND_LONGs addressed to the vehicle's system, for a component it does not
  have (parsed, then ignored: a command flood costs the vehicle as much as a real one).

:class:`Flood` sends them from a process of its own (so the sender does not share an interpreter
with the test's clients), paced in ``TICK_S`` slices of the wall clock; ``sent`` says how many went
out, so a caller reports the rate it really produced.  :class:`GroundStation` is the pilot on the
flooded port: LAND and the like sent by the MAVLink command protocol (one resend after RETRY_S),
COMMAND_ACKs, the vehicle's mode and the simulated clock noted by a thread of its own.
"""

from __future__ import annotations

import multiprocessing as mp
import random
import socket
import threading
import time

from pymavlink.dialects.v20 import common as mavlink

KINDS = ("random", "foreign", "heartbeat", "param_read", "command")
TICK_S = 0.002  # the sender's pacing slice: rate * TICK_S datagrams per slice
GCS_SYSID = 255  # the ground station's system id (GroundStation)
RETRY_S = 0.5  # MAVSDK resends a command after 0.5 s without its COMMAND_ACK
PARAM_TIMEOUT_S = 30.0  # wall seconds a parameter read or set is resent for (a safety net: the answer is asserted)
POOL = 4000  # distinct datagrams, sent in turn
PARAM_NAMES = (b"MPC_XY_P", b"MC_ROLLRATE_P", b"MIS_TAKEOFF_ALT", b"NO_SUCH_PARAM")


def junk_datagrams(target_sysid: int, n: int = POOL, kinds: tuple[str, ...] = KINDS, seed: int = 1) -> list[bytes]:
    """``n`` junk datagrams for a vehicle of system id ``target_sysid``, the ``kinds`` taken in turn."""
    rng = random.Random(seed)
    other = (target_sysid + 100) % 250 + 1  # a system that is not the vehicle
    out = []
    for k in range(n):
        kind = kinds[k % len(kinds)]
        enc = mavlink.MAVLink(None, rng.randint(100, 250), rng.randint(1, 200))
        enc.seq = rng.randint(0, 255)
        if kind == "random":
            data = bytes(rng.getrandbits(8) for _ in range(rng.randint(6, 80)))
        elif kind == "foreign":
            msg = rng.choice(
                (
                    mavlink.MAVLink_command_long_message(
                        other, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0
                    ),
                    mavlink.MAVLink_set_mode_message(other, 1, 0),
                    mavlink.MAVLink_param_set_message(other, 1, b"MC_ROLLRATE_P", 0.0, mavlink.MAV_PARAM_TYPE_REAL32),
                )
            )
            data = msg.pack(enc)
        elif kind == "heartbeat":
            data = mavlink.MAVLink_heartbeat_message(
                mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3
            ).pack(enc)
        elif kind == "param_read":
            data = mavlink.MAVLink_param_request_read_message(target_sysid, 1, rng.choice(PARAM_NAMES), -1).pack(enc)
        elif kind == "command":
            land = mavlink.MAV_CMD_NAV_LAND
            data = mavlink.MAVLink_command_long_message(target_sysid, 99, land, 0, 0, 0, 0, 0, 0, 0, 0).pack(enc)
        else:
            raise ValueError(f"unknown junk kind {kind!r}; kinds: {KINDS}")
        out.append(data)
    return out


def _send_loop(dest: tuple[str, int], pool: list[bytes], rate_hz: mp.Value, sent: mp.Value, stop: mp.Event) -> None:
    """The sender process: ``rate_hz`` datagrams per wall second (0: idle) until ``stop``."""
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    sock.setblocking(False)
    i, count, owed = 0, 0, 0.0
    last = time.perf_counter()
    while not stop.is_set():
        now = time.perf_counter()
        owed = min(owed + (now - last) * rate_hz.value, rate_hz.value * 0.05)  # no catch-up burst past 50 ms
        last = now
        while owed >= 1.0:
            try:
                sock.sendto(pool[i], dest)
                count += 1
            except OSError:  # the kernel's buffers are full: the datagram is lost, as on a real network
                pass
            i = (i + 1) % len(pool)
            owed -= 1.0
        sent.value = count
        time.sleep(TICK_S)
    sock.close()


class Flood:
    """Junk to ``dest`` from a process of its own; ``rate_hz`` settable while it runs; ``sent`` so far.

    Use as a context manager (the process ends on leaving)."""

    def __init__(self, dest: tuple[str, int], target_sysid: int, kinds: tuple[str, ...] = KINDS) -> None:
        ctx = mp.get_context("spawn")  # (no fork: the callers run client threads)
        self._rate = ctx.Value("d", 0.0)
        self._sent = ctx.Value("q", 0)
        self._stop = ctx.Event()
        pool = junk_datagrams(target_sysid, kinds=kinds)
        self._proc = ctx.Process(target=_send_loop, args=(dest, pool, self._rate, self._sent, self._stop), daemon=True)

    @property
    def rate_hz(self) -> float:
        return self._rate.value

    @rate_hz.setter
    def rate_hz(self, value: float) -> None:
        self._rate.value = float(value)

    @property
    def pid(self) -> int | None:
        return self._proc.pid

    @property
    def sent(self) -> int:
        return int(self._sent.value)

    def __enter__(self) -> "Flood":
        self._proc.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        self._proc.join(timeout=5.0)
        if self._proc.is_alive():
            self._proc.kill()


class GroundStation:
    """A ground station on the stack's ground-station port (the one flooded): a thread receives, notes
    COMMAND_ACKs (by the echoed source component), the vehicle's HEARTBEATs, PARAM_VALUEs, STATUSTEXTs
    and the simulated clock, and sends a GCS HEARTBEAT every second (times: wall, perf_counter)."""

    def __init__(self, port: int, sysid: int) -> None:
        self.sysid = sysid
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("0.0.0.0", port))
        self.sock.settimeout(0.1)
        self.fc_addr: tuple[str, int] | None = None
        self.acks: dict[tuple[int, int], tuple[float, int]] = {}  # (command, component) -> (wall s, result)
        self.heartbeats: list[tuple[float, int, int]] = []  # (wall s, base_mode, custom_mode)
        self.params: list[tuple[float, str, float]] = []  # (wall s, name, value) of PARAM_VALUE
        self.texts: list[str] = []  # STATUSTEXT
        self.sim_clock: list[tuple[float, int]] = []  # (wall s, time_boot_ms)
        # The latest time_boot_ms of any message, and each HEARTBEAT stamped with the one before it (the link's own
        # order: a HEARTBEAT's simulated time, within the 1 Hz SYSTEM_TIME's period, whatever this reader's pace)
        self.latest_sim_ms = 0
        self.heartbeat_sim_ms: list[int] = []
        self.running = True
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        parser = mavlink.MAVLink(None)
        parser.robust_parsing = True
        beat = mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0, 3)
        encoder, next_beat = mavlink.MAVLink(None, GCS_SYSID, 190), 0.0
        while self.running:
            now = time.perf_counter()
            if self.fc_addr is not None and now >= next_beat:
                self.sock.sendto(beat.pack(encoder), self.fc_addr)
                next_beat = now + 1.0
            try:
                data, addr = self.sock.recvfrom(65536)
            except (socket.timeout, OSError):
                continue
            now = time.perf_counter()
            for msg in parser.parse_buffer(data) or []:
                if msg.get_srcSystem() != self.sysid:
                    continue
                mtype = msg.get_type()
                stamp = getattr(msg, "time_boot_ms", None)
                if stamp is not None:
                    self.latest_sim_ms = max(self.latest_sim_ms, stamp)
                if mtype == "COMMAND_ACK" and msg.target_system == GCS_SYSID:
                    self.acks.setdefault((msg.command, msg.target_component), (now, msg.result))
                elif mtype == "ATTITUDE":
                    self.sim_clock.append((now, msg.time_boot_ms))
                elif mtype == "HEARTBEAT" and msg.get_srcComponent() == 1:
                    self.fc_addr = addr
                    self.heartbeats.append((now, msg.base_mode, msg.custom_mode))
                    self.heartbeat_sim_ms.append(self.latest_sim_ms)
                elif mtype == "PARAM_VALUE":
                    self.params.append((now, msg.param_id, msg.param_value))
                elif mtype == "STATUSTEXT":
                    self.texts.append(msg.text)

    def send(self, msg: mavlink.MAVLink_message, compid: int) -> float:
        """``msg`` from (GCS_SYSID, compid), one datagram; the wall time of the send."""
        data = msg.pack(mavlink.MAVLink(None, GCS_SYSID, compid))
        t = time.perf_counter()
        self.sock.sendto(data, self.fc_addr)
        return t

    def command(self, command: int, params: tuple[float, ...], compid: int) -> tuple[int, float | None, int | None]:
        """COMMAND_LONG, resent once (confirmation 1) after RETRY_S: (attempts, latency s or None, result)."""
        self.acks.pop((command, compid), None)
        first = None
        for attempt in range(2):
            msg = mavlink.MAVLink_command_long_message(self.sysid, 1, command, attempt, *params)
            t = self.send(msg, compid)
            first = t if first is None else first
            while time.perf_counter() < t + RETRY_S:
                ack = self.acks.get((command, compid))
                if ack is not None:
                    return attempt + 1, ack[0] - first, ack[1]
                time.sleep(0.002)
        return 2, None, None

    def sim_speed(self, since: float, until: float) -> float:
        """Simulated seconds per wall second between two wall times (ATTITUDE)."""
        pts = [p for p in self.sim_clock if since <= p[0] <= until]
        if len(pts) < 2 or pts[-1][0] <= pts[0][0]:
            return float("nan")
        return (pts[-1][1] - pts[0][1]) / 1000.0 / (pts[-1][0] - pts[0][0])

    def mode_since(self, since: float) -> int | None:
        """The custom_mode of the latest HEARTBEAT received after wall time ``since`` (None: none yet)."""
        return next((m for t, _, m in reversed(self.heartbeats) if t >= since), None)

    def armed(self) -> bool | None:
        """Armed, by the latest HEARTBEAT (None before the first)."""
        return bool(self.heartbeats[-1][1] & mavlink.MAV_MODE_FLAG_SAFETY_ARMED) if self.heartbeats else None

    def param_set(self, name: str, value: float) -> float | None:
        """PARAM_SET (REAL32), resent every RETRY_S until PARAM_TIMEOUT_S: the value the vehicle echoes, None if
        none came."""
        real32 = mavlink.MAV_PARAM_TYPE_REAL32
        return self._param(mavlink.MAVLink_param_set_message(self.sysid, 1, name.encode(), value, real32), name)

    def param_get(self, name: str) -> float | None:
        """PARAM_REQUEST_READ, resent every RETRY_S until PARAM_TIMEOUT_S: the value, None if no PARAM_VALUE
        came."""
        return self._param(mavlink.MAVLink_param_request_read_message(self.sysid, 1, name.encode(), -1), name)

    def _param(self, msg: mavlink.MAVLink_message, name: str) -> float | None:
        # What the tests read is the value, not how fast it came: one resend (a second of wall time) was not
        # enough beside a second suite (the eighth flake hunt: no answer to a PARAM_SET in a hover at 5x).
        deadline = time.perf_counter() + PARAM_TIMEOUT_S
        while time.perf_counter() < deadline:
            t = self.send(msg, 190)
            while time.perf_counter() < t + RETRY_S:
                value = next((v for w, n, v in reversed(self.params) if w >= t and n == name), None)
                if value is not None:
                    return value
                time.sleep(0.002)
        return None

    def close(self) -> None:
        self.running = False
        self._thread.join(timeout=1.0)
        self.sock.close()
