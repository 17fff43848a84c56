"""The commander: arming, mode switching, health and the command methods a ground station calls.

* :mod:`autopilot.commander.commander`: :class:`Commander` (arming state machine, modes,
  the flight task that is active, typed command methods returning MAV_RESULT); it
  publishes a frozen :class:`autopilot.topics.CommanderStatus` after every change.
* :mod:`autopilot.commander.flight_commands`: the flight commands the commander inherits
  (take-off and its altitude rules, land, return to launch, reposition).
* :mod:`autopilot.commander.prearm_checks`: the pre-arm checks, pure functions returning
  the reasons arming is refused.
* :mod:`autopilot.commander.health`: SYS_STATUS sensor bits and the battery warning level
  (``BAT_LOW_THR``, ``BAT_CRIT_THR``, ``BAT_EMERGEN_THR``).
"""

from autopilot.commander.commander import Commander

__all__ = ["Commander"]
