"""The protocols the ground-station link serves besides telemetry, commands, parameters and plans.

Called once by the process (``autopilot/__main__.py``) after the link, the flight controller and
the simulator link exist; each service is a :class:`autopilot.mavlink.link_service.LinkService`.
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from autopilot.flight_controller import FlightController
    from autopilot.mavlink.link import GcsLink
    from autopilot.mavlink.sim_link import SimLink


def add_link_services(link: GcsLink, fc: FlightController, sim: SimLink, args: argparse.Namespace) -> None:
    """Add every service to ``link`` (``args``: the process's parsed command line)."""
