"""Parameter persistence and start-up parameter files of the flight controller.

At start-up, in this order (each later source wins):

1. the declared defaults (:mod:`autopilot.parameters`);
2. the vehicle's default set, ``params/vehicles/<vehicle>.params`` beside its
   ``.toml`` if there is one: these *become the defaults* (PX4's airframe
   ``param set-default``);
3. with ``--state-dir DIR``: the changes saved by an earlier run, from
   ``DIR/<vehicle>-<instance>.params`` (one file per vehicle and instance, so
   several vehicles can share a directory);
4. with ``--params FILE``: a QGroundControl (or MAVProxy) parameter file, applied
   as if a ground station had set each value; they are then saved like any change.

Without ``--state-dir`` nothing is saved: every run starts from the defaults,
which keeps simulations reproducible and tests independent.  (PX4 SITL keeps
``parameters.bson`` in its per-instance working directory; give
``--state-dir`` to get the same.)

Saving: every accepted change marks the set dirty; a background thread
writes the changed (non-default) parameters in QGroundControl's format at once,
then at most once per ``min_interval_s`` of wall time, and :meth:`ParamSaver.close`
writes what is left at exit.  The lockstep loop never waits on the disk.  Each
write is atomic (temporary file in the same directory, fsync, ``os.replace``,
fsync of the directory), so a crash at any moment leaves either the old or the
new complete file.
"""

from __future__ import annotations

import sys
import threading
from pathlib import Path
from typing import Callable

from autopilot.parameters import ParamError, ParameterStore, ParamType
from mavsim_core.param_encoding import INT32, REAL32, is_integer_type
from params.param_file import (
    LineProblem,
    ParamEntry,
    ParamFileError,
    apply_in_passes,
    atomic_write_text,
    format_qgc,
    read_param_file,
)

MIN_SAVE_INTERVAL_S = 1.0  # wall seconds between two writes of the state file
FC_COMPONENT_ID = 1  # entries of other components in a QGroundControl file are not ours

_MAV_TYPE = {ParamType.INT32: INT32, ParamType.REAL32: REAL32}
_PTYPE = {INT32: ParamType.INT32, REAL32: ParamType.REAL32}


def state_file(state_dir: str | Path, vehicle_name: str, instance: int) -> Path:
    """Where the changed parameters of a vehicle and instance are kept: ``DIR/<vehicle>-<instance>.params``."""
    return Path(state_dir) / f"{vehicle_name}-{instance}.params"


def vehicle_defaults_file(vehicle_toml: str | Path) -> Path | None:
    """The vehicle's default parameter set (``.params`` beside its ``.toml``), or None."""
    path = Path(vehicle_toml).with_suffix(".params")
    return path if path.exists() else None


def store_entries(store: ParameterStore, names: list[str] | None = None, sysid: int = 1) -> list[ParamEntry]:
    """The store's parameters (all, or ``names``) as typed file entries."""
    out = []
    for name in names if names is not None else store.names():
        mav_type = _MAV_TYPE[store.definition(name).ptype]
        value = store.get(name)
        out.append(ParamEntry(name, int(value) if mav_type == INT32 else value, mav_type, 0, sysid, FC_COMPONENT_ID))
    return out


def apply_entries(store: ParameterStore, entries: list[ParamEntry]) -> tuple[int, list[LineProblem]]:
    """Set each entry in the store (passes, so cross-parameter rules do not depend on line order).

    Entries of other components are skipped with a problem; a typed entry must
    match the parameter's type.  Returns (number applied, problems by line).
    """
    problems: list[LineProblem] = []
    mine = []
    for e in entries:
        if e.compid != FC_COMPONENT_ID:
            problems.append(
                LineProblem(
                    e.line, f"{e.name}: component {e.compid}, not the flight controller ({FC_COMPONENT_ID}); ignored"
                )
            )
        else:
            mine.append(e)

    def apply(e: ParamEntry) -> None:
        ptype = None
        if e.mav_type is not None:
            ptype = _PTYPE.get(e.mav_type)
            if ptype is None:  # another integer type: PX4 has INT32 only
                ptype = "INT32" if is_integer_type(e.mav_type) else str(e.mav_type)
        store.set(e.name, e.value, ptype)

    refused = apply_in_passes(mine, apply, ParamError)
    problems += [LineProblem(e.line, reason) for e, reason in refused]
    problems.sort(key=lambda p: p.line)
    return len(mine) - len(refused), problems


