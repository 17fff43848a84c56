"""The bundled ground station: a MAVLink client library, the ``gcs`` CLI, plots and the flight demo.

The client library, split as MAVSDK splits its API:

- :mod:`gcs.client`: :class:`VehicleClient`, the facade every caller uses (a
  connection with every plugin; ``client.arm()`` is ``client.action.arm()``).
- :mod:`gcs.connection`: :class:`Connection`, the link (socket, heartbeats, receive loop, waits).
- :mod:`gcs.plugins`: ``telemetry``, ``action`` and ``param`` (``mission`` and ``offboard`` to come).
- :mod:`gcs.errors`: the public errors and the records that explain them.
- :mod:`gcs.geo`: NED <-> latitude/longitude/altitude on top of :mod:`mavsim_core.geodesy`.
- :mod:`gcs.sim_client`: :class:`SimClient`, the simulator's own port (ground truth, ``SIM_*`` parameters).
- PX4 mode names: :mod:`mavsim_core.px4_modes`; parameter encoding: :mod:`mavsim_core.param_encoding`.

Around it: ``python -m gcs`` / ``gcs``, the CLI (:mod:`gcs.param_cli` for ``gcs param``);
:mod:`gcs.flight_logs` reads flight logs into series and :mod:`gcs.plot` draws them
(``gcs plot``).  :mod:`gcs.launcher` (``Stack``, ``flight-demo``) starts the ``sitl``
and ``autopilot`` processes; it is the only part that knows them, and the client
library never imports it.
"""

from mavsim_core.px4_modes import UnknownModeError, custom_mode_to_name, lookup_mode, name_to_custom_mode

from .client import VehicleClient
from .connection import Connection
from .errors import (
    CommandRefused,
    CommandResult,
    GcsError,
    GcsTimeout,
    NoAnswer,
    ParamListError,
    ParamRefused,
    ParamUnknown,
    StatusText,
)
from .plugins.param import VehicleParam
from .plugins.telemetry import Home

__all__ = [
    "CommandRefused",
    "CommandResult",
    "Connection",
    "GcsError",
    "GcsTimeout",
    "Home",
    "NoAnswer",
    "ParamListError",
    "ParamRefused",
    "ParamUnknown",
    "StatusText",
    "VehicleClient",
    "VehicleParam",
    "UnknownModeError",
    "custom_mode_to_name",
    "lookup_mode",
    "name_to_custom_mode",
]
