"""The pilot's sticks, buttons and auxiliary channels: one MANUAL_CONTROL, decoded (PX4's manual_control_setpoint).

Kept apart from :mod:`autopilot.topics` (which re-exports :class:`ManualInput`) so the record can grow with
MANUAL_CONTROL's extension fields without the topics outgrowing their file.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

AUX_CHANNELS = 6  # MANUAL_CONTROL aux1..aux6
NO_AUX: tuple[float, ...] = (math.nan,) * AUX_CHANNELS


@dataclass(frozen=True, slots=True)
class ManualInput:
    """One MANUAL_CONTROL message (a joystick, QGroundControl's virtual sticks, MAVSDK ManualControl).

    Sticks as fractions: ``pitch`` forward +1, ``roll`` right +1, ``yaw`` clockwise +1 (each -1..1),
    ``throttle`` 0..1 (0.5 centred: MANUAL_CONTROL.z 0..1000).  ``received_us`` is the simulated
    time it arrived, ``received_wall_s`` the wall clock's (time.monotonic): the loss timers measure
    both, because a client sends on the wall clock while the simulation may run faster.

    The extension fields, as sent: ``buttons2`` (buttons 16-31), ``aux`` (aux1..aux6 as -1..1) and the
    pitch-only and roll-only axes ``s`` and ``t`` (-1..1); NaN where the sender did not enable the field
    (``enabled_extensions``) or sent a value outside -1000..1000, as PX4 reads them.
    """

    received_us: int
    received_wall_s: float
    pitch: float
    roll: float
    throttle: float
    yaw: float
    buttons: int = 0
    buttons2: int = 0
    aux: tuple[float, ...] = NO_AUX
    s: float = math.nan
    t: float = math.nan
