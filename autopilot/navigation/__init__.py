"""Navigation: the flight tasks that turn the active mode into a position setpoint, and the
land detector.

One task per file, all behind the small interface of :mod:`.flight_task` (PX4's FlightTask:
``activate(est, now_us)``, ``update(est, now_us) -> PositionSetpoint``, ``done``, ``failed``,
``shift(delta_ned_m)`` on estimator resets):

- :mod:`.takeoff`  climb straight up to the take-off height;
- :mod:`.loiter`   hold a point (AUTO.LOITER, POSCTL without sticks);
- :mod:`.goto`     jerk-free straight move with a trapezoidal speed profile (DO_REPOSITION);
- :mod:`.land`     two-stage descent with a slewed speed setpoint;
- :mod:`.rtl`      return to launch: climb, return, wait, land;
- :mod:`.land_detector`  the ON_GROUND / IN_AIR state machine with its hysteresis times.

The commander (:mod:`autopilot.commander`) chooses, builds and updates the tasks.  Still to
come, each in its own file here behind the same interface: the landing state machine
(precision landing on the moving marker, ``precland.py``) and the mission runner
(``mission.py``).

Nothing here reads a clock, opens a socket or speaks MAVLink: time is an input.
"""

from autopilot.navigation.flight_task import FlightTask, started
from autopilot.navigation.goto import GotoTask
from autopilot.navigation.land import LandTask
from autopilot.navigation.land_detector import LandDetector, Landed
from autopilot.navigation.loiter import LoiterTask
from autopilot.navigation.rtl import ReturnTask, RtlPhase
from autopilot.navigation.takeoff import TakeoffTask

__all__ = [
    "FlightTask",
    "GotoTask",
    "LandDetector",
    "LandTask",
    "Landed",
    "LoiterTask",
    "ReturnTask",
    "RtlPhase",
    "TakeoffTask",
    "started",
]
