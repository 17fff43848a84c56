"""The MAVLink link to one vehicle: socket, heartbeats, receive loop and waits.

:class:`Connection` wraps one ``pymavlink`` connection (as system 255,
component 190, like QGroundControl and MAVSDK do), sends the ground station's
HEARTBEAT once a second, caches the latest message of each type from the
vehicle (the first autopilot heard, component 1, unless a system id is given: several vehicles
may share one port, as every PX4 instance sends to 14550), joins and collects
STATUSTEXTs, and waits for conditions.  The plugins (:mod:`gcs.plugins`:
telemetry, action, param) are built on it; :class:`gcs.client.VehicleClient`
is a connection with all of them.

Units: timeouts are *wall-clock* seconds (this is a user tool); the vehicle's
clock (``sim_time_s``) is the *simulated* time in seconds, from ``time_boot_ms``.
Nothing here sleeps in a loop: every wait is a blocking ``select`` on the
socket with a short timeout.
"""

from __future__ import annotations

import math
import time
from collections import deque
from typing import Callable, Iterable, Self

from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink2

from mavsim_core.mavlink_signing import SigningState
from mavsim_core.udp_buffers import enlarge_receive_buffer

from .errors import GcsTimeout, NoAnswer, StatusText

mavlink = mavutil.mavlink

GCS_SYSTEM_ID = 255
GCS_COMPONENT_ID = 190  # MAV_COMP_ID_MISSIONPLANNER, what QGroundControl uses
VEHICLE_COMPONENT_ID = 1

DEFAULT_TIMEOUT_S = 10.0
PUMP_TIMEOUT_S = 0.1
STATUSTEXT_CHUNK_LEN = 50  # a chunk this long (no NUL) means more chunks follow
SILENT_NOTE_S = 2.0  # describe() mentions a vehicle silent for longer than this
SILENT_S = 5.0  # a wait that times out after the vehicle has been silent this long: no answer (NoAnswer)


