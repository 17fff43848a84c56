"""The client's plugins, one job each, as MAVSDK splits its API.

Each takes a :class:`gcs.connection.Connection` and adds one group of calls:

- :mod:`.telemetry`: :class:`Telemetry`, the vehicle's state from the latest messages;
- :mod:`.action`: :class:`Action`, commands (arm, disarm, mode, take off, land, RTL, hold, go to);
- :mod:`.param`: :class:`Param`, parameter read, set and full download.

Missions and offboard control come as ``mission.py`` and ``offboard.py`` beside them.
"""

from .action import Action
from .param import Param
from .telemetry import Telemetry

__all__ = ["Action", "Param", "Telemetry"]
