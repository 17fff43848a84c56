"""Telemetry plugin: the vehicle's state as the latest messages tell it.

Read-only views of what the :class:`~gcs.connection.Connection` has cached
(HEARTBEAT, SYS_STATUS, EXTENDED_SYS_STATE, GLOBAL_POSITION_INT,
LOCAL_POSITION_NED, VFR_HUD, BATTERY_STATUS, GPS_RAW_INT, HOME_POSITION), the
flight conditions the CLI and the demo wait for, and the waits on mode and
arming.  Positions are metres NED relative to the home position, altitudes
metres, speeds m/s; ``None`` means not known yet.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from mavsim_core import px4_modes as modes

from ..connection import Connection, mavlink
from ..geo import e7_to_deg, global_to_ned

MAV_SYS_STATUS_PREARM_CHECK = 0x10000000
UINT16_UNKNOWN = 65535  # BATTERY_STATUS.voltages / SYS_STATUS.voltage_battery: no value

LANDED_STATE_NAMES = {0: "UNDEFINED", 1: "ON_GROUND", 2: "IN_AIR", 3: "TAKEOFF", 4: "LANDING"}
GPS_FIX_NAMES = {
    0: "NO_GPS",
    1: "NO_FIX",
    2: "2D",
    3: "3D",
    4: "DGPS",
    5: "RTK_FLOAT",
    6: "RTK_FIXED",
    7: "STATIC",
    8: "PPP",
}


@dataclass(frozen=True)
class Home:
    """The vehicle's home position (HOME_POSITION): degrees and metres AMSL."""

    lat_deg: float
    lon_deg: float
    alt_amsl_m: float


