"""The bundled ground station: a MAVLink client library, the ``gcs`` CLI and the flight demo.

- :mod:`gcs.client`: :class:`VehicleClient` (commands, modes, parameters, waiting).
- :mod:`mavsim_core.px4_modes`: PX4 mode names <-> HEARTBEAT custom_mode.
- :mod:`gcs.geo`: flat-earth NED <-> latitude/longitude/altitude.
- PX4's byte-wise parameter encoding: :mod:`mavsim_core.param_encoding` (shared with the flight controller and the simulator).
- :mod:`gcs.stack`: :class:`Stack`, starting and stopping ``sitl`` + ``autopilot``.
- ``python -m gcs`` / ``gcs``: the CLI; ``flight-demo`` (:mod:`gcs.demo`): the scripted flight.
"""

from .client import (
    CommandRefused,
    CommandResult,
    GcsError,
    GcsTimeout,
    Home,
    ParamRefused,
    StatusText,
    VehicleClient,
)
from mavsim_core.px4_modes import UnknownModeError, custom_mode_to_name, lookup_mode, name_to_custom_mode
from .stack import Stack, StackError

__all__ = [
    "CommandRefused", "CommandResult", "GcsError", "GcsTimeout", "Home", "ParamRefused", "StatusText",
    "VehicleClient", "UnknownModeError", "custom_mode_to_name", "lookup_mode", "name_to_custom_mode",
    "Stack", "StackError",
]
