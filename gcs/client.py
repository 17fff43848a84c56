"""A small MAVLink ground-station client for a PX4-like vehicle.

:class:`VehicleClient` wraps one ``pymavlink`` connection (as system 255,
component 190, like QGroundControl and MAVSDK do), caches the latest message of
each type from the vehicle (sysid 1, compid 1 unless told otherwise), collects
STATUSTEXTs and offers the command, mode, parameter and waiting helpers the
``gcs`` CLI and the flight demo are built from.

Units: timeouts are *wall-clock* seconds (this is a user tool); the vehicle's
clock (``sim_time_s``) is the *simulated* time in seconds, from ``time_boot_ms``.
Positions are metres NED relative to the home position, altitudes metres.
Nothing here sleeps in a loop: every wait is a blocking ``select`` on the
socket with a short timeout.
"""

from __future__ import annotations

import math
import struct
from collections import deque
import sys
import time
from dataclasses import dataclass
from typing import Callable, Iterable

from pymavlink import mavutil

from mavsim_core import param_encoding
from params import param_file

from mavsim_core import px4_modes as modes

from . import geo

mavlink = mavutil.mavlink

GCS_SYSTEM_ID = 255
GCS_COMPONENT_ID = 190  # MAV_COMP_ID_MISSIONPLANNER, what QGroundControl uses
VEHICLE_SYSTEM_ID = 1
VEHICLE_COMPONENT_ID = 1

MAV_SYS_STATUS_PREARM_CHECK = 0x10000000
ARM_FORCE_MAGIC = 21196.0  # COMPONENT_ARM_DISARM param2: skip checks / force disarm

DEFAULT_TIMEOUT_S = 10.0
PUMP_TIMEOUT_S = 0.1

LANDED_STATE_NAMES = {0: "UNDEFINED", 1: "ON_GROUND", 2: "IN_AIR", 3: "TAKEOFF", 4: "LANDING"}
GPS_FIX_NAMES = {0: "NO_GPS", 1: "NO_FIX", 2: "2D", 3: "3D", 4: "DGPS", 5: "RTK_FLOAT", 6: "RTK_FIXED",
                 7: "STATIC", 8: "PPP"}


# --------------------------------------------------------------------------- errors


class GcsError(Exception):
    """Base class of the errors this client raises."""


class GcsTimeout(GcsError):
    """Something did not happen within its (wall-clock) timeout; the message says what."""


class CommandRefused(GcsError):
    """The vehicle answered a command with a result other than ACCEPTED."""

    def __init__(self, result: "CommandResult") -> None:
        super().__init__(result.describe())
        self.result = result


class ParamRefused(GcsError):
    """A PARAM_SET was not applied (the vehicle echoed another value)."""


# --------------------------------------------------------------------------- small records


def command_name(command: int) -> str:
    """``MAV_CMD_NAV_TAKEOFF`` for 22, or ``MAV_CMD_<n>`` if unknown."""
    entry = mavlink.enums["MAV_CMD"].get(command)
    return entry.name if entry is not None else f"MAV_CMD_{command}"


def result_name(result: int) -> str:
    """``DENIED`` for MAV_RESULT_DENIED (the MAV_RESULT name without prefix)."""
    entry = mavlink.enums["MAV_RESULT"].get(result)
    name = entry.name if entry is not None else f"MAV_RESULT_{result}"
    return name.removeprefix("MAV_RESULT_")


@dataclass(frozen=True)
class StatusText:
    """One STATUSTEXT from the vehicle (chunks already joined)."""

    severity: int  # MAV_SEVERITY: 0 emergency .. 7 debug
    text: str
    sim_time_s: float | None  # vehicle time when it arrived, if known
    wall_time_s: float  # time.monotonic() when it arrived

    @property
    def severity_name(self) -> str:
        entry = mavlink.enums["MAV_SEVERITY"].get(self.severity)
        return entry.name.removeprefix("MAV_SEVERITY_") if entry is not None else str(self.severity)


