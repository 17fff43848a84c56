"""A small MAVLink ground-station client for a PX4-like vehicle: the facade.

:class:`VehicleClient` is a :class:`~gcs.connection.Connection` (socket,
heartbeats, receive loop, waits) with the plugins :mod:`gcs.plugins` as
attributes, as MAVSDK's ``System`` has them:

- ``client.telemetry`` (:class:`~gcs.plugins.telemetry.Telemetry`): mode, arming, position, battery ...;
- ``client.action`` (:class:`~gcs.plugins.action.Action`): commands, arm, take off, land, go to ...;
- ``client.param`` (:class:`~gcs.plugins.param.Param`): parameter read, set, download.

For convenience every plugin call is also a method of the client
(``client.arm()`` is ``client.action.arm()``); the ``gcs`` CLI, the flight
demo, the tests and the benchmarks use these.  Units: timeouts are wall-clock
seconds, vehicle time simulated seconds, positions metres NED relative to home,
altitudes metres.
"""

from __future__ import annotations

import math
from typing import Any, Callable

from mavsim_core import px4_modes as modes

from .connection import DEFAULT_TIMEOUT_S, Connection, mavlink
from .errors import CommandResult
from .plugins.action import Action
from .plugins.param import Param, VehicleParam
from .plugins.telemetry import Home, Telemetry

__all__ = ["VehicleClient", "mavlink"]


