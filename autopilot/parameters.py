"""Parameter registry: every tunable value declared once, with type, range and unit.

Each module defines its parameters with :func:`param` next to the code that uses
them, in a module-level ``PARAMS`` tuple (PX4 keeps a params file per module;
ArduPilot an @Param block), and :mod:`autopilot.param_catalogue` lists those tuples
explicitly: nothing is registered by importing a module.  The MAVLink parameter
service sits on top of one :class:`ParameterStore` built from the catalogue.

Names follow PX4 where PX4 has the same parameter.  Only INT32 and REAL32 exist,
as in PX4.

Cross-parameter rules (:data:`RULES`, e.g. ``MPC_THR_MIN < MPC_THR_MAX``) are
checked on every set: a value that would break one is refused like an
out-of-range value.  PX4 clamps such values silently in its controllers; here
the ground station is told why.  While the vehicle is armed, the gains without which
it cannot fly (:data:`FLIGHT_FLOORS`, e.g. ``MC_ROLLRATE_P``) are refused below a
fraction of their default; disarmed, any declared value is accepted.
"""

from __future__ import annotations

import math
import struct
from dataclasses import dataclass
from typing import Callable, Iterable

from mavsim_core.param_types import ParamType


@dataclass(frozen=True)
class ParamDef:
    name: str
    ptype: ParamType
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


def param(
    name: str,
    default: float,
    min: float,
    max: float,
    unit: str,
    description: str,
    ptype: ParamType = ParamType.REAL32,
    reboot_required: bool = False,
) -> ParamDef:
    """A parameter definition (a plain value: nothing is registered; the catalogue lists it)."""
    return ParamDef(name, ptype, default, min, max, unit, description, reboot_required)


def definitions(params: Iterable[ParamDef]) -> dict[str, ParamDef]:
    """Definitions by name; ValueError if a name comes twice with different definitions."""
    out: dict[str, ParamDef] = {}
    for d in params:
        old = out.get(d.name)
        if old is not None and old != d:
            raise ValueError(f"parameter {d.name} declared twice with different definitions")
        out[d.name] = d
    return out


class ParamError(ValueError):
    """A parameter set was refused; the message says why."""


@dataclass(frozen=True)
class ParamRule:
    """``lhs op rhs`` must hold between the current values of two parameters (op ``<`` or ``<=``)."""

    lhs: str
    op: str
    rhs: str
    why: str  # what the rule protects, for documentation

    def __post_init__(self) -> None:
        if self.op not in ("<", "<="):
            raise ValueError(f"rule {self.lhs} {self.op} {self.rhs}: operator must be < or <=")

    def holds(self, lhs_value: float, rhs_value: float) -> bool:
        return lhs_value < rhs_value if self.op == "<" else lhs_value <= rhs_value

    def __str__(self) -> str:
        return f"{self.lhs} {self.op} {self.rhs}"


# The rules between declared parameters.  Each names two parameters of the same unit;
# a rule whose parameters are not both in a store is not checked there.
RULES: tuple[ParamRule, ...] = (
    ParamRule("MPC_THR_MIN", "<", "MPC_THR_MAX", "the thrust range of flight is not empty"),
    ParamRule("MPC_LAND_SPEED", "<=", "MPC_Z_VEL_MAX_DN", "landing descends no faster than any descent"),
    ParamRule("MPC_TKO_SPEED", "<=", "MPC_Z_VEL_MAX_UP", "take-off climbs no faster than any ascent"),
    ParamRule("MPC_XY_CRUISE", "<=", "MPC_XY_VEL_MAX", "automatic moves respect the horizontal speed limit"),
    ParamRule("LNDMC_Z_VEL_MAX", "<", "MPC_LAND_SPEED", "a landing descent is never taken for landed"),
)


@dataclass(frozen=True)
class FlightFloor:
    """While armed, ``name`` may not be set below ``fraction`` of its default (the vehicle's); any value
    of its declared range is accepted disarmed.  ``zero_is_off``: 0 switches the feature off and is
    accepted (a filter's cut-off)."""

    name: str
    fraction: float
    why: str  # what goes wrong below it, for documentation
    zero_is_off: bool = False

    def limit(self, default: float) -> float:
        return self.fraction * default


