"""The commander: arming, mode switching, failsafes and the command methods a ground station calls.

Rooms, top to bottom (the import contract in pyproject.toml keeps imports going down only):

* :mod:`autopilot.commander.commander`: :class:`Commander` (arming state machine, modes, the flight task that
  is active); it publishes a frozen :class:`autopilot.topics.CommanderStatus` after every change, and is the
  only place decisions are applied.
* Its mixins: :mod:`.flight_commands` and :mod:`.vehicle_commands` (the command methods, returning MAV_RESULT),
  :mod:`.mode_entry` (the mode switch and the modes' tasks), :mod:`.mission_flight` (missions, precision
  landings and the geofence flown), :mod:`.failsafe_actions` (the failsafes' and the failure detector's
  decisions applied).
* The decisions, functions of what they are given (typed, frozen snapshots or explicit arguments), never of
  the Commander: :mod:`.failsafes`, :mod:`.failure_detector` (with :mod:`.thrust_loss`),
  :mod:`.mode_requirements`, :mod:`.prearm_checks`, :mod:`.health` (SYS_STATUS bits, the battery warning
  level), :mod:`.mission_control` and :mod:`.mission_landing` (the plans, returns), :mod:`.precision_landing`.
"""

from autopilot.commander.commander import Commander

__all__ = ["Commander"]