class VehicleClient(Connection):
    """A MAVLink link to one vehicle with the telemetry, action and param plugins.

    Arguments as :class:`~gcs.connection.Connection`: ``url`` a pymavlink
    connection string; the constructor waits up to ``timeout_s`` wall seconds
    for the vehicle's HEARTBEAT (:class:`~gcs.errors.GcsTimeout` if none), and
    ``timeout_s`` is the default of every later wait; ``idle`` is called on
    every receive cycle and may raise to abort a wait; ``on_statustext`` gets
    each :class:`~gcs.errors.StatusText`.
    """

    def __init__(self, url: str, timeout_s: float = DEFAULT_TIMEOUT_S, **options: Any) -> None:
        """``options``: the keyword options of :class:`~gcs.connection.Connection`."""
        super().__init__(url, timeout_s, **options)
        self.telemetry = Telemetry(self)
        self.action = Action(self, self.telemetry)
        self.param = Param(self)
        self.describe_state = self.telemetry.state_parts

    # ----------------------------------------------------------------- telemetry

    def mode(self) -> modes.Px4Mode | None:
        """The current mode table entry, or None (:meth:`Telemetry.mode`)."""
        return self.telemetry.mode()

    def mode_name(self) -> str | None:
        """Canonical mode name from the heartbeat (:meth:`Telemetry.mode_name`)."""
        return self.telemetry.mode_name()

    def armed(self) -> bool:
        """True if the latest heartbeat says armed (:meth:`Telemetry.armed`)."""
        return self.telemetry.armed()

    def prearm_ok(self) -> bool:
        """True if ready to arm (:meth:`Telemetry.prearm_ok`)."""
        return self.telemetry.prearm_ok()

    def wait_mode(self, name: str, timeout_s: float | None = None) -> None:
        """Wait until the heartbeat shows mode ``name`` (:meth:`Telemetry.wait_mode`)."""
        self.telemetry.wait_mode(name, timeout_s)

    def wait_armed(self, armed: bool = True, timeout_s: float | None = None) -> None:
        """Wait until armed (or disarmed) (:meth:`Telemetry.wait_armed`)."""
        self.telemetry.wait_armed(armed, timeout_s)

    def landed_state(self) -> int | None:
        """MAV_LANDED_STATE or None (:meth:`Telemetry.landed_state`)."""
        return self.telemetry.landed_state()

    def on_ground(self) -> bool | None:
        """True on the ground, None if unknown (:meth:`Telemetry.on_ground`)."""
        return self.telemetry.on_ground()

    def relative_alt_m(self) -> float | None:
        """Altitude above home, m (:meth:`Telemetry.relative_alt_m`)."""
        return self.telemetry.relative_alt_m()

    def global_position(self) -> tuple[float, float, float] | None:
        """(lat deg, lon deg, alt AMSL m) (:meth:`Telemetry.global_position`)."""
        return self.telemetry.global_position()

    def position_ned(self) -> tuple[float, float, float] | None:
        """(north, east, down) m from home (:meth:`Telemetry.position_ned`)."""
        return self.telemetry.position_ned()

    def local_position_ned(self) -> tuple[float, float, float] | None:
        """(x, y, z) m from LOCAL_POSITION_NED (:meth:`Telemetry.local_position_ned`)."""
        return self.telemetry.local_position_ned()

    def velocity_ned_m_s(self) -> tuple[float, float, float] | None:
        """(vn, ve, vd) m/s (:meth:`Telemetry.velocity_ned_m_s`)."""
        return self.telemetry.velocity_ned_m_s()

    def ground_speed_m_s(self) -> float | None:
        """Horizontal speed, m/s (:meth:`Telemetry.ground_speed_m_s`)."""
        return self.telemetry.ground_speed_m_s()

    def battery(self) -> tuple[float | None, int | None]:
        """(voltage V, remaining %) (:meth:`Telemetry.battery`)."""
        return self.telemetry.battery()

    def gps(self) -> tuple[int, int] | None:
        """(fix_type, satellites) (:meth:`Telemetry.gps`)."""
        return self.telemetry.gps()

    def home(self) -> Home | None:
        """The latest HOME_POSITION or None (:meth:`Telemetry.home`)."""
        return self.telemetry.home()

    def wait_home(self, timeout_s: float | None = None) -> Home:
        """The home position, requested if needed (:meth:`Telemetry.wait_home`)."""
        return self.telemetry.wait_home(timeout_s)

    def takeoff_done(self, target_m: float | None, tol_m: float = 0.5, still_m_s: float = 0.3) -> bool:
        """In the air at ``target_m`` above home and still (:meth:`Telemetry.takeoff_done`)."""
        return self.telemetry.takeoff_done(target_m, tol_m, still_m_s)

    def landed_and_disarmed(self) -> bool:
        """Disarmed and not in the air (:meth:`Telemetry.landed_and_disarmed`)."""
        return self.telemetry.landed_and_disarmed()

    def arrived(self, north_m: float, east_m: float, radius_m: float = 0.5, speed_m_s: float = 0.5) -> bool:
        """Near (north, east) m from home and slow (:meth:`Telemetry.arrived`)."""
        return self.telemetry.arrived(north_m, east_m, radius_m, speed_m_s)

    # ----------------------------------------------------------------- action

    def command_long(
        self,
        command: int,
        *params: float,
        timeout_s: float | None = None,
        retries: int | None = None,
        timeout: float | None = None,
    ) -> CommandResult:
        """COMMAND_LONG until its COMMAND_ACK (:meth:`Action.command_long`)."""
        return self.action.command_long(command, *params, timeout_s=timeout_s, retries=retries, timeout=timeout)

    def command_int(
        self,
        command: int,
        *params: float,
        frame: int = mavlink.MAV_FRAME_GLOBAL,
        timeout_s: float | None = None,
        retries: int | None = None,
        timeout: float | None = None,
        current: int = 0,
        autocontinue: int = 0,
    ) -> CommandResult:
        """COMMAND_INT until its COMMAND_ACK (:meth:`Action.command_int`)."""
        return self.action.command_int(
            command,
            *params,
            frame=frame,
            timeout_s=timeout_s,
            retries=retries,
            timeout=timeout,
            current=current,
            autocontinue=autocontinue,
        )

    def arm(self, force: bool = False, timeout_s: float | None = None) -> CommandResult:
        """Arm (:meth:`Action.arm`)."""
        return self.action.arm(force, timeout_s)

    def disarm(self, force: bool = False, timeout_s: float | None = None) -> CommandResult:
        """Disarm (:meth:`Action.disarm`)."""
        return self.action.disarm(force, timeout_s)

    def set_mode(self, name: str, timeout_s: float | None = None) -> CommandResult:
        """DO_SET_MODE to a named PX4 mode (:meth:`Action.set_mode`)."""
        return self.action.set_mode(name, timeout_s)

    def hold(self, timeout_s: float | None = None) -> CommandResult:
        """Hold position (:meth:`Action.hold`)."""
        return self.action.hold(timeout_s)

    def takeoff(self, alt_amsl_m: float = math.nan, timeout_s: float | None = None) -> CommandResult:
        """NAV_TAKEOFF to an altitude AMSL, m (:meth:`Action.takeoff`)."""
        return self.action.takeoff(alt_amsl_m, timeout_s)

    def land(self, timeout_s: float | None = None, precision: int = 0) -> CommandResult:
        """NAV_LAND here; ``precision`` 1 opportunistic, 2 required (:meth:`Action.land`)."""
        return self.action.land(timeout_s, precision)

    def return_to_launch(self, timeout_s: float | None = None) -> CommandResult:
        """NAV_RETURN_TO_LAUNCH (:meth:`Action.return_to_launch`)."""
        return self.action.return_to_launch(timeout_s)

    def goto_global(
        self,
        lat_deg: float,
        lon_deg: float,
        alt_amsl_m: float,
        *,
        ground_speed_m_s: float = -1.0,
        yaw_deg: float = math.nan,
        timeout_s: float | None = None,
        frame: int = mavlink.MAV_FRAME_GLOBAL,
    ) -> CommandResult:
        """DO_REPOSITION to (lat, lon, alt AMSL; above home in a relative ``frame``) (:meth:`Action.goto_global`)."""
        return self.action.goto_global(
            lat_deg,
            lon_deg,
            alt_amsl_m,
            ground_speed_m_s=ground_speed_m_s,
            yaw_deg=yaw_deg,
            timeout_s=timeout_s,
            frame=frame,
        )

    def ned_to_global(self, north_m: float, east_m: float, down_rel_home_m: float) -> tuple[float, float, float]:
        """(lat, lon, alt AMSL) of a NED point from home (:meth:`Action.ned_to_global`)."""
        return self.action.ned_to_global(north_m, east_m, down_rel_home_m)

    def goto_ned(
        self,
        north_m: float,
        east_m: float,
        down_rel_home_m: float,
        *,
        ground_speed_m_s: float = -1.0,
        yaw_deg: float = math.nan,
        timeout_s: float | None = None,
    ) -> CommandResult:
        """Fly to metres NED from home and hold (:meth:`Action.goto_ned`)."""
        return self.action.goto_ned(
            north_m, east_m, down_rel_home_m, ground_speed_m_s=ground_speed_m_s, yaw_deg=yaw_deg, timeout_s=timeout_s
        )

    # ----------------------------------------------------------------- param

    def param_get(self, name: str, timeout_s: float | None = None, retries: int | None = None) -> int | float:
        """Read a parameter (:meth:`Param.get`)."""
        return self.param.get(name, timeout_s, retries)

    def param_set(
        self,
        name: str,
        value: float | int,
        param_type: int | None = None,
        timeout_s: float | None = None,
        retries: int | None = None,
    ) -> int | float:
        """Set a parameter; the value the vehicle echoes (:meth:`Param.set`)."""
        return self.param.set(name, value, param_type, timeout_s, retries)

    def param_list(
        self, progress: Callable[[int, int], None] | None = None, timeout_s: float | None = None
    ) -> list[VehicleParam]:
        """Every parameter in index order (:meth:`Param.get_all`)."""
        return self.param.get_all(progress, timeout_s)