# The gains below which the vehicle cannot be flown, refused while armed (issue 18, finding 6: an
# in-range PARAM_SET of MC_ROLLRATE_P = 0 in flight).  PX4 and ArduPilot take any in-range value in
# flight; raising a gain stays allowed up to the declared maximum (live tuning: x10 makes the rate loop
# oscillate, it still flies).  Measured with quad_x, hover at 5 m and 8 m moves, each gain pair at a
# fraction of its default: rate P 0.5 tilts 23 deg (1: 19), 0.25 tilts 54 deg, 0.1 flips; attitude P
# 0.25 flies, 0.1 creeps, 0 drifts away; rate limits 0.1 fly, 0 cannot tilt; gyro cut-off 0.1 (3 Hz)
# flies, 0.05 (1.5 Hz) falls.
FLIGHT_FLOORS: tuple[FlightFloor, ...] = (
    *(FlightFloor(f"MC_{a}RATE_P", 0.5, "rate loop: at 0.25 of its default a move tilts 54 deg, at 0.1 it flips")
      for a in ("ROLL", "PITCH", "YAW")),
    *(FlightFloor(f"MC_{a}_P", 0.25, "attitude loop: at 0.1 of its default the vehicle creeps, at 0 it drifts away")
      for a in ("ROLL", "PITCH", "YAW")),
    *(FlightFloor(f"MC_{a}RATE_MAX", 0.25, "at 0 the attitude loop commands no rate: no control")
      for a in ("ROLL", "PITCH", "YAW")),
    FlightFloor("IMU_GYRO_CUTOFF", 0.25, "at 1.5 Hz the filtered rates lag: the vehicle falls", zero_is_off=True),
)  # fmt: skip


def _same(a: float, b: float) -> bool:
    """Equal, or equal once rounded to float32 (what REAL32 parameters are on the wire)."""
    if a == b:
        return True
    try:
        return struct.pack("<f", a) == struct.pack("<f", b)
    except OverflowError:
        return False


