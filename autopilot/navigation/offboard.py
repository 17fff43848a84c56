"""PLACEHOLDER (being written): OFFBOARD mode."""

from __future__ import annotations

from autopilot.navigation.loiter import LoiterTask
from autopilot.parameters import ParamDef

PARAMS: tuple[ParamDef, ...] = ()


class OffboardTask(LoiterTask):
    def __init__(self, params, latest, hover_thrust_frac) -> None:
        super().__init__()


def offboard_refusal(inputs, now_us, wall_s, params) -> str | None:
    return "not yet"
