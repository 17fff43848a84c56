"""What the ground-station link needs from the flight controller.

``gcs_link`` talks MAVLink; the commander implements this protocol.  Keeping it
a Protocol lets the link be tested with nothing flying and keeps the link free
of flight logic.
"""

from __future__ import annotations

from typing import Protocol

from autopilot.parameters import ParameterStore
from autopilot.topics import TelemetrySnapshot


class VehicleInterface(Protocol):
    params: ParameterStore

    def snapshot(self) -> TelemetrySnapshot:
        """Current state for telemetry (cheap; called once per link update)."""

    def handle_command(self, command: int, params: tuple[float, ...], frame: int) -> int:
        """Run a COMMAND_LONG/COMMAND_INT and return its MAV_RESULT.

        ``params`` are the seven float parameters (for COMMAND_INT, params 5 and 6
        are already converted from degE7 to degrees).  A refusal queues a STATUSTEXT
        saying why (see :meth:`pop_events`).  Unknown commands return
        MAV_RESULT_UNSUPPORTED.  Commands handled by the link itself
        (REQUEST_MESSAGE, SET_MESSAGE_INTERVAL, REQUEST_AUTOPILOT_CAPABILITIES) never
        reach this method.
        """

    def handle_set_mode(self, base_mode: int, custom_mode: int) -> int:
        """SET_MODE message or MAV_CMD_DO_SET_MODE: return MAV_RESULT."""

    def pop_events(self) -> list[tuple[int, str]]:
        """STATUSTEXT events (severity, text) queued since the last call."""
