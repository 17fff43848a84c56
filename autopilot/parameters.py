"""Parameter registry: every tunable value declared once, with type, range and unit.

Modules declare their parameters with :func:`declare` next to the code that uses
them (PX4 keeps a params file per module; ArduPilot an @Param block).  The
MAVLink parameter service (``gcs_link``) sits on top of one :class:`ParameterStore`.

Names follow PX4 where PX4 has the same parameter.  Only INT32 and REAL32 exist,
as in PX4.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable


class ParamType:
    INT32 = "INT32"
    REAL32 = "REAL32"


@dataclass(frozen=True)
class ParamDef:
    name: str
    ptype: str  # ParamType.INT32 or ParamType.REAL32
    default: float
    min: float
    max: float
    unit: str
    description: str
    reboot_required: bool = False

    def __post_init__(self) -> None:
        if len(self.name) > 16:
            raise ValueError(f"parameter name longer than 16 characters: {self.name}")
        if not self.min <= self.default <= self.max:
            raise ValueError(f"{self.name}: default {self.default} outside [{self.min}, {self.max}]")


_REGISTRY: dict[str, ParamDef] = {}


def declare(
    name: str,
    default: float,
    min: float,
    max: float,
    unit: str,
    description: str,
    ptype: str = ParamType.REAL32,
    reboot_required: bool = False,
) -> ParamDef:
    """Declare a parameter (idempotent for an identical declaration)."""
    d = ParamDef(name, ptype, default, min, max, unit, description, reboot_required)
    old = _REGISTRY.get(name)
    if old is not None and old != d:
        raise ValueError(f"parameter {name} declared twice with different definitions")
    _REGISTRY[name] = d
    return d


def registry() -> dict[str, ParamDef]:
    """All declared parameters, by name."""
    return dict(_REGISTRY)


class ParamError(ValueError):
    """A parameter set was refused; the message says why."""


class ParameterStore:
    """Current values of all declared parameters, in name order (index = position).

    ``set`` validates name, type and range and refuses with :class:`ParamError`
    without changing anything.  Listeners are called after each accepted change.
    """

    def __init__(self, defs: dict[str, ParamDef] | None = None) -> None:
        self._defs = dict(sorted((defs if defs is not None else registry()).items()))
        self._values: dict[str, float] = {n: d.default for n, d in self._defs.items()}
        self._names = list(self._defs)
        self._listeners: list[Callable[[str, float], None]] = []

    def __len__(self) -> int:
        return len(self._names)

    def __contains__(self, name: str) -> bool:
        return name in self._defs

    def names(self) -> list[str]:
        return list(self._names)

    def definition(self, name: str) -> ParamDef:
        try:
            return self._defs[name]
        except KeyError:
            raise ParamError(f"unknown parameter {name}") from None

    def index(self, name: str) -> int:
        return self._names.index(name)

    def name_at(self, index: int) -> str:
        if not 0 <= index < len(self._names):
            raise ParamError(f"parameter index {index} out of range 0..{len(self._names) - 1}")
        return self._names[index]

    def get(self, name: str) -> float:
        try:
            return self._values[name]
        except KeyError:
            raise ParamError(f"unknown parameter {name}") from None

    def set(self, name: str, value: float, ptype: str | None = None) -> float:
        """Validate and store; return the stored value.  Raise ParamError if refused."""
        d = self.definition(name)
        if ptype is not None and ptype != d.ptype:
            raise ParamError(f"{name} is {d.ptype}, not {ptype}")
        v = float(value)
        if not math.isfinite(v):
            raise ParamError(f"{name}: value must be finite")
        if d.ptype == ParamType.INT32:
            if v != int(v):
                raise ParamError(f"{name} is an integer, {value} is not")
            v = float(int(v))
        if not d.min <= v <= d.max:
            raise ParamError(f"{name}: {value:g} outside range [{d.min:g}, {d.max:g}] {d.unit}".rstrip())
        self._values[name] = v
        for cb in self._listeners:
            cb(name, v)
        return v

    def subscribe(self, callback: Callable[[str, float], None]) -> None:
        self._listeners.append(callback)
