"""Action plugin: commands to the vehicle and what they answer.

The COMMAND_LONG / COMMAND_INT exchange of the MAVLink command protocol: the command is sent
again with ``confirmation`` incremented each time a try's ACK_TRY_S passes without its
COMMAND_ACK (MAVSDK's per-try timeout), until an ACK comes or the caller's timeout has passed;
a refusal carries the vehicle's STATUSTEXT reason.  An action that the telemetry can confirm
(armed, mode) also ends when the vehicle is seen doing it, so a lost ACK does not fail a command
the vehicle carried out.  On top: arm, disarm, set mode, take off, land, return to launch, hold
and go to a point (DO_REPOSITION).  Altitudes are metres AMSL unless the name says otherwise,
positions degrees or metres NED relative to home; timeouts wall seconds.
"""

from __future__ import annotations

import math
import time
from typing import Callable

from mavsim_core import px4_modes as modes

from ..connection import Connection, mavlink
from ..errors import CommandResult, GcsTimeout, NoAnswer, command_name
from ..geo import deg_to_e7, ned_to_global
from .telemetry import Telemetry

ARM_FORCE_MAGIC = 21196.0  # COMPONENT_ARM_DISARM param2: skip checks / force disarm
COMMAND_PARAMS = 7  # COMMAND_LONG param1..7; COMMAND_INT p1..p4, x, y, z
ACK_TRY_S = 0.5  # wall seconds a try waits for its COMMAND_ACK before the command goes again (as MAVSDK)
Effect = Callable[[], bool]  # True once the telemetry shows the command carried out


