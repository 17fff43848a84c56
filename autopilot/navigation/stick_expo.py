"""Stick curves as PX4 shapes its sticks (its ``math::expo`` and ``math::superexpo``) and their parameters.

- :func:`expo`: ``(1 - e) x + e x^3`` on a stick ``x`` (-1..1) with ``e`` (0..1) blending the linear and the
  cubic curve: the centre is gentler, full stick is still full.  PX4 applies it after the deadzone
  (MPC_HOLD_DZ) in Position and Altitude mode: MPC_XY_MAN_EXPO to the horizontal sticks of Position mode
  (Altitude mode's tilt takes them as they come), MPC_Z_MAN_EXPO to the throttle's climb rate and
  MPC_YAW_EXPO to the yaw stick (also in Stabilized mode).
- :func:`superexpo`: ``expo(x, e) (1 - g) / (1 - |x| g)`` (``g`` 0..0.99) bends the curve further towards
  full stick; Acro mode shapes roll and pitch with MC_ACRO_EXPO and MC_ACRO_SUPEXPO, yaw with MC_ACRO_EXPO_Y
  and MC_ACRO_SUPEXPOY (no deadzone).

Defaults are PX4's (1.14 onwards): 0.6 for the three MPC_*_EXPO, 0 (linear) for the acro ones.
"""

from __future__ import annotations

from autopilot.parameters import ParamDef, param

PARAMS: tuple[ParamDef, ...] = (
    param("MPC_XY_MAN_EXPO", 0.6, 0.0, 1.0, "norm", "Position mode horizontal stick expo: 0 linear, 1 cubic"),
    param("MPC_Z_MAN_EXPO", 0.6, 0.0, 1.0, "norm", "Climb-rate stick expo (Position, Altitude): 0 linear, 1 cubic"),
    param("MPC_YAW_EXPO", 0.6, 0.0, 1.0, "norm", "Yaw stick expo (Position, Altitude, Stabilized): 0 linear, 1 cubic"),
    param("MC_ACRO_EXPO", 0.0, 0.0, 1.0, "norm", "Acro mode roll and pitch stick expo: 0 linear, 1 cubic"),
    param("MC_ACRO_EXPO_Y", 0.0, 0.0, 1.0, "norm", "Acro mode yaw stick expo: 0 linear, 1 cubic"),
    param("MC_ACRO_SUPEXPO", 0.0, 0.0, 0.95, "norm", "Acro mode roll and pitch super-expo: 0 plain expo, 0.95 bent"),
    param("MC_ACRO_SUPEXPOY", 0.0, 0.0, 0.95, "norm", "Acro mode yaw super-expo: 0 plain expo, 0.95 bent"),
)  # fmt: skip


def _clip(x: float, lo: float, hi: float) -> float:
    return min(max(x, lo), hi)


def expo(x: float, e: float) -> float:
    """PX4's ``math::expo``: ``(1 - e) x + e x^3``, ``x`` clipped to -1..1 and ``e`` to 0..1."""
    x, e = _clip(x, -1.0, 1.0), _clip(e, 0.0, 1.0)
    return (1.0 - e) * x + e * x * x * x


def superexpo(x: float, e: float, g: float) -> float:
    """PX4's ``math::superexpo``: ``expo(x, e) (1 - g) / (1 - |x| g)``, ``g`` clipped to 0..0.99 (full stick
    stays full)."""
    x, g = _clip(x, -1.0, 1.0), _clip(g, 0.0, 0.99)
    return expo(x, e) * (1.0 - g) / (1.0 - abs(x) * g)