def load_file(store: ParameterStore, path: str | Path, *, as_defaults: bool = False) -> tuple[int, list[str]]:
    """Apply a parameter file to the store; return (values applied, messages naming file and line).

    Never raises for the file's content: unreadable files, bad lines, unknown
    names, wrong types and refused values all come back as messages.  With
    ``as_defaults`` the values become the store's defaults (all or nothing).
    """
    try:
        pf = read_param_file(path)
    except ParamFileError as exc:
        return 0, [str(exc)]
    messages = [f"{path}, {p}" for p in pf.problems]
    if as_defaults:
        try:
            store.set_defaults({e.name: e.value for e in pf.entries})
        except ParamError as exc:
            return 0, messages + [f"{path}: {exc}; vehicle defaults not applied"]
        return len(pf.entries), messages
    applied, problems = apply_entries(store, pf.entries)
    return applied, messages + [f"{path}, {p}" for p in problems]


class ParamSaver:
    """Keeps ``path`` equal to the store's changed parameters (QGroundControl format).

    Construct after the start-up values are in the store; it writes once at
    start if the file does not hold them already (``initial_save``), then after
    each change as described in the module note.  :meth:`close` stops the
    thread and writes any change not yet saved.  Write errors are reported
    through ``report`` (stderr by default) and retried at the next change.
    """

    def __init__(
        self,
        store: ParameterStore,
        path: str | Path,
        *,
        vehicle_name: str = "",
        min_interval_s: float = MIN_SAVE_INTERVAL_S,
        initial_save: bool = False,
        report: Callable[[str], None] | None = None,
    ) -> None:
        self.store = store
        self.path = Path(path)
        self.vehicle_name = vehicle_name
        self.min_interval_s = float(min_interval_s)
        self.report = report or (lambda text: print(text, file=sys.stderr, flush=True))
        self.saves = 0  # files written
        self._changes = 0  # accepted changes seen (written by the store's thread only)
        self._saved_changes = 0
        self._lock = threading.Lock()
        self._dirty = threading.Event()
        self._stop = threading.Event()
        store.subscribe(self._on_change)
        if initial_save:
            self._on_change("", 0.0)
        self._thread = threading.Thread(target=self._run, name="param-saver", daemon=True)
        self._thread.start()

    def _on_change(self, name: str, value: float) -> None:
        self._changes += 1
        self._dirty.set()

    def _run(self) -> None:
        while True:
            self._dirty.wait()
            if self._stop.is_set():
                return
            self._dirty.clear()
            self.save()
            if self._stop.wait(self.min_interval_s):
                return

    def save(self) -> bool:
        """Write the changed parameters now; False (and a report) if the write failed."""
        with self._lock:
            changes = self._changes
            changed = self.store.changed()
            header = (
                f"Parameters of {self.vehicle_name or 'the vehicle'} changed from its defaults\n"
                "saved by the autopilot and loaded at its start-up"
            )
            text = format_qgc(store_entries(self.store, list(changed)), header)
            try:
                atomic_write_text(self.path, text)
            except OSError as exc:
                self.report(f"[autopilot] cannot save parameters to {self.path}: {exc}")
                return False
            self._saved_changes = changes
            self.saves += 1
            return True

    def close(self) -> None:
        """Stop the thread and write any change not yet saved (idempotent)."""
        self._stop.set()
        self._dirty.set()
        self._thread.join(timeout=5.0)
        if self._changes != self._saved_changes:
            self.save()


def prepare_parameters(
    store: ParameterStore,
    *,
    vehicle_toml: str | Path | None = None,
    state_path: str | Path | None = None,
    params_path: str | Path | None = None,
    log: Callable[[str], None] = print,
) -> None:
    """Fill the store at start-up from the vehicle defaults, the saved state and ``--params`` (in that order).

    Every problem is logged (with file and line) and skipped; nothing here stops
    the flight controller from starting.
    """
    defaults = vehicle_defaults_file(vehicle_toml) if vehicle_toml is not None else None
    sources = [
        (defaults, "vehicle defaults", True),
        (state_path, "saved parameters", False),
        (params_path, "parameter file", False),
    ]
    for path, what, as_defaults in sources:
        if path is None:
            continue
        if what == "saved parameters" and not Path(path).exists():
            log(f"[autopilot] no saved parameters yet ({path})")
            continue
        applied, messages = load_file(store, path, as_defaults=as_defaults)
        for m in messages:
            log(f"[autopilot] {what}: {m}")
        log(f"[autopilot] {what}: {applied} values from {path}")
