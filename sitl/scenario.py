"""Scenario files: ``SIM_*`` parameters at start-up and changes at given simulated times.

A scenario is a TOML file (``params/scenarios/NAME.toml``, or any path)::

    description = "Hexacopter loses motor 1 at t = 20 s"

    [parameters]            # applied before the simulation starts
    SIM_WIND_SPD = 5.0

    [[events]]              # applied when simulated time reaches at_s
    at_s = 20.0
    set = { SIM_ENGINE_FAIL = 1, SIM_ENGINE_MUL = 0.0 }

    [pad]                   # the nested landing pad on the UGV's deck instead of vision.pad.NESTED_PAD,
    markers = [             # id (DICT_ARUCO_ORIGINAL), side (m), centre (m, x the UGV's forward, y its left)
        { id = 76, size_m = 0.333, x_m = -0.30, y_m = 0.0 },
        { id = 42, size_m = 0.125, x_m = 0.0, y_m = 0.0 },
    ]

Every name and value is checked against :class:`sitl.sim_params.SimParameters`
when the file is loaded, and the pad against the deck (:func:`vision.pad.check_pad`: markers
that overlap, with their white borders, or do not fit on the deck are refused), so a bad file
fails at start-up with :class:`ScenarioError` naming the file, the key and the reason, never in flight.

:class:`EventSchedule` hands out the events as simulated time passes; the process
loop (``sitl.lockstep``) asks it once per 50 Hz period.  No sockets, no clocks.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import params as params_package
from sitl.sim_params import SimParamError, SimParameters
from sitl.sim_settings import CameraSettings, MotorSettings, SensorSettings, UgvSettings, WindSettings
from sitl.ugv import UgvGeometry
from vision.pad import PadLayout, PadLayoutError, PadMarker, check_pad

SCENARIO_DIR = Path(params_package.__file__).resolve().parent / "scenarios"  # shipped as package data
_TOP_KEYS = ("description", "parameters", "events", "pad")
_PAD_MARKER_KEYS = ("id", "size_m", "x_m", "y_m")  # x_m, y_m: 0 when left out
_EVENT_KEYS = ("at_s", "set")


class ScenarioError(ValueError):
    """A scenario file that cannot be used; ``str()`` is "FILE: KEY: REASON"."""

    def __init__(self, file: str | Path, key: str | None, reason: str) -> None:
        self.file = str(file)
        self.key = key
        self.reason = reason
        super().__init__(f"{self.file}: {key}: {reason}" if key else f"{self.file}: {reason}")


@dataclass(frozen=True)
class ScenarioEvent:
    """Parameter changes applied together when simulated time reaches ``at_us``."""

    at_us: int
    values: dict[str, int | float]  # parameter name -> value, in file order


@dataclass(frozen=True)
class Scenario:
    name: str
    path: Path
    description: str
    parameters: dict[str, int | float]  # applied at start-up, in file order
    events: tuple[ScenarioEvent, ...]  # sorted by time (file order among equal times)
    pad: PadLayout | None = None  # the [pad] table's markers: the nested pad (None: the default one)


def list_scenarios() -> list[str]:
    """Names of the scenarios shipped in ``params/scenarios``."""
    return sorted(p.stem for p in SCENARIO_DIR.glob("*.toml"))


def scenario_path(name_or_path: str | Path) -> Path:
    """A bare name (no directory, no ``.toml``) means ``params/scenarios/NAME.toml``."""
    text = str(name_or_path)
    p = Path(text)
    if p.suffix == ".toml" or len(p.parts) > 1:
        return p
    return SCENARIO_DIR / f"{text}.toml"


def load_scenario(name_or_path: str | Path, params: SimParameters | None = None) -> Scenario:
    """Read and check a scenario; ``params`` (default: a fresh set) defines the valid names and ranges.

    Nothing is applied: see :meth:`SimParameters.set_many` and :class:`EventSchedule`.
    """
    path = scenario_path(name_or_path)
    if not path.is_file():
        known = ", ".join(list_scenarios()) or "none"
        raise ScenarioError(path, None, f"no such scenario file (shipped scenarios: {known})")
    try:
        with path.open("rb") as f:
            doc = tomllib.load(f)
    except tomllib.TOMLDecodeError as e:
        raise ScenarioError(path, None, f"not valid TOML: {e}") from None
    except (OSError, UnicodeDecodeError) as e:
        raise ScenarioError(path, None, f"cannot read: {e}") from None
    if params is None:
        params = SimParameters(WindSettings(), SensorSettings(), MotorSettings(), UgvSettings(), CameraSettings())

    for key in doc:
        if key not in _TOP_KEYS:
            raise ScenarioError(path, key, f"unknown key (expected {', '.join(_TOP_KEYS)})")
    description = doc.get("description", "")
    if not isinstance(description, str):
        raise ScenarioError(path, "description", "must be a string")
    parameters = _check_values(path, "parameters", doc.get("parameters", {}), params)

    raw_events = doc.get("events", [])
    if not isinstance(raw_events, list):
        raise ScenarioError(path, "events", "must be an array of tables ([[events]])")
    events = []
    for i, ev in enumerate(raw_events):
        where = f"events[{i}]"
        if not isinstance(ev, dict):
            raise ScenarioError(path, where, "must be a table with at_s and set")
        _check_keys(path, where, ev, _EVENT_KEYS, required=_EVENT_KEYS)
        at_s = ev["at_s"]
        if isinstance(at_s, bool) or not isinstance(at_s, (int, float)) or not math.isfinite(at_s) or at_s < 0:
            raise ScenarioError(path, f"{where}.at_s", f"must be a number of seconds >= 0, not {at_s!r}")
        values = _check_values(path, f"{where}.set", ev["set"], params)
        if not values:
            raise ScenarioError(path, f"{where}.set", "sets no parameter")
        events.append(ScenarioEvent(round(at_s * 1e6), values))
    events.sort(key=lambda e: e.at_us)  # stable: file order among equal times
    pad = _check_pad(path, doc["pad"]) if "pad" in doc else None
    return Scenario(path.stem, path, description, parameters, tuple(events), pad)


def _check_keys(path: Path, where: str, table: dict, known: tuple[str, ...], required: tuple[str, ...]) -> None:
    """:class:`ScenarioError` for the first key of ``table`` (the table at ``where``) not in ``known``, or else
    the first of ``required`` it lacks."""
    for key in table:
        if key not in known:
            raise ScenarioError(path, f"{where}.{key}", f"unknown key (expected {', '.join(known)})")
    for key in required:
        if key not in table:
            raise ScenarioError(path, where, f"missing {key}")


def _check_pad(path: Path, table: object) -> PadLayout:
    """The ``[pad]`` table as a :class:`PadLayout` that fits on the UGV's deck, or :class:`ScenarioError`."""
    if not isinstance(table, dict) or set(table) != {"markers"} or not isinstance(table["markers"], list):
        raise ScenarioError(path, "pad", "must be a table with one key, markers = [{ id, size_m, x_m, y_m }, ...]")
    markers = []
    for i, raw in enumerate(table["markers"]):
        where = f"pad.markers[{i}]"
        if not isinstance(raw, dict):
            raise ScenarioError(path, where, "must be a table { id, size_m, x_m, y_m }")
        _check_keys(path, where, raw, _PAD_MARKER_KEYS, required=("id", "size_m"))
        marker_id = raw["id"]
        if isinstance(marker_id, bool) or not isinstance(marker_id, int):
            raise ScenarioError(path, f"{where}.id", f"must be an integer, not {marker_id!r}")
        numbers = []
        for key in ("size_m", "x_m", "y_m"):
            value = raw.get(key, 0.0)
            if isinstance(value, bool) or not isinstance(value, (int, float)) or not math.isfinite(value):
                raise ScenarioError(path, f"{where}.{key}", f"must be a number of metres, not {value!r}")
            numbers.append(float(value))
        markers.append(PadMarker(marker_id, *numbers))
    try:
        return check_pad(PadLayout(tuple(markers)), UgvGeometry.deck_side_m)
    except PadLayoutError as e:
        raise ScenarioError(path, e.key, e.reason) from None