class ParameterStore:
    """Current values of all declared parameters, in name order (index = position).

    ``set`` validates name, type, range and the cross-parameter ``rules`` and
    refuses with :class:`ParamError` without changing anything.  Listeners are
    called after each accepted change.  Each store keeps its own defaults: the
    declared ones, replaced by a vehicle's default set with :meth:`set_defaults`.
    """

    def __init__(
        self,
        defs: dict[str, ParamDef] | Iterable[ParamDef],
        rules: tuple[ParamRule, ...] = RULES,
        floors: tuple[FlightFloor, ...] = FLIGHT_FLOORS,
    ) -> None:
        by_name = defs if isinstance(defs, dict) else definitions(defs)
        self._defs = dict(sorted(by_name.items()))
        self._defaults: dict[str, float] = {n: float(d.default) for n, d in self._defs.items()}
        self._values: dict[str, float] = dict(self._defaults)
        self._names = list(self._defs)
        self._index = {n: i for i, n in enumerate(self._names)}
        self._rules = tuple(r for r in rules if r.lhs in self._defs and r.rhs in self._defs)
        self._rules_of: dict[str, list[ParamRule]] = {}
        for r in self._rules:
            self._rules_of.setdefault(r.lhs, []).append(r)
            self._rules_of.setdefault(r.rhs, []).append(r)
        self._listeners: list[Callable[[str, float], None]] = []
        self._floors = {f.name: f for f in floors if f.name in self._defs}
        # True while the vehicle is armed (the flight controller sets it): FLIGHT_FLOORS apply then
        self.armed: Callable[[], bool] | None = None
        for r in self._rules:
            if not r.holds(self._values[r.lhs], self._values[r.rhs]):
                raise ValueError(
                    f"declared defaults break the rule {r}: {self._values[r.lhs]:g} vs {self._values[r.rhs]:g}"
                )

    def __len__(self) -> int:
        return len(self._names)

    def __contains__(self, name: str) -> bool:
        return name in self._defs

    def names(self) -> list[str]:
        return list(self._names)

    def rules(self) -> tuple[ParamRule, ...]:
        """The cross-parameter rules checked by this store."""
        return self._rules

    def definition(self, name: str) -> ParamDef:
        try:
            return self._defs[name]
        except KeyError:
            raise ParamError(f"unknown parameter {name}") from None

    def index(self, name: str) -> int:
        try:
            return self._index[name]
        except KeyError:
            raise ParamError(f"unknown parameter {name}") from None

    def name_at(self, index: int) -> str:
        if not 0 <= index < len(self._names):
            raise ParamError(f"parameter index {index} out of range 0..{len(self._names) - 1}")
        return self._names[index]

    def get(self, name: str) -> float:
        try:
            return self._values[name]
        except KeyError:
            raise ParamError(f"unknown parameter {name}") from None

    def default(self, name: str) -> float:
        """This store's default of ``name`` (declared, or the vehicle's)."""
        try:
            return self._defaults[name]
        except KeyError:
            raise ParamError(f"unknown parameter {name}") from None

    def values(self) -> dict[str, float]:
        """A copy of every current value, by name."""
        return dict(self._values)

    def changed(self) -> dict[str, float]:
        """The values that differ from this store's defaults, in name order.

        REAL32 values compare as 32-bit floats: 0.95 set over MAVLink arrives as
        0.949999988 and is still the default 0.95.
        """
        values = dict(self._values)  # one copy: safe to call from another thread
        return {n: v for n, v in values.items() if not _same(v, self._defaults[n])}

    def check(self, name: str, value: float, ptype: str | None = None) -> float:
        """The value ``set`` would store (validated, integers made exact); raise ParamError if refused."""
        v = self._validate(name, value, ptype)
        self._check_floor(name, v)
        for r in self._rules_of.get(name, ()):
            lhs = v if r.lhs == name else self._values[r.lhs]
            rhs = v if r.rhs == name else self._values[r.rhs]
            if not r.holds(lhs, rhs):
                other, op = (r.rhs, r.op) if r.lhs == name else (r.lhs, {"<": ">", "<=": ">="}[r.op])
                unit = self._defs[name].unit
                unit = f" {unit}" if unit else ""
                raise ParamError(f"{name} {v:g} refused: must be {op} {other} ({self._values[other]:g}{unit})")
        return v

    def _check_floor(self, name: str, v: float) -> None:
        """While armed, a gain of FLIGHT_FLOORS not below its floor (ParamError)."""
        floor = self._floors.get(name)
        if floor is None or self.armed is None or not self.armed():
            return
        limit = floor.limit(self._defaults[name])
        if v < limit and not _same(v, limit) and not (floor.zero_is_off and v == 0.0):
            off = " or 0" if floor.zero_is_off else ""
            raise ParamError(f"{name} {v:g} refused while armed: at least {limit:g}{off} until disarmed")

    def _validate(self, name: str, value: float, ptype: str | None) -> float:
        """Name, type and range of one value (no rules); the value as stored."""
        d = self.definition(name)
        if ptype is not None and ptype != d.ptype:
            raise ParamError(f"{name} is {d.ptype}, not {ptype}")
        try:
            v = float(value)
        except (TypeError, ValueError):
            raise ParamError(f"{name}: {value!r} is not a number") from None
        if not math.isfinite(v):
            raise ParamError(f"{name}: value must be finite")
        if d.ptype == ParamType.INT32:
            if v != int(v):
                raise ParamError(f"{name} is an integer, {value} is not")
            v = float(int(v))
        elif _same(v, d.min) or _same(v, d.max):
            v = d.min if _same(v, d.min) else d.max  # a bound as the wire's float32 carries it (0.01 -> 0.0099999998)
        if not d.min <= v <= d.max:
            raise ParamError(f"{name}: {v:g} outside range [{d.min:g}, {d.max:g}] {d.unit}".rstrip())
        return v

    def set(self, name: str, value: float, ptype: str | None = None) -> float:
        """Validate and store; return the stored value.  Raise ParamError if refused."""
        v = self.check(name, value, ptype)
        self._values[name] = v
        for cb in self._listeners:
            cb(name, v)
        return v

    def set_defaults(self, values: dict[str, float]) -> None:
        """Replace defaults (a vehicle's default set, at start-up); current values follow.

        All or nothing: every value is checked (range, type) and the rules must hold
        for the new set, else ParamError and nothing changes.
        """
        new = dict(self._values)
        for name, value in values.items():
            new[name] = self._validate(name, value, None)
        for r in self._rules:
            if not r.holds(new[r.lhs], new[r.rhs]):
                raise ParamError(f"default set breaks the rule {r}: {new[r.lhs]:g} vs {new[r.rhs]:g}")
        for name in values:
            self._defaults[name] = new[name]
            if new[name] != self._values[name]:
                self._values[name] = new[name]
                for cb in self._listeners:
                    cb(name, new[name])

    def subscribe(self, callback: Callable[[str, float], None]) -> None:
        """Call ``callback(name, value)`` after each accepted change (in the setting thread)."""
        self._listeners.append(callback)