class Action:
    """Commands over one connection; ``telemetry`` gives the home position for NED targets."""

    def __init__(self, link: Connection, telemetry: Telemetry) -> None:
        self.link = link
        self.telemetry = telemetry

    # ----------------------------------------------------------------- the command protocol

    def command_long(
        self,
        command: int,
        *params: float,
        timeout_s: float | None = None,
        retries: int | None = None,
        timeout: float | None = None,
        effect: Effect | None = None,
    ) -> CommandResult:
        """Send COMMAND_LONG (up to 7 params, missing ones 0) until its COMMAND_ACK arrives.

        Sent again every ACK_TRY_S without an ACK (confirmation 0, 1, 2 ...), at most ``retries``
        times in all (None: as often as ``timeout_s`` allows; ``timeout`` is an alias), listening
        until ``timeout_s`` has passed.  Returns the result; on refusal it carries the latest
        STATUSTEXT (the vehicle's reason).  ``effect()`` true after a try went unanswered: the
        vehicle did it, the result is ACCEPTED with ``acknowledged`` False.  Raises
        :class:`NoAnswer` if neither an ACK nor the effect comes.
        """
        p = _padded(params, COMMAND_PARAMS)
        link = self.link

        def send(attempt: int) -> None:
            link.conn.mav.command_long_send(link.target_system, link.target_component, command, min(attempt, 255), *p)

        return self._command(command, send, timeout_s if timeout is None else timeout, retries, effect)

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
        """Send COMMAND_INT: params are p1, p2, p3, p4, x (int, e.g. degE7), y (int), z (float).

        Same retry and result behaviour as :meth:`command_long`.
        """
        p = _padded(params, COMMAND_PARAMS)
        x, y = int(p[4]), int(p[5])
        link = self.link

        def send(attempt: int) -> None:
            link.conn.mav.command_int_send(
                link.target_system,
                link.target_component,
                frame,
                command,
                current,
                autocontinue,
                p[0],
                p[1],
                p[2],
                p[3],
                x,
                y,
                p[6],
            )

        return self._command(command, send, timeout_s if timeout is None else timeout, retries)

    def _command(
        self,
        command: int,
        send: Callable[[int], None],
        timeout_s: float | None,
        retries: int | None,
        effect: Effect | None = None,
    ) -> CommandResult:
        """Send (attempt 0, 1 ...) every ACK_TRY_S until a final COMMAND_ACK or the effect; IN_PROGRESS stops
        the resending and extends the wait to the timeout."""
        link = self.link
        timeout = link._timeout(timeout_s)
        texts_before = len(link.statustexts)
        start = time.monotonic()
        deadline = start + timeout
        ack, attempts, next_try = None, 0, start
        while ack is None or ack.result == mavlink.MAV_RESULT_IN_PROGRESS:
            now = time.monotonic()
            try_due = ack is None and now >= next_try
            if ack is None and attempts and effect is not None and (try_due or now >= deadline) and effect():
                return CommandResult(command, mavlink.MAV_RESULT_ACCEPTED, None, acknowledged=False)  # ACK lost
            if now >= deadline:
                break
            if try_due:
                if retries is None or attempts < max(1, retries):
                    send(attempts)
                    attempts += 1
                    next_try = now + ACK_TRY_S
                else:
                    next_try = deadline  # no tries left: listen until the timeout
            wait = (deadline if ack is not None else min(next_try, deadline)) - now
            msg = link.recv("COMMAND_ACK", max(wait, 0.0), lambda m: m.command == command)
            if msg is not None:
                ack = msg
        if ack is None or ack.result == mavlink.MAV_RESULT_IN_PROGRESS:
            state = "only IN_PROGRESS" if ack is not None else "no COMMAND_ACK"
            raise (GcsTimeout if ack is not None else NoAnswer)(
                f"timed out after {timeout:g} s waiting for the vehicle to acknowledge "
                f"{command_name(command)} ({state} after {attempts} attempt(s)) [{link.describe()}]"
            )
        reason = None
        if ack.result != mavlink.MAV_RESULT_ACCEPTED:
            reason = link.reason_since(texts_before)
        return CommandResult(command, ack.result, reason)

    # ----------------------------------------------------------------- actions

    def arm(self, force: bool = False, timeout_s: float | None = None) -> CommandResult:
        """COMPONENT_ARM_DISARM(1); ``force`` skips the pre-arm checks (param2 = 21196).  Effect: armed."""
        return self.command_long(
            mavlink.MAV_CMD_COMPONENT_ARM_DISARM,
            1,
            ARM_FORCE_MAGIC if force else 0,
            timeout_s=timeout_s,
            effect=self.telemetry.armed,
        )

    def disarm(self, force: bool = False, timeout_s: float | None = None) -> CommandResult:
        """COMPONENT_ARM_DISARM(0); ``force`` disarms even in flight (param2 = 21196).  Effect: disarmed."""
        return self.command_long(
            mavlink.MAV_CMD_COMPONENT_ARM_DISARM,
            0,
            ARM_FORCE_MAGIC if force else 0,
            timeout_s=timeout_s,
            effect=lambda: self.link.latest("HEARTBEAT") is not None and not self.telemetry.armed(),
        )

    def set_mode(self, name: str, timeout_s: float | None = None) -> CommandResult:
        """MAV_CMD_DO_SET_MODE to a named PX4 mode (any accepted spelling; does not wait for the heartbeat).
        Effect: the heartbeat shows the mode."""
        mode = modes.lookup_mode(name)
        return self.command_long(
            mavlink.MAV_CMD_DO_SET_MODE,
            mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED,
            mode.main,
            mode.sub,
            timeout_s=timeout_s,
            effect=self._in_mode(mode.name),
        )

    def hold(self, timeout_s: float | None = None) -> CommandResult:
        """Hold position: DO_SET_MODE to AUTO.LOITER (PX4's Hold mode)."""
        return self.set_mode("HOLD", timeout_s)

    def takeoff(self, alt_amsl_m: float = math.nan, timeout_s: float | None = None) -> CommandResult:
        """NAV_TAKEOFF to an altitude AMSL, m (NaN: the vehicle's MIS_TAKEOFF_ALT above home).  Effect: mode
        TAKEOFF."""
        nan = math.nan
        return self.command_long(
            mavlink.MAV_CMD_NAV_TAKEOFF, nan, 0, 0, nan, nan, nan, alt_amsl_m, timeout_s=timeout_s,
            effect=self._in_mode("TAKEOFF"),
        )  # fmt: skip

    def land(self, timeout_s: float | None = None, precision: int = 0) -> CommandResult:
        """NAV_LAND where the vehicle is (yaw, lat, lon, alt NaN = keep current); ``precision`` is
        param 2 as in PX4: 0 ordinary, 1 precision landing if the target is found, 2 precision required.
        Effect: mode LAND (or PRECLAND with ``precision``)."""
        nan = math.nan
        return self.command_long(
            mavlink.MAV_CMD_NAV_LAND, 0, precision, 0, nan, nan, nan, nan, timeout_s=timeout_s,
            effect=self._in_mode("PRECLAND", "LAND") if precision else self._in_mode("LAND"),
        )  # fmt: skip

    def return_to_launch(self, timeout_s: float | None = None) -> CommandResult:
        """NAV_RETURN_TO_LAUNCH.  Effect: mode RTL."""
        return self.command_long(mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH, timeout_s=timeout_s, effect=self._in_mode("RTL"))

    def _in_mode(self, *names: str) -> Effect:
        """Effect: the heartbeat shows one of the modes ``names``."""
        targets = [modes.lookup_mode(name) for name in names]
        return lambda: self.telemetry.mode() in targets

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
        """DO_REPOSITION (as COMMAND_INT, degE7) with the change-mode flag: fly there and hold.  ``alt_amsl_m``
        is metres AMSL in the global frames (MAV_FRAME_GLOBAL, MAV_FRAME_GLOBAL_INT), metres above home with
        ``frame`` MAV_FRAME_GLOBAL_RELATIVE_ALT(_INT), as PX4 reads them."""
        return self.command_int(
            mavlink.MAV_CMD_DO_REPOSITION,
            ground_speed_m_s,
            mavlink.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE,
            0,
            math.radians(yaw_deg),  # DO_REPOSITION's yaw is in radians (MAVLink spec, PX4); NaN: keep the heading
            deg_to_e7(lat_deg),
            deg_to_e7(lon_deg),
            alt_amsl_m,
            frame=frame,
            timeout_s=timeout_s,
        )

    def ned_to_global(self, north_m: float, east_m: float, down_rel_home_m: float) -> tuple[float, float, float]:
        """(lat deg, lon deg, alt AMSL m) of a NED point relative to home (waits for home)."""
        home = self.telemetry.wait_home()
        return ned_to_global(home.lat_deg, home.lon_deg, home.alt_amsl_m, north_m, east_m, down_rel_home_m)

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
        """Fly to a point given in metres NED relative to home (down negative = above home) and hold there."""
        lat, lon, alt = self.ned_to_global(north_m, east_m, down_rel_home_m)
        return self.goto_global(lat, lon, alt, ground_speed_m_s=ground_speed_m_s, yaw_deg=yaw_deg, timeout_s=timeout_s)


def _padded(params: tuple, n: int) -> list[float]:
    """``params`` as floats, padded with zeros to ``n``; ValueError if more than ``n``."""
    if len(params) > n:
        raise ValueError(f"at most {n} parameters, got {len(params)}")
    return [float(v) for v in params] + [0.0] * (n - len(params))