@dataclass(frozen=True)
class CommandResult:
    """The outcome of a COMMAND_LONG / COMMAND_INT: the ACK result and, on refusal, the reason."""

    command: int
    result: int  # MAV_RESULT
    reason: str | None = None  # text of the latest STATUSTEXT received with a refusal

    @property
    def accepted(self) -> bool:
        return self.result == mavlink.MAV_RESULT_ACCEPTED

    @property
    def command_name(self) -> str:
        return command_name(self.command)

    @property
    def result_name(self) -> str:
        return result_name(self.result)

    def describe(self) -> str:
        text = f"{self.command_name}: {self.result_name}"
        if self.reason:
            text += f" ({self.reason})"
        return text

    def check(self) -> "CommandResult":
        """Return self if accepted, else raise :class:`CommandRefused`."""
        if not self.accepted:
            raise CommandRefused(self)
        return self


@dataclass(frozen=True)
class Home:
    """The vehicle's home position (HOME_POSITION)."""

    lat_deg: float
    lon_deg: float
    alt_amsl_m: float


# --------------------------------------------------------------------------- client


class VehicleClient:
    """A MAVLink link to one vehicle.

    ``url`` is a pymavlink connection string (``udpin:0.0.0.0:14550``,
    ``udpout:127.0.0.1:14550``, ``tcp:127.0.0.1:5760`` ...).  The constructor
    waits up to ``timeout_s`` wall seconds for the vehicle's HEARTBEAT and
    raises :class:`GcsTimeout` if none comes.  ``timeout_s`` is also the
    default for every later wait.

    ``idle`` is called on every receive cycle (about every 0.1 s at most); it may
    raise to abort a wait (the demo uses it to stop when a child process dies).
    ``on_statustext`` is called with each :class:`StatusText` as it arrives.
    """

    def __init__(
        self,
        url: str,
        timeout_s: float = DEFAULT_TIMEOUT_S,
        *,
        target_system: int = VEHICLE_SYSTEM_ID,
        target_component: int = VEHICLE_COMPONENT_ID,
        wait_heartbeat: bool = True,
        idle: Callable[[], None] | None = None,
        on_statustext: Callable[[StatusText], None] | None = None,
        heartbeat_period_s: float = 1.0,
    ) -> None:
        self.url = url
        self.timeout_s = float(timeout_s)
        self.target_system = target_system
        self.target_component = target_component
        self.idle = idle
        self.on_statustext = on_statustext
        self.heartbeat_period_s = heartbeat_period_s
        self.statustexts: list[StatusText] = []
        self._latest: dict[str, object] = {}
        self._latest_wall: dict[str, float] = {}
        self._listeners: list[Callable[[object], None]] = []
        # Messages that came in the same read as one recv() returned, after it: the next recv()
        # looks at them first (a ground station's datagram can hold several answers).
        self._pending: deque = deque()
        self._chunks: dict[int, tuple[int, str]] = {}
        self._sim_time_ms: int | None = None
        self._param_types: dict[str, int] = {}
        self._last_gcs_heartbeat = -math.inf
        self._last_rx_wall: float | None = None
        self.conn = mavutil.mavlink_connection(
            url, source_system=GCS_SYSTEM_ID, source_component=GCS_COMPONENT_ID, autoreconnect=True
        )
        if wait_heartbeat:
            try:
                self.wait_heartbeat()
            except BaseException:
                self.close()
                raise

    # ----------------------------------------------------------------- lifecycle

    def close(self) -> None:
        """Close the connection (idempotent)."""
        conn, self.conn = getattr(self, "conn", None), None
        if conn is not None:
            try:
                conn.close()
            except OSError:
                pass

    def __enter__(self) -> "VehicleClient":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def wait_heartbeat(self, timeout_s: float | None = None) -> None:
        """Wait for the vehicle's HEARTBEAT (sysid/compid as configured)."""
        self.wait_until(
            lambda: "HEARTBEAT" in self._latest,
            timeout_s,
            f"a heartbeat from the vehicle (sysid {self.target_system}, compid {self.target_component}) "
            f"on {self.url}",
            describe=False,
        )

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

    def recv(self, types: str | Iterable[str], timeout_s: float | None = None,
             condition: Callable[[object], bool] | None = None):
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
                    self._pending.extend(batch[i + 1:])
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
        if msg.get_srcSystem() != self.target_system or msg.get_srcComponent() != self.target_component:
            return False
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
            if len(text) >= 50:
                self._chunks[chunk_id] = (msg.severity, sofar)
                return
            self._chunks.pop(chunk_id, None)
            text = sofar
        st = StatusText(msg.severity, text, self.sim_time_s(), now)
        self.statustexts.append(st)
        if self.on_statustext is not None:
            self.on_statustext(st)

    def _send_gcs_heartbeat_if_due(self) -> None:
        now = time.monotonic()
        if now - self._last_gcs_heartbeat >= self.heartbeat_period_s:
            self._last_gcs_heartbeat = now
            self.conn.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0,
                                         mavlink.MAV_STATE_ACTIVE)

    def _timeout(self, timeout_s: float | None) -> float:
        return self.timeout_s if timeout_s is None else float(timeout_s)

    # ----------------------------------------------------------------- waiting

    def wait_until(self, predicate: Callable[[], object], timeout_s: float | None = None,
                   what: str = "a condition", *, describe: bool = True):
        """Pump messages until ``predicate()`` is truthy; return its value.

        Raises :class:`GcsTimeout` after ``timeout_s`` wall seconds (default:
        the client's timeout), saying what it was waiting for and, with
        ``describe``, the vehicle's last known state.
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
                raise GcsTimeout(f"timed out after {timeout:g} s waiting for {what}{detail}")
            self.pump(min(PUMP_TIMEOUT_S, remaining))

    def wait_sim_time(self, duration_s: float, timeout_s: float | None = None, what: str | None = None) -> float:
        """Wait until ``duration_s`` seconds of *vehicle* (simulated) time have passed; return the end time."""
        self.wait_until(lambda: self.sim_time_s() is not None, timeout_s, "vehicle time")
        end = self.sim_time_s() + duration_s
        self.wait_until(lambda: self.sim_time_s() >= end, timeout_s,
                        what or f"{duration_s:g} s of vehicle time to pass")
        return self.sim_time_s()

    def wait_mode(self, name: str, timeout_s: float | None = None) -> None:
        """Wait until the heartbeat shows mode ``name`` (any accepted spelling)."""
        target = modes.lookup_mode(name)
        self.wait_until(lambda: self.mode() == target, timeout_s, f"mode {target.name}")

    def wait_armed(self, armed: bool = True, timeout_s: float | None = None) -> None:
        """Wait until the heartbeat shows the vehicle armed (or disarmed)."""
        self.wait_until(lambda: self.armed() == armed, timeout_s, "armed" if armed else "disarmed")

    # ----------------------------------------------------------------- state accessors

    def latest(self, mtype: str):
        """The latest message of a type from the vehicle, or None."""
        return self._latest.get(mtype)

    def age_s(self, mtype: str) -> float | None:
        """Wall seconds since the latest message of a type arrived, or None."""
        t = self._latest_wall.get(mtype)
        return None if t is None else time.monotonic() - t

    def sim_time_s(self) -> float | None:
        """Vehicle (simulated) time in seconds, from the latest GLOBAL_POSITION_INT / ATTITUDE."""
        return None if self._sim_time_ms is None else self._sim_time_ms / 1000.0

    def mode(self) -> modes.Px4Mode | None:
        """The current mode table entry, or None if unknown / no heartbeat."""
        hb = self._latest.get("HEARTBEAT")
        if hb is None or not hb.base_mode & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            return None
        return modes.mode_from_custom_mode(hb.custom_mode)

    def mode_name(self) -> str | None:
        """Canonical mode name (``LOITER``, ``POSCTL`` ...) decoded from the heartbeat's custom_mode."""
        hb = self._latest.get("HEARTBEAT")
        if hb is None:
            return None
        return modes.custom_mode_to_name(hb.custom_mode)

    def armed(self) -> bool:
        """True if the latest heartbeat has MAV_MODE_FLAG_SAFETY_ARMED."""
        hb = self._latest.get("HEARTBEAT")
        return bool(hb is not None and hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)

    def prearm_ok(self) -> bool:
        """True if SYS_STATUS reports the pre-arm check healthy (ready to arm)."""
        st = self._latest.get("SYS_STATUS")
        return bool(st is not None and st.onboard_control_sensors_health & MAV_SYS_STATUS_PREARM_CHECK)

    def landed_state(self) -> int | None:
        """MAV_LANDED_STATE from EXTENDED_SYS_STATE (1 on ground, 2 in air, 3 takeoff, 4 landing) or None."""
        ess = self._latest.get("EXTENDED_SYS_STATE")
        return None if ess is None else ess.landed_state

    def on_ground(self) -> bool | None:
        """True if landed_state is ON_GROUND, None if unknown."""
        state = self.landed_state()
        if state is None or state == mavlink.MAV_LANDED_STATE_UNDEFINED:
            return None
        return state == mavlink.MAV_LANDED_STATE_ON_GROUND

    def relative_alt_m(self) -> float | None:
        """Altitude above home, m (GLOBAL_POSITION_INT.relative_alt)."""
        gpi = self._latest.get("GLOBAL_POSITION_INT")
        return None if gpi is None else gpi.relative_alt / 1000.0

    def global_position(self) -> tuple[float, float, float] | None:
        """(lat deg, lon deg, alt AMSL m) from GLOBAL_POSITION_INT."""
        gpi = self._latest.get("GLOBAL_POSITION_INT")
        if gpi is None:
            return None
        return geo.e7_to_deg(gpi.lat), geo.e7_to_deg(gpi.lon), gpi.alt / 1000.0

    def position_ned(self) -> tuple[float, float, float] | None:
        """(north, east, down) m relative to home, or None until position and home are known.

        From GLOBAL_POSITION_INT and HOME_POSITION with the flat-earth helper
        (the same one :meth:`goto_ned` uses), so targets and positions agree.
        """
        pos = self.global_position()
        home = self.home()
        if pos is None or home is None:
            return None
        n, e, _ = geo.global_to_ned(home.lat_deg, home.lon_deg, home.alt_amsl_m, *pos)
        return n, e, -self.relative_alt_m()

    def local_position_ned(self) -> tuple[float, float, float] | None:
        """(x, y, z) m from LOCAL_POSITION_NED (estimator origin, not necessarily home)."""
        lp = self._latest.get("LOCAL_POSITION_NED")
        return None if lp is None else (lp.x, lp.y, lp.z)

    def velocity_ned_m_s(self) -> tuple[float, float, float] | None:
        """(vn, ve, vd) m/s from GLOBAL_POSITION_INT."""
        gpi = self._latest.get("GLOBAL_POSITION_INT")
        return None if gpi is None else (gpi.vx / 100.0, gpi.vy / 100.0, gpi.vz / 100.0)

    def ground_speed_m_s(self) -> float | None:
        """Horizontal speed, m/s (GLOBAL_POSITION_INT, else VFR_HUD)."""
        vel = self.velocity_ned_m_s()
        if vel is not None:
            return math.hypot(vel[0], vel[1])
        hud = self._latest.get("VFR_HUD")
        return None if hud is None else float(hud.groundspeed)

    def battery(self) -> tuple[float | None, int | None]:
        """(voltage V, remaining %) from BATTERY_STATUS, else SYS_STATUS; None where unknown."""
        volts = pct = None
        bs = self._latest.get("BATTERY_STATUS")
        if bs is not None:
            cells = [v for v in bs.voltages if v != 65535]
            if cells:
                volts = sum(cells) / 1000.0
            pct = bs.battery_remaining if bs.battery_remaining >= 0 else None
        st = self._latest.get("SYS_STATUS")
        if st is not None:
            if volts is None and st.voltage_battery not in (0, 65535):
                volts = st.voltage_battery / 1000.0
            if pct is None and st.battery_remaining >= 0:
                pct = st.battery_remaining
        return volts, pct

    def gps(self) -> tuple[int, int] | None:
        """(fix_type, satellites_visible) from GPS_RAW_INT, or None."""
        g = self._latest.get("GPS_RAW_INT")
        return None if g is None else (g.fix_type, g.satellites_visible)

    def home(self) -> Home | None:
        """The latest HOME_POSITION, or None if none received yet."""
        hp = self._latest.get("HOME_POSITION")
        if hp is None:
            return None
        return Home(geo.e7_to_deg(hp.latitude), geo.e7_to_deg(hp.longitude), hp.altitude / 1000.0)

    def wait_home(self, timeout_s: float | None = None) -> Home:
        """The home position, waiting for (and if needed requesting) HOME_POSITION."""
        if self.home() is None:
            self._request_message(mavlink.MAVLINK_MSG_ID_HOME_POSITION)
        return self.wait_until(self.home, timeout_s, "HOME_POSITION")

    def _request_message(self, msg_id: int) -> None:
        """Fire-and-forget MAV_CMD_REQUEST_MESSAGE (the ACK, if any, is ignored)."""
        self.conn.mav.command_long_send(self.target_system, self.target_component,
                                        mavlink.MAV_CMD_REQUEST_MESSAGE, 0, msg_id, 0, 0, 0, 0, 0, 0)

    # ----------------------------------------------------------------- flight conditions

    def takeoff_done(self, target_m: float | None, tol_m: float = 0.5, still_m_s: float = 0.3) -> bool:
        """True once armed, in the air and no longer climbing, within ``tol_m`` of ``target_m`` above home.

        With no known target (None): above 1 m and vertical speed below ``still_m_s`` m/s.
        """
        alt, vel = self.relative_alt_m(), self.velocity_ned_m_s()
        if alt is None or vel is None or not self.armed() or self.on_ground() is True:
            return False
        if target_m is not None and abs(alt - target_m) > tol_m:
            return False
        if target_m is None and alt < 1.0:
            return False
        return abs(vel[2]) < still_m_s

    def landed_and_disarmed(self) -> bool:
        """True when disarmed and (if the vehicle reports a landed state) on the ground."""
        return not self.armed() and self.on_ground() is not False

    def arrived(self, north_m: float, east_m: float, radius_m: float = 0.5, speed_m_s: float = 0.5) -> bool:
        """Within ``radius_m`` horizontally of (north, east) m from home and slower than ``speed_m_s``."""
        pos, gs = self.position_ned(), self.ground_speed_m_s()
        if pos is None or gs is None:
            return False
        return math.hypot(pos[0] - north_m, pos[1] - east_m) < radius_m and gs < speed_m_s

    def describe(self) -> str:
        """One-line summary of the last known state, for messages and logs."""
        parts = []
        if self._last_rx_wall is None:
            return "nothing received from the vehicle"
        silent = time.monotonic() - self._last_rx_wall
        parts.append(f"mode {self.mode_name() or '?'}")
        parts.append("armed" if self.armed() else "disarmed")
        state = self.landed_state()
        if state is not None:
            parts.append(LANDED_STATE_NAMES.get(state, str(state)).lower().replace("_", " "))
        alt = self.relative_alt_m()
        if alt is not None:
            parts.append(f"alt {alt:.2f} m")
        t = self.sim_time_s()
        if t is not None:
            parts.append(f"t {t:.2f} s")
        if silent > 2.0:
            parts.append(f"no message for {silent:.1f} s")
        if self.statustexts:
            parts.append(f"last text: {self.statustexts[-1].text!r}")
        return ", ".join(parts)

    # ----------------------------------------------------------------- commands

    def command_long(self, command: int, *params: float, timeout_s: float | None = None,
                     retries: int = 3, timeout: float | None = None) -> CommandResult:
        """Send COMMAND_LONG (up to 7 params, missing ones 0) until its COMMAND_ACK arrives.

        Resends up to ``retries`` times (confirmation 0, 1, 2 ...) within
        ``timeout_s`` (``timeout`` is an alias).  Returns the result; on
        refusal it carries the latest STATUSTEXT (the vehicle's reason).
        Raises :class:`GcsTimeout` if no ACK comes at all.
        """
        p = self._params(params, 7)

        def send(attempt: int) -> None:
            self.conn.mav.command_long_send(self.target_system, self.target_component, command,
                                            min(attempt, 255), *p)

        return self._command(command, send, timeout_s if timeout is None else timeout, retries)

    def command_int(self, command: int, *params: float, frame: int = mavlink.MAV_FRAME_GLOBAL,
                    timeout_s: float | None = None, retries: int = 3, timeout: float | None = None,
                    current: int = 0, autocontinue: int = 0) -> CommandResult:
        """Send COMMAND_INT: params are p1, p2, p3, p4, x (int, e.g. degE7), y (int), z (float).

        Same retry and result behaviour as :meth:`command_long`.
        """
        p = self._params(params, 7)
        x, y = int(p[4]), int(p[5])

        def send(attempt: int) -> None:
            self.conn.mav.command_int_send(self.target_system, self.target_component, frame, command,
                                           current, autocontinue, p[0], p[1], p[2], p[3], x, y, p[6])

        return self._command(command, send, timeout_s if timeout is None else timeout, retries)

    @staticmethod
    def _params(params: tuple, n: int) -> list[float]:
        if len(params) > n:
            raise ValueError(f"at most {n} parameters, got {len(params)}")
        return [float(v) for v in params] + [0.0] * (n - len(params))

    def _command(self, command: int, send: Callable[[int], None], timeout_s: float | None,
                 retries: int) -> CommandResult:
        timeout = self._timeout(timeout_s)
        retries = max(1, retries)
        texts_before = len(self.statustexts)
        start = time.monotonic()
        ack = None
        for attempt in range(retries):
            send(attempt)
            attempt_deadline = start + timeout * (attempt + 1) / retries
            while ack is None or ack.result == mavlink.MAV_RESULT_IN_PROGRESS:
                if ack is not None:  # IN_PROGRESS: the vehicle is working on it, keep listening
                    attempt_deadline = start + timeout
                remaining = attempt_deadline - time.monotonic()
                if remaining <= 0:
                    break
                msg = self.recv("COMMAND_ACK", remaining, lambda m: m.command == command)
                if msg is not None:
                    ack = msg
            if ack is not None and ack.result != mavlink.MAV_RESULT_IN_PROGRESS:
                break
            if time.monotonic() >= start + timeout:
                break
        if ack is None or ack.result == mavlink.MAV_RESULT_IN_PROGRESS:
            state = "only IN_PROGRESS" if ack is not None else "no COMMAND_ACK"
            raise GcsTimeout(f"timed out after {timeout:g} s waiting for the vehicle to acknowledge "
                             f"{command_name(command)} ({state} after {retries} attempt(s)) [{self.describe()}]")
        reason = None
        if ack.result != mavlink.MAV_RESULT_ACCEPTED:
            reason = self._refusal_reason(texts_before)
        return CommandResult(command, ack.result, reason)

    def _refusal_reason(self, texts_before: int, grace_s: float = 0.5) -> str | None:
        """The latest STATUSTEXT since the command was sent, waiting briefly if none yet."""
        if len(self.statustexts) == texts_before:
            try:
                self.wait_until(lambda: len(self.statustexts) > texts_before, grace_s, "a reason",
                                describe=False)
            except GcsTimeout:
                return None
        return self.statustexts[-1].text

    # ----------------------------------------------------------------- command helpers

    def arm(self, force: bool = False, timeout_s: float | None = None) -> CommandResult:
        """COMPONENT_ARM_DISARM(1); ``force`` skips the pre-arm checks (param2 = 21196)."""
        return self.command_long(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1, ARM_FORCE_MAGIC if force else 0,
                                 timeout_s=timeout_s)

    def disarm(self, force: bool = False, timeout_s: float | None = None) -> CommandResult:
        """COMPONENT_ARM_DISARM(0); ``force`` disarms even in flight (param2 = 21196)."""
        return self.command_long(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, ARM_FORCE_MAGIC if force else 0,
                                 timeout_s=timeout_s)

    def set_mode(self, name: str, timeout_s: float | None = None) -> CommandResult:
        """MAV_CMD_DO_SET_MODE to a named PX4 mode (any accepted spelling; does not wait for the heartbeat)."""
        mode = modes.lookup_mode(name)
        return self.command_long(mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
                                 mode.main, mode.sub, timeout_s=timeout_s)

    def takeoff(self, alt_amsl_m: float = math.nan, timeout_s: float | None = None) -> CommandResult:
        """NAV_TAKEOFF to an altitude AMSL, m (NaN: the vehicle's MIS_TAKEOFF_ALT above home)."""
        nan = math.nan
        return self.command_long(mavlink.MAV_CMD_NAV_TAKEOFF, nan, 0, 0, nan, nan, nan, alt_amsl_m,
                                 timeout_s=timeout_s)

    def land(self, timeout_s: float | None = None) -> CommandResult:
        """NAV_LAND where the vehicle is (yaw, lat, lon, alt NaN = keep current)."""
        nan = math.nan
        return self.command_long(mavlink.MAV_CMD_NAV_LAND, 0, 0, 0, nan, nan, nan, nan, timeout_s=timeout_s)

    def return_to_launch(self, timeout_s: float | None = None) -> CommandResult:
        """NAV_RETURN_TO_LAUNCH."""
        return self.command_long(mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH, timeout_s=timeout_s)

    def goto_global(self, lat_deg: float, lon_deg: float, alt_amsl_m: float, *, ground_speed_m_s: float = -1.0,
                    yaw_deg: float = math.nan, timeout_s: float | None = None) -> CommandResult:
        """DO_REPOSITION (as COMMAND_INT, MAV_FRAME_GLOBAL, degE7) with the change-mode flag: fly there and hold."""
        return self.command_int(
            mavlink.MAV_CMD_DO_REPOSITION, ground_speed_m_s, mavlink.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, 0,
            yaw_deg, geo.deg_to_e7(lat_deg), geo.deg_to_e7(lon_deg), alt_amsl_m,
            frame=mavlink.MAV_FRAME_GLOBAL, timeout_s=timeout_s)

    def ned_to_global(self, north_m: float, east_m: float, down_rel_home_m: float) -> tuple[float, float, float]:
        """(lat deg, lon deg, alt AMSL m) of a NED point relative to home (waits for home)."""
        home = self.wait_home()
        return geo.ned_to_global(home.lat_deg, home.lon_deg, home.alt_amsl_m, north_m, east_m, down_rel_home_m)

    def goto_ned(self, north_m: float, east_m: float, down_rel_home_m: float, *, ground_speed_m_s: float = -1.0,
                 yaw_deg: float = math.nan, timeout_s: float | None = None) -> CommandResult:
        """Fly to a point given in metres NED relative to home (down negative = above home) and hold there."""
        lat, lon, alt = self.ned_to_global(north_m, east_m, down_rel_home_m)
        return self.goto_global(lat, lon, alt, ground_speed_m_s=ground_speed_m_s, yaw_deg=yaw_deg,
                                timeout_s=timeout_s)

    # ----------------------------------------------------------------- parameters

    def param_get(self, name: str, timeout_s: float | None = None, retries: int = 3) -> int | float:
        """Read a parameter (PARAM_REQUEST_READ): int for INT32, float for REAL32.

        Raises :class:`GcsTimeout` if the vehicle does not answer (e.g. unknown name).
        """
        name_b = self._param_id(name)
        msg = self._param_exchange(
            name, lambda: self.conn.mav.param_request_read_send(self.target_system, self.target_component,
                                                                name_b, -1),
            timeout_s, retries, f"PARAM_VALUE for {name} (unknown parameter?)")
        return self._decode_param_value(msg)

    def param_set(self, name: str, value: float | int, param_type: int | None = None,
                  timeout_s: float | None = None, retries: int = 3) -> int | float:
        """Set a parameter (PARAM_SET) and return the value the vehicle echoes.

        ``param_type`` is a MAV_PARAM_TYPE (6 INT32, 9 REAL32); if omitted the
        parameter is read first to learn it.  Integers are sent byte-wise
        encoded, as PX4 expects.  Raises :class:`ParamRefused` if the echoed
        value differs (the vehicle kept the old one), with its STATUSTEXT reason.
        """
        name_b = self._param_id(name)
        if param_type is None:
            if name not in self._param_types:
                self.param_get(name, timeout_s)
            param_type = self._param_types[name]
        raw = param_encoding.encode_param_bytes(value, param_type)
        self.drain()  # older PARAM_VALUEs and STATUSTEXTs must not pass for this set's answer
        texts_before = len(self.statustexts)
        msg = self._param_exchange(name, lambda: self._send_param_set(name_b, raw, param_type), timeout_s, retries,
                                   f"PARAM_VALUE echo for {name}")
        want = param_encoding.decode_param_bytes(raw, param_type)

        def matches(m) -> bool:
            v = self._decode_param_value(m)
            return v == want or (isinstance(v, float) and math.isnan(v) and math.isnan(want))

        got = self._decode_param_value(msg)
        if not matches(msg):
            # A refusal comes with a STATUSTEXT (in the same datagram as the echo); without one this
            # was a late answer to an earlier request (another station's change, a read), and the
            # echo of this set follows.
            if len(self.statustexts) == texts_before:
                later = self.recv(("PARAM_VALUE", "STATUSTEXT"), 1.0,
                                  lambda m: m.get_type() == "STATUSTEXT" or
                                  (self._text(m.param_id) == name and matches(m)))
                if later is not None and later.get_type() == "PARAM_VALUE":
                    return self._decode_param_value(later)
            reason = self._refusal_reason(texts_before)
            because = f" ({reason})" if reason else ""
            kept = param_file.format_value(got, param_type if param_encoding.is_integer_type(param_type) else None)
            raise ParamRefused(f"{name} not set to {value!r}: vehicle kept {kept}{because}")
        return got

    def param_list(self, progress: Callable[[int, int], None] | None = None, timeout_s: float | None = None):
        """Every parameter of the vehicle in index order (list of ``gcs.param_download.VehicleParam``).

        PARAM_REQUEST_LIST, then PARAM_REQUEST_READ by index for any missing, as
        QGroundControl does; ``progress(received, count)`` follows the download.
        See :func:`gcs.param_download.download_parameters` for the errors.
        """
        from .param_download import download_parameters

        return download_parameters(self, progress, timeout_s)

    @staticmethod
    def _param_id(name: str) -> bytes:
        name_b = name.encode("ascii")
        if not name_b or len(name_b) > 16:
            raise ValueError(f"parameter name must be 1..16 characters: {name!r}")
        return name_b

    def _param_exchange(self, name: str, send: Callable[[], None], timeout_s: float | None, retries: int,
                        what: str):
        timeout = self._timeout(timeout_s)
        retries = max(1, retries)
        for _ in range(retries):
            self.drain()  # a PARAM_VALUE queued before the request is not its answer
            send()
            msg = self.recv("PARAM_VALUE", timeout / retries, lambda m: self._text(m.param_id) == name)
            if msg is not None:
                self._param_types[name] = msg.param_type
                return msg
        raise GcsTimeout(f"timed out after {timeout:g} s waiting for {what} [{self.describe()}]")

    def _send_param_set(self, name_b: bytes, raw: bytes, param_type: int) -> None:
        """PARAM_SET with the exact 4 value bytes (a Python float would alter signalling-NaN patterns)."""
        dialect = sys.modules[type(self.conn.mav).__module__]
        msg = dialect.MAVLink_param_set_message(self.target_system, self.target_component, name_b, 0.0, param_type)
        payload = raw + struct.pack("<BB16sB", self.target_system, self.target_component, name_b, param_type)
        msg.pack = lambda mav, force_mavlink1=False: msg._pack(mav, msg.crc_extra, payload,
                                                               force_mavlink1=force_mavlink1)
        self.conn.mav.send(msg)

    @staticmethod
    def _decode_param_value(msg) -> int | float:
        """int for integer types (byte-wise), float for REAL32."""
        if not param_encoding.is_integer_type(msg.param_type):
            return msg.param_value
        return param_encoding.decode_param_bytes(param_encoding.raw_param_value(msg), msg.param_type)

    @staticmethod
    def _text(value) -> str:
        return value.decode("ascii", "replace").rstrip("\0") if isinstance(value, (bytes, bytearray)) else value
