"""What the Commander's mixins read and call of the Commander, declared once for the type checker.

The mixins (:mod:`~autopilot.commander.flight_commands`, :mod:`~autopilot.commander.vehicle_commands`,
:mod:`~autopilot.commander.mode_entry`, :mod:`~autopilot.commander.mission_flight`,
:mod:`~autopilot.commander.failsafe_actions`) are methods of the :class:`~autopilot.commander.commander.Commander`
that apply the commander's decisions; each declares only what it alone uses beside this.  Nothing here runs:
``Commander.__init__`` sets the state, the Commander defines the methods.  Times are simulated µs.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from mavsim_core.px4_modes import Mode

if TYPE_CHECKING:
    import numpy as np

    from autopilot.commander.external_inputs import ExternalInputs
    from autopilot.commander.mission_control import Plans
    from autopilot.parameters import ParameterStore
    from autopilot.topics import HomePosition, VehicleEstimate


class CommanderState:
    """The commander's state and methods its mixins share (see the module docstring)."""

    params: ParameterStore
    est: VehicleEstimate | None
    home: HomePosition | None
    armed: bool
    mode: Mode
    now_us: int
    task: Any
    plans: Plans
    inputs: ExternalInputs

    if TYPE_CHECKING:

        @property
        def in_air(self) -> bool: ...
        def say(self, severity: int, text: str) -> None: ...
        def _enter(self, mode: Mode, takeoff_down_m: float | None = None) -> int: ...
        def _switch_mode(self, mode: Mode) -> None: ...
        def _disarm(self, why: str) -> None: ...
        def _set_home_at(self, pos_ned_m: np.ndarray, quiet: bool = False) -> None: ...
        def _publish(self) -> None: ...
        def _start_mission(self) -> int: ...