class Telemetry:
    """The vehicle's state from one connection's latest messages."""

    def __init__(self, link: Connection) -> None:
        self.link = link

    # ----------------------------------------------------------------- mode and arming

    def mode(self) -> modes.Px4Mode | None:
        """The current mode table entry, or None if unknown / no heartbeat."""
        hb = self.link.latest("HEARTBEAT")
        if hb is None or not hb.base_mode & mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED:
            return None
        return modes.mode_from_custom_mode(hb.custom_mode)

    def mode_name(self) -> str | None:
        """Canonical mode name (``LOITER``, ``POSCTL`` ...) decoded from the heartbeat's custom_mode."""
        hb = self.link.latest("HEARTBEAT")
        if hb is None:
            return None
        return modes.custom_mode_to_name(hb.custom_mode)

    def armed(self) -> bool:
        """True if the latest heartbeat has MAV_MODE_FLAG_SAFETY_ARMED."""
        hb = self.link.latest("HEARTBEAT")
        return bool(hb is not None and hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)

    def prearm_ok(self) -> bool:
        """True if SYS_STATUS reports the pre-arm check healthy (ready to arm)."""
        st = self.link.latest("SYS_STATUS")
        return bool(st is not None and st.onboard_control_sensors_health & MAV_SYS_STATUS_PREARM_CHECK)

    def wait_mode(self, name: str, timeout_s: float | None = None) -> None:
        """Wait until the heartbeat shows mode ``name`` (any accepted spelling)."""
        target = modes.lookup_mode(name)
        self.link.wait_until(lambda: self.mode() == target, timeout_s, f"mode {target.name}")

    def wait_armed(self, armed: bool = True, timeout_s: float | None = None) -> None:
        """Wait until the heartbeat shows the vehicle armed (or disarmed)."""
        self.link.wait_until(lambda: self.armed() == armed, timeout_s, "armed" if armed else "disarmed")

    # ----------------------------------------------------------------- landed state

    def landed_state(self) -> int | None:
        """MAV_LANDED_STATE from EXTENDED_SYS_STATE (1 on ground, 2 in air, 3 takeoff, 4 landing) or None."""
        ess = self.link.latest("EXTENDED_SYS_STATE")
        return None if ess is None else ess.landed_state

    def on_ground(self) -> bool | None:
        """True if landed_state is ON_GROUND, None if unknown."""
        state = self.landed_state()
        if state is None or state == mavlink.MAV_LANDED_STATE_UNDEFINED:
            return None
        return state == mavlink.MAV_LANDED_STATE_ON_GROUND

    # ----------------------------------------------------------------- position and velocity

    def relative_alt_m(self) -> float | None:
        """Altitude above home, m (GLOBAL_POSITION_INT.relative_alt)."""
        gpi = self.link.latest("GLOBAL_POSITION_INT")
        return None if gpi is None else gpi.relative_alt / 1000.0

    def global_position(self) -> tuple[float, float, float] | None:
        """(lat deg, lon deg, alt AMSL m) from GLOBAL_POSITION_INT."""
        gpi = self.link.latest("GLOBAL_POSITION_INT")
        if gpi is None:
            return None
        return e7_to_deg(gpi.lat), e7_to_deg(gpi.lon), gpi.alt / 1000.0

    def position_ned(self) -> tuple[float, float, float] | None:
        """(north, east, down) m relative to home, or None until position and home are known.

        From GLOBAL_POSITION_INT and HOME_POSITION with the flat-earth helper
        (the same one the action plugin's ``goto_ned`` uses), so targets and positions agree.
        """
        pos = self.global_position()
        home = self.home()
        if pos is None or home is None:
            return None
        n, e, _ = global_to_ned(home.lat_deg, home.lon_deg, home.alt_amsl_m, *pos)
        return n, e, -self.relative_alt_m()

    def local_position_ned(self) -> tuple[float, float, float] | None:
        """(x, y, z) m from LOCAL_POSITION_NED (estimator origin, not necessarily home)."""
        lp = self.link.latest("LOCAL_POSITION_NED")
        return None if lp is None else (lp.x, lp.y, lp.z)

    def velocity_ned_m_s(self) -> tuple[float, float, float] | None:
        """(vn, ve, vd) m/s from GLOBAL_POSITION_INT."""
        gpi = self.link.latest("GLOBAL_POSITION_INT")
        return None if gpi is None else (gpi.vx / 100.0, gpi.vy / 100.0, gpi.vz / 100.0)

    def ground_speed_m_s(self) -> float | None:
        """Horizontal speed, m/s (GLOBAL_POSITION_INT, else VFR_HUD)."""
        vel = self.velocity_ned_m_s()
        if vel is not None:
            return math.hypot(vel[0], vel[1])
        hud = self.link.latest("VFR_HUD")
        return None if hud is None else float(hud.groundspeed)

    # ----------------------------------------------------------------- battery, GPS, home

    def battery(self) -> tuple[float | None, int | None]:
        """(voltage V, remaining %) from BATTERY_STATUS, else SYS_STATUS; None where unknown."""
        volts = pct = None
        bs = self.link.latest("BATTERY_STATUS")
        if bs is not None:
            cells = [v for v in bs.voltages if v != UINT16_UNKNOWN]
            if cells:
                volts = sum(cells) / 1000.0
            pct = bs.battery_remaining if bs.battery_remaining >= 0 else None
        st = self.link.latest("SYS_STATUS")
        if st is not None:
            if volts is None and st.voltage_battery not in (0, UINT16_UNKNOWN):
                volts = st.voltage_battery / 1000.0
            if pct is None and st.battery_remaining >= 0:
                pct = st.battery_remaining
        return volts, pct

    def gps(self) -> tuple[int, int] | None:
        """(fix_type, satellites_visible) from GPS_RAW_INT, or None."""
        g = self.link.latest("GPS_RAW_INT")
        return None if g is None else (g.fix_type, g.satellites_visible)

    def home(self) -> Home | None:
        """The latest HOME_POSITION, or None if none received yet."""
        hp = self.link.latest("HOME_POSITION")
        if hp is None:
            return None
        return Home(e7_to_deg(hp.latitude), e7_to_deg(hp.longitude), hp.altitude / 1000.0)

    def wait_home(self, timeout_s: float | None = None) -> Home:
        """The home position, waiting for (and if needed requesting) HOME_POSITION."""
        if self.home() is None:
            self.request_message(mavlink.MAVLINK_MSG_ID_HOME_POSITION)
        return self.link.wait_until(self.home, timeout_s, "HOME_POSITION")

    def request_message(self, msg_id: int) -> None:
        """Fire-and-forget MAV_CMD_REQUEST_MESSAGE (the ACK, if any, is ignored)."""
        link = self.link
        link.conn.mav.command_long_send(
            link.target_system, link.target_component, mavlink.MAV_CMD_REQUEST_MESSAGE, 0, msg_id, 0, 0, 0, 0, 0, 0
        )

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

    def state_parts(self) -> list[str]:
        """Mode, arming, landed state and altitude as short phrases (the start of ``Connection.describe``)."""
        parts = [f"mode {self.mode_name() or '?'}", "armed" if self.armed() else "disarmed"]
        state = self.landed_state()
        if state is not None:
            parts.append(LANDED_STATE_NAMES.get(state, str(state)).lower().replace("_", " "))
        alt = self.relative_alt_m()
        if alt is not None:
            parts.append(f"alt {alt:.2f} m")
        return parts
