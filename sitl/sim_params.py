"""The simulator's ``SIM_*`` parameters: one ordered, validated view of the settings dataclasses.

:class:`SimParameters` wraps the live settings objects of a simulation
(:mod:`sitl.sim_settings`).  It adds no state of its own: :meth:`SimParameters.get`
reads the dataclass field and :meth:`SimParameters.set` validates a value and
writes the field, so the models see it on their next step.  The MAVLink
parameter service (:mod:`sitl.param_server`), scenario files
(:mod:`sitl.scenario`) and ``sitl --param`` / ``--list-params`` all go through it.

No sockets, no clocks, no files.
"""

from __future__ import annotations

import math
import numbers
import struct
from dataclasses import dataclass
from typing import Iterator, NamedTuple

from mavsim_core.param_types import ParamType
from sitl.hold import WORLD_HOLD, HoldSettings
from sitl.sim_settings import MotorSettings, SensorSettings, WindSettings, param_fields

# INT32 limits stay within +-(2**23 - 1): the byte-wise encoding of such an integer read as
# a float32 is never a signalling NaN, so it survives a Python float exactly (sitl.param_server).
INT32_FLOAT_SAFE = 2**23 - 1


class SimParamError(ValueError):
    """A ``SIM_*`` parameter could not be set (or does not exist); nothing was changed.

    ``name`` is the parameter name as given, ``reason`` a short text without the name,
    ``str(error)`` both ("SIM_WIND_SPD: 40 outside range [0, 30] m/s").
    """

    def __init__(self, name: str, reason: str) -> None:
        super().__init__(f"{name}: {reason}")
        self.name = name
        self.reason = reason


@dataclass(frozen=True)
class SimParam:
    """One parameter: its definition (from the field metadata) and where its value lives."""

    index: int  # 0-based position in the parameter list (PARAM_VALUE.param_index)
    name: str
    type: ParamType
    default: int | float
    min: float
    max: float
    unit: str
    description: str
    owner: object  # the settings dataclass instance holding the value
    attr: str  # its field name
    start_only: bool = False  # read once when the simulator starts (refused in flight)


class ParamRow(NamedTuple):
    """One line of :meth:`SimParameters.describe` (values as numbers; see :func:`format_table`)."""

    name: str
    type: str
    value: int | float
    default: int | float
    min: float
    max: float
    unit: str
    description: str


def _float32(x: float) -> float:
    """``x`` rounded to float32 (what a MAVLink parameter value can carry); inf beyond its range."""
    try:
        return struct.unpack("<f", struct.pack("<f", x))[0]
    except OverflowError:
        return math.copysign(math.inf, x)


def format_value(value: int | float, ptype: str) -> str:
    """A parameter value as people write it: integers plain, reals in %g."""
    return str(int(value)) if ptype == ParamType.INT32 else f"{value:g}"


