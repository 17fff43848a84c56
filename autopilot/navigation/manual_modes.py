"""PLACEHOLDER (being written): the stick modes POSCTL, ALTCTL, STABILIZED and ACRO."""

from __future__ import annotations

from autopilot.navigation.loiter import LoiterTask
from autopilot.parameters import ParamDef

PARAMS: tuple[ParamDef, ...] = ()


class PosCtlTask(LoiterTask):
    def __init__(self, params, sticks) -> None:
        super().__init__()
        self.on_ground = False


AltCtlTask = StabilizedTask = AcroTask = PosCtlTask