def _check_values(path: Path, where: str, table: object, params: SimParameters) -> dict[str, int | float]:
    if not isinstance(table, dict):
        raise ScenarioError(path, where, "must be a table of SIM_NAME = value")
    out: dict[str, int | float] = {}
    for name, value in table.items():
        if name not in params:
            raise ScenarioError(path, f"{where}.{name}", "unknown parameter (sitl --list-params lists them)")
        try:
            out[name] = params.validate(name, value)
        except SimParamError as e:
            raise ScenarioError(path, f"{where}.{name}", e.reason) from None
    return out


class EventSchedule:
    """The events of a scenario, handed out once each as simulated time passes them.

    ``next_us`` is the time of the next event (``math.inf`` when none is left), so the
    loop's test is a single comparison.
    """

    def __init__(self, events: tuple[ScenarioEvent, ...] | list[ScenarioEvent] = ()) -> None:
        self._events = sorted(events, key=lambda e: e.at_us)
        self._next = 0
        self.next_us: float = self._events[0].at_us if self._events else math.inf

    def __len__(self) -> int:
        """Events not handed out yet."""
        return len(self._events) - self._next

    def pop_due(self, time_us: int) -> list[ScenarioEvent]:
        """The events with ``at_us <= time_us`` not handed out before, in order."""
        due = []
        while self._next < len(self._events) and self._events[self._next].at_us <= time_us:
            due.append(self._events[self._next])
            self._next += 1
        self.next_us = self._events[self._next].at_us if self._next < len(self._events) else math.inf
        return due