class SimParameters:
    """The ``SIM_*`` parameters of one simulation, in a fixed order (wind, sensors, motors, ..., the hold)."""

    def __init__(
        self,
        wind: WindSettings,
        sensors: SensorSettings,
        motors: MotorSettings,
        *more: object,
        hold: HoldSettings = WORLD_HOLD,
    ) -> None:
        """``more``: further settings objects (the UGV's, the camera's), listed after the motors'; ``hold``: the
        world's ``SIM_HOLD_MS`` (:mod:`sitl.hold`; the process's one by default), listed last."""
        self._params: list[SimParam] = []
        self._by_name: dict[str, SimParam] = {}
        self.started = False  # set by the simulator once it runs: start-only parameters are then refused
        for owner in (wind, sensors, motors, *more, hold):
            for f in param_fields(owner):
                md = f.metadata
                name = md["param"]
                if name in self._by_name:
                    raise ValueError(f"parameter {name} declared twice (sitl.sim_settings)")
                if md["type"] not in (ParamType.INT32, ParamType.REAL32):
                    raise ValueError(f"parameter {name}: unsupported type {md['type']!r}")
                if (
                    md["type"] == ParamType.INT32
                    and not -INT32_FLOAT_SAFE <= md["min"] <= md["max"] <= INT32_FLOAT_SAFE
                ):
                    raise ValueError(f"parameter {name}: INT32 limits must lie within +-{INT32_FLOAT_SAFE}")
                p = SimParam(
                    len(self._params),
                    name,
                    ParamType(md["type"]),
                    f.default,
                    float(md["min"]),
                    float(md["max"]),
                    md["unit"],
                    md["description"],
                    owner,
                    f.name,
                    bool(md.get("start_only", False)),
                )
                self._params.append(p)
                self._by_name[name] = p

    # -- the list
    def __len__(self) -> int:
        return len(self._params)

    def __contains__(self, name: object) -> bool:
        return name in self._by_name

    def __iter__(self) -> Iterator[SimParam]:
        return iter(self._params)

    def names(self) -> list[str]:
        return [p.name for p in self._params]

    def param(self, name: str) -> SimParam:
        """The definition of ``name``; :class:`SimParamError` if there is no such parameter."""
        try:
            return self._by_name[name]
        except (KeyError, TypeError):
            raise SimParamError(str(name), "unknown parameter") from None

    def at(self, index: int) -> SimParam:
        """The parameter at a 0-based index; :class:`SimParamError` if out of range."""
        if not 0 <= index < len(self._params):
            raise SimParamError(f"#{index}", f"no parameter at index {index} (0..{len(self._params) - 1})")
        return self._params[index]

    # -- values
    def get(self, name: str) -> int | float:
        p = self.param(name)
        return getattr(p.owner, p.attr)

    def validate(self, name: str, value: object) -> int | float:
        """The value ``set`` would store (int for INT32, float for REAL32); raise if it would refuse."""
        p = self.param(name)
        if isinstance(value, bool) or not isinstance(value, numbers.Real):
            raise SimParamError(name, f"expected a number, not {type(value).__name__} {value!r}")
        v = float(value)
        if not math.isfinite(v):
            raise SimParamError(name, f"value must be finite, not {v}")
        if self.started and p.start_only and v != getattr(p.owner, p.attr):
            raise SimParamError(name, "set at start only: restart to change")
        if p.type == ParamType.INT32 and v != math.floor(v):
            raise SimParamError(name, f"{v:g} is not an integer (INT32 parameter)")
        if not p.min <= v <= p.max:
            # A limit sent as a float32 (0.1 -> 0.10000000149) is the limit, not outside it.
            if _float32(v) == _float32(p.min):
                v = p.min
            elif _float32(v) == _float32(p.max):
                v = p.max
            else:
                unit = f" {p.unit}" if p.unit else ""
                raise SimParamError(name, f"{v:.8g} outside range [{p.min:g}, {p.max:g}]{unit}")
        return int(v) if p.type == ParamType.INT32 else v

    def set(self, name: str, value: object) -> int | float:
        """Validate and store ``value``; return the stored value.

        Raises :class:`SimParamError` (and changes nothing) for an unknown name, a value
        that is not a number, NaN or infinity, a value outside [min, max], or a
        non-integer for an INT32 parameter.
        """
        v = self.validate(name, value)
        p = self._by_name[name]
        setattr(p.owner, p.attr, v)
        return v

    def set_many(self, values: dict[str, object]) -> None:
        """Set several parameters, all or none: every value is checked before any is written."""
        checked = {name: self.validate(name, value) for name, value in values.items()}
        for name, v in checked.items():
            p = self._by_name[name]
            setattr(p.owner, p.attr, v)

    def describe(self) -> list[ParamRow]:
        """One row per parameter, in list order, with its current value."""
        return [
            ParamRow(p.name, p.type, self.get(p.name), p.default, p.min, p.max, p.unit, p.description)
            for p in self._params
        ]


def format_table(rows: list[ParamRow]) -> str:
    """The rows of :meth:`SimParameters.describe` as an aligned text table."""
    header = ("NAME", "VALUE", "MIN", "MAX", "UNIT", "DESCRIPTION")
    cells = [header] + [
        (
            r.name,
            format_value(r.value, r.type),
            format_value(r.min, r.type),
            format_value(r.max, r.type),
            r.unit,
            r.description,
        )
        for r in rows
    ]
    widths = [max(len(c[i]) for c in cells) for i in range(len(header) - 1)]
    lines = ["  ".join(c[i].ljust(widths[i]) for i in range(len(widths))) + "  " + c[-1] for c in cells]
    return "\n".join(line.rstrip() for line in lines)
