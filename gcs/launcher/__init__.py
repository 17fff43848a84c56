"""Starting the simulator and the flight controller: the one part of ``gcs`` that knows them.

- :mod:`.stack`: :class:`Stack`, the ``sitl`` + ``autopilot`` processes of one
  instance (started with ``python -m``, never imported), its ports and logs;
- :mod:`.demo`: ``flight-demo``, a stack and a scripted flight with the client.

The client library (:mod:`gcs.client`, :mod:`gcs.connection`, :mod:`gcs.plugins`)
imports nothing from here; it talks MAVLink to whatever runs.
"""

from .stack import Stack, StackError

__all__ = ["Stack", "StackError"]
