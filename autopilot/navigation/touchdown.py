"""The precision landing's touchdown on a moving deck: level on the legs before the motors cut.

Over a deck that turns, the vehicle docks tilted: its thrust's horizontal part keeps it with the deck (2 m/s^2 on
a 2 m circle at 2 m/s: 11 deg), and in wind it leans upwind.  Cut there, the motors leave it falling onto its
low-side feet; it pivots on them, swings level and, on a narrow stance, over the far feet.  The AscTec Firefly's
skids stand 0.18 m apart under a centre of mass 0.16 m up: landed 10 deg into the turn of a 2 m circle at 2 m/s it
tips over (every one of 10 calm circle landings, "fell off the deck"; the same drop level stays).  Once the legs
are on the deck, friction can hold the vehicle with the deck (a friction coefficient of 1 against 0.2 g), so the
tilt is no longer needed: :class:`Touchdown` then flies it level at a low thrust, the rate loop damping the swing,
and cuts the motors once it is level or after ``PLD_TD_LEVEL`` seconds.  ``PLD_TD_LEVEL`` 0: the motors cut at the
docking point, as [F 3] does.

Frames and units: the attitude quaternion ``(w, x, y, z)`` FRD -> NED, yaw rad NED, rad/s, thrust a fraction of
the vehicle's maximum, seconds; time is ``now_us`` (simulated microseconds).
"""

from __future__ import annotations

import math

from autopilot.parameters import ParamDef, param
from autopilot.topics import AttitudeSetpoint, VehicleEstimate
from mavsim_core import quaternion as quat

PARAMS: tuple[ParamDef, ...] = (
    param(
        "PLD_TD_LEVEL", 0.6, 0.0, 3.0, "s",
        "Precision landing on a moving deck: the docking flies on until the legs touch, then holds the vehicle "
        "level on them at low thrust up to this long before the motors cut (0: cut at the docking point; ours)",
    ),
)  # fmt: skip

THRUST_OF_HOVER = 0.5  # collective thrust on the deck, fraction of the hover thrust: pressed on, the rates held
LEVEL_TILT_RAD = math.radians(2.0)  # level: tilt within this ...
MIN_S = 0.15  # ... and on the deck at least this long (the swing damped, not passing through level)


class Touchdown:
    """Level on the deck, then the cut: :meth:`setpoint` each step from :meth:`start`, :meth:`finished` says when."""

    def __init__(self, level_s: float, started_us: int) -> None:
        self.level_s = level_s
        self.started_us = started_us

    def setpoint(self, yaw_rad: float, yaw_rate_rad_s: float, hover_thrust_frac: float) -> AttitudeSetpoint:
        """Level at ``yaw_rad`` (turning with the deck at ``yaw_rate_rad_s``), pressed on at a low thrust."""
        return AttitudeSetpoint(quat.from_euler(0.0, 0.0, yaw_rad), None, THRUST_OF_HOVER * hover_thrust_frac,
                                yaw_rate_rad_s)  # fmt: skip

    def finished(self, est: VehicleEstimate, now_us: int, on_deck: bool) -> str:
        """Why the motors may cut now ("" while not): level with the legs felt on the deck (``on_deck``: a bounce
        leaves it level in the air), or the time is up."""
        on_s = (now_us - self.started_us) * 1e-6
        tilt = quat.tilt_rad(est.roll_rad, est.pitch_rad)
        if on_s >= MIN_S and tilt <= LEVEL_TILT_RAD and on_deck:
            return f"level on the deck after {on_s:.2f} s"
        if on_s >= self.level_s:
            return f"{math.degrees(tilt):.0f} deg from level after {on_s:.2f} s"
        return ""