class Connection:
    """A MAVLink link to one vehicle.

    ``url`` is a pymavlink connection string (``udpin:0.0.0.0:14550``,
    ``udpout:127.0.0.1:14550``, ``tcp:127.0.0.1:5760`` ...).  The constructor
    waits up to ``timeout_s`` wall seconds for the vehicle's HEARTBEAT and
    raises :class:`GcsTimeout` if none comes.  ``timeout_s`` is also the
    default for every later wait.

    ``idle`` is called on every receive cycle (about every 0.1 s at most); it may
    raise to abort a wait (the demo uses it to stop when a child process dies).
    ``on_statustext`` is called with each :class:`StatusText` as it arrives.
    ``describe_state`` (set by whoever knows the vehicle's state, e.g. the
    telemetry plugin) returns the leading parts of :meth:`describe`.
    ``signing_key`` (32 bytes): sign everything sent and accept from the vehicle only what is signed
    with it (PX4's few exceptions aside: RADIO_STATUS ...), as the vehicle does once it has the key
    (docs/security.md, :mod:`mavsim_core.mavlink_signing`).
    """

    def __init__(
        self,
        url: str,
        timeout_s: float = DEFAULT_TIMEOUT_S,
        *,
        target_system: int | None = None,
        target_component: int = VEHICLE_COMPONENT_ID,
        wait_heartbeat: bool = True,
        idle: Callable[[], None] | None = None,
        on_statustext: Callable[[StatusText], None] | None = None,
        heartbeat_period_s: float = 1.0,
        signing_key: bytes | None = None,
    ) -> None:
        self.url = url
        self.timeout_s = float(timeout_s)
        # None: the first autopilot heard (its HEARTBEAT from component target_component) is ours
        self._target_system: int | None = target_system
        self.target_component = target_component
        self.idle = idle
        self.on_statustext = on_statustext
        self.heartbeat_period_s = heartbeat_period_s
        self.describe_state: Callable[[], list[str]] | None = None
        self.statustexts: list[StatusText] = []
        self._latest: dict[str, object] = {}
        self._latest_wall: dict[str, float] = {}
        self._listeners: list[Callable[[object], None]] = []
        # Messages that came in the same read as one recv() returned, after it: the next recv()
        # looks at them first (a ground station's datagram can hold several answers).
        self._pending: deque = deque()
        self._chunks: dict[int, tuple[int, str]] = {}
        self._sim_time_ms: int | None = None
        # MAV_PARAM_TYPE of each parameter name answered on this link; filled by the parameter
        # plugin and the parameter download (gcs.plugins.param), kept here so they share it.
        self._param_types: dict[str, int] = {}
        self._last_gcs_heartbeat = -math.inf
        self._last_rx_wall: float | None = None
        self.conn = mavutil.mavlink_connection(
            url, source_system=GCS_SYSTEM_ID, source_component=GCS_COMPONENT_ID, autoreconnect=True
        )
        enlarge_receive_buffer(getattr(self.conn, "port", None))  # pymavlink's UDP socket: telemetry at 30x
        self.signing = SigningState()  # MAVLink 2 signing (set_signing_key); no key: nothing signed or checked
        self.conn.mav.signing = self.signing
        self.signing.set_key(signing_key)
        if wait_heartbeat:
            try:
                self.wait_heartbeat()
            except BaseException:
                self.close()
                raise

    @property
    def target_system(self) -> int:
        """The vehicle's system id; 0 (broadcast) until a vehicle has been heard when none was given."""
        return self._target_system or 0

    # ----------------------------------------------------------------- lifecycle

    def close(self) -> None:
        """Close the connection (idempotent)."""
        conn, self.conn = getattr(self, "conn", None), None
        if conn is not None:
            try:
                conn.close()
            except OSError:
                pass

    def __enter__(self) -> Self:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def wait_heartbeat(self, timeout_s: float | None = None) -> None:
        """Wait for the vehicle's HEARTBEAT (sysid/compid as configured)."""
        try:
            self.wait_until(
                lambda: "HEARTBEAT" in self._latest,
                timeout_s,
                f"a heartbeat from the vehicle (sysid {self._target_system or 'any'}, compid {self.target_component}) "
                f"on {self.url}",
                describe=False,
            )
        except GcsTimeout as exc:
            if not self.signing.enabled:
                raise NoAnswer(str(exc)) from None
            refused = self.signing.refused
            note = f"{refused} messages refused as not signed with it" if refused else "nothing heard, none refused"
            raise NoAnswer(f"{exc} ({note}: has the vehicle this --signing-key?)") from None

    def set_signing_key(self, key: bytes | None) -> None:
        """Sign with ``key`` from now on and accept only what is signed with it (None: no signing)."""
        self.signing.set_key(key)

    # ----------------------------------------------------------------- receiving

    def add_listener(self, callback: Callable[[object], None]) -> None:
        """Call ``callback(msg)`` for every message received from the vehicle."""
        self._listeners.append(callback)

    def remove_listener(self, callback: Callable[[object], None]) -> None:
        """Stop calling a callback added with :meth:`add_listener`."""
        self._listeners.remove(callback)

    def pump(self, timeout_s: float = PUMP_TIMEOUT_S) -> list:
        """Receive and process what arrives within ``timeout_s`` wall seconds.

        Blocks (in ``select``) until the first message or the timeout, then
        drains whatever else is already queued.  Returns the messages received
        from the vehicle, oldest first.  Sends our GCS heartbeat when due.
        """
        self.signing.keep_up_with_clock()  # (a signed packet older than the stream's last is refused)
        self._send_gcs_heartbeat_if_due()
        if self.idle is not None:
            self.idle()
        out = []
        if timeout_s > 0:
            msg = self.conn.recv_match(blocking=True, timeout=timeout_s)
        else:
            msg = self.conn.recv_match(blocking=False)
        while msg is not None:
            if self._handle(msg):
                out.append(msg)
            msg = self.conn.recv_match(blocking=False)
        return out

    def recv(
        self,
        types: str | Iterable[str],
        timeout_s: float | None = None,
        condition: Callable[[object], bool] | None = None,
    ):
        """The next message of the given type(s) from the vehicle (meeting ``condition``), or None."""
        wanted = {types} if isinstance(types, str) else set(types)
        deadline = time.monotonic() + self._timeout(timeout_s)

        def fits(msg) -> bool:
            return msg.get_type() in wanted and (condition is None or condition(msg))

        while self._pending:
            msg = self._pending.popleft()
            if fits(msg):
                return msg
        while True:
            batch = self.pump(min(PUMP_TIMEOUT_S, max(deadline - time.monotonic(), 0.0)))
            for i, msg in enumerate(batch):
                if fits(msg):
                    self._pending.extend(batch[i + 1 :])
                    return msg
            if time.monotonic() >= deadline:
                return None

    def drain(self) -> None:
        """Forget what has arrived so far (it answers earlier requests, not the next one)."""
        self.pump(0.0)
        self._pending.clear()

    def _handle(self, msg) -> bool:
        """Cache one message; True if it came from the vehicle."""
        mtype = msg.get_type()
        if mtype == "BAD_DATA":
            return False
        if mtype.startswith("UNKNOWN_"):
            msg = _in_mavlink2_common(msg)
            mtype = msg.get_type()
        if self._target_system is None and mtype == "HEARTBEAT" and _is_autopilot(msg, self.target_component):
            self._target_system = msg.get_srcSystem()
        if msg.get_srcSystem() != self._target_system or msg.get_srcComponent() != self.target_component:
            return False
        if self._last_rx_wall is None:  # the vehicle is heard: our HEARTBEAT is due at once (on udpin the
            self._last_gcs_heartbeat = -math.inf  # first went nowhere; it must not wait a period to hear us)
        now = time.monotonic()
        self._last_rx_wall = now
        self._latest[mtype] = msg
        self._latest_wall[mtype] = now
        if mtype in ("GLOBAL_POSITION_INT", "ATTITUDE"):
            self._sim_time_ms = msg.time_boot_ms
        elif mtype == "STATUSTEXT":
            self._handle_statustext(msg, now)
        for cb in self._listeners:
            cb(msg)
        return True

    def _handle_statustext(self, msg, now: float) -> None:
        text = msg.text if isinstance(msg.text, str) else msg.text.decode("utf-8", "replace")
        text = text.rstrip("\0")
        chunk_id = getattr(msg, "id", 0) or 0
        if chunk_id:
            # MAVLink 2 multi-chunk statustext: chunks share an id; the last one is shorter than 50.
            _, sofar = self._chunks.get(chunk_id, (msg.severity, ""))
            sofar += text
            if len(text) >= STATUSTEXT_CHUNK_LEN:
                self._chunks[chunk_id] = (msg.severity, sofar)
                return
            self._chunks.pop(chunk_id, None)
            text = sofar
        st = StatusText(msg.severity, text, self.sim_time_s(), now)
        self.statustexts.append(st)
        if self.on_statustext is not None:
            self.on_statustext(st)

    def keep_alive(self) -> None:
        """Send the ground station's HEARTBEAT if its period has passed, without reading anything: for a caller
        that waits on something else for a while (:class:`gcs.launcher.sim_stepper.SimStepper`), so the vehicle
        does not take the silence for a lost data link."""
        self._send_gcs_heartbeat_if_due()

    def _send_gcs_heartbeat_if_due(self) -> None:
        if time.monotonic() - self._last_gcs_heartbeat >= self.heartbeat_period_s:
            self.send_heartbeat()

    def send_heartbeat(self) -> None:
        """Send the ground station's HEARTBEAT now (a client keeping its own clock: a simulated second,
        :class:`gcs.launcher.sim_stepper.SimStepper`); the wall-clock period restarts from here."""
        self._last_gcs_heartbeat = time.monotonic()
        self.conn.mav.heartbeat_send(
            mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, mavlink.MAV_STATE_ACTIVE
        )

    def _timeout(self, timeout_s: float | None) -> float:
        """``timeout_s``, or the connection's default timeout if None (wall seconds)."""
        return self.timeout_s if timeout_s is None else float(timeout_s)

    # ----------------------------------------------------------------- waiting

    def wait_until(
        self,
        predicate: Callable[[], object],
        timeout_s: float | None = None,
        what: str = "a condition",
        *,
        describe: bool = True,
    ):
        """Pump messages until ``predicate()`` is truthy; return its value.

        Raises :class:`GcsTimeout` after ``timeout_s`` wall seconds (default:
        the client's timeout), saying what it was waiting for and, with
        ``describe``, the vehicle's last known state; :class:`NoAnswer` (a GcsTimeout)
        if by then nothing has come from the vehicle for SILENT_S (or the whole wait, if shorter).
        """
        timeout = self._timeout(timeout_s)
        deadline = time.monotonic() + timeout
        while True:
            value = predicate()
            if value:
                return value
            remaining = deadline - time.monotonic()
            if remaining <= 0:
                detail = f" [{self.describe()}]" if describe else ""
                error = NoAnswer if self.silent_s() > min(SILENT_S, timeout) else GcsTimeout
                raise error(f"timed out after {timeout:g} s waiting for {what}{detail}")
            self.pump(min(PUMP_TIMEOUT_S, remaining))

    def wait_sim_time(self, duration_s: float, timeout_s: float | None = None, what: str | None = None) -> float:
        """Wait until ``duration_s`` seconds of *vehicle* (simulated) time have passed; return the end time."""
        self.wait_until(lambda: self.sim_time_s() is not None, timeout_s, "vehicle time")
        end = self.sim_time_s() + duration_s
        self.wait_until(
            lambda: self.sim_time_s() >= end, timeout_s, what or f"{duration_s:g} s of vehicle time to pass"
        )
        return self.sim_time_s()

    def reason_since(self, texts_before: int, grace_s: float = 0.5, about: str | None = None) -> str | None:
        """The latest STATUSTEXT after the first ``texts_before`` (containing ``about``, when given: the name of
        the parameter refused), waiting ``grace_s`` wall s if none yet.

        A vehicle refusing a command or a parameter says why in a STATUSTEXT that
        may arrive just after the answer; another that comes meanwhile ("Home set") is not the reason.
        """

        def latest() -> str | None:
            texts = [t.text for t in self.statustexts[texts_before:] if about is None or about in t.text]
            return texts[-1] if texts else None

        if latest() is None:
            try:
                self.wait_until(lambda: latest() is not None, grace_s, "a reason", describe=False)
            except GcsTimeout:
                return None
        return latest()

    # ----------------------------------------------------------------- what has arrived

    def latest(self, mtype: str):
        """The latest message of a type from the vehicle, or None."""
        return self._latest.get(mtype)

    def age_s(self, mtype: str) -> float | None:
        """Wall seconds since the latest message of a type arrived, or None."""
        t = self._latest_wall.get(mtype)
        return None if t is None else time.monotonic() - t

    def silent_s(self) -> float:
        """Wall seconds since the last message from the vehicle (inf if none yet)."""
        return math.inf if self._last_rx_wall is None else time.monotonic() - self._last_rx_wall

    def sim_time_s(self) -> float | None:
        """Vehicle (simulated) time in seconds, from the latest GLOBAL_POSITION_INT / ATTITUDE."""
        return None if self._sim_time_ms is None else self._sim_time_ms / 1000.0

    def describe(self) -> str:
        """One-line summary of the last known state, for messages and logs."""
        if self._last_rx_wall is None:
            return "nothing received from the vehicle"
        silent = time.monotonic() - self._last_rx_wall
        parts = list(self.describe_state()) if self.describe_state is not None else []
        t = self.sim_time_s()
        if t is not None:
            parts.append(f"t {t:.2f} s")
        if silent > SILENT_NOTE_S:
            parts.append(f"no message for {silent:.1f} s")
        if self.statustexts:
            parts.append(f"last text: {self.statustexts[-1].text!r}")
        return ", ".join(parts)


def _is_autopilot(msg, component: int) -> bool:
    """A vehicle's autopilot HEARTBEAT from ``component`` (not a ground station, not a generic component)."""
    return (
        msg.get_srcComponent() == component
        and msg.type != mavlink.MAV_TYPE_GCS
        and msg.autopilot != mavlink.MAV_AUTOPILOT_INVALID
    )


def _in_mavlink2_common(msg):
    """A message the connection's dialect does not know (pymavlink's MAVLink 1 dialects stop at id 255),
    parsed again with MAVLink 2's common set (PARAM_ERROR 345 ...); the message as it was if that fails."""
    try:
        parsed = mavlink2.MAVLink(None).parse_buffer(bytes(msg.get_msgbuf()))
    except Exception:  # noqa: BLE001 - whatever a damaged frame raises, it stays unknown
        return msg
    return parsed[0] if parsed else msg
