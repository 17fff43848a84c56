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

Saving: the ground-station link has the changes written (:meth:`ParamSaver.request_save`, by the
saver's own thread, so the control loop never waits on the disk) before it sends the PARAM_VALUEs
that acknowledge them, so every change a ground station saw acknowledged is on the disk: the
PARAM_SETs handled since the link's last update (50 Hz of simulated time) go into one write.
:meth:`ParamSaver.close` writes what is left at exit.  Each write is atomic (temporary file in the
same directory, fsync, ``os.replace``, fsync of the directory), so a crash at any moment leaves
either the old or the new complete file; the temporary file a crash left is removed at the next
start, and a state file that cannot be read is kept as ``*.corrupt`` and the defaults used
(:func:`load_saved_state`).  A write that fails is reported (stderr and, by the link, STATUSTEXT);
the value stays in use until a restart, as PX4 keeps a parameter it could not save.  (PX4 itself
acknowledges first and saves 300 ms later, at most every 2 s: its ``param_autosave``.)
"""

from __future__ import annotations

import os
import sys
import threading
from pathlib import Path
from typing import Callable, NamedTuple

from autopilot.parameters import ParamError, ParameterStore, ParamType
from mavsim_core.param_encoding import INT32, REAL32, is_integer_type
from params.param_file import (
    QGC,
    LineProblem,
    ParamEntry,
    ParamFileError,
    apply_in_passes,
    atomic_write_text,
    format_qgc,
    read_param_file,
)

KEPT_OUTCOMES = 64  # save outcomes kept for the asking (a caller asks about its latest ticket)
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
        ptype: str | None = None  # (a ParamType is a str)
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


class SaveOutcome(NamedTuple):
    """How a requested save ended: ``ok``, else ``reason`` (the OS's words)."""

    ok: bool
    reason: str = ""


class ParamSaver:
    """Keeps ``path`` equal to the store's changed parameters (QGroundControl format), written by its thread.

    :meth:`request_save` (the control loop's thread) takes a snapshot of the changed values at once
    (~0.2 ms) and returns a ticket; the ``param-saver`` thread writes it (atomic, fsync: 1-15 ms,
    never in the control loop) and :meth:`save_outcome` then tells how it went.  The link sends the
    PARAM_VALUEs that acknowledge the changes only after their ticket's outcome is in
    (:mod:`autopilot.mavlink.param_service`).  Requests made while a write runs are merged: the newest
    snapshot is written and answers them all.  A snapshot equal to the file's content is not written
    again.  Write errors go to ``report`` (stderr by default) and into the outcome; the next request
    tries again.  :meth:`save` (MAV_CMD_PREFLIGHT_STORAGE) and :meth:`close` (at exit) wait for
    their write.  With ``initial_save`` the file is written at construction.
    """

    def __init__(
        self,
        store: ParameterStore,
        path: str | Path,
        *,
        vehicle_name: str = "",
        initial_save: bool = False,
        report: Callable[[str], None] | None = None,
    ) -> None:
        self.store = store
        self.path = Path(path)
        self.vehicle_name = vehicle_name
        self.report = report or (lambda text: print(text, file=sys.stderr, flush=True))
        self.saves = 0  # files written
        self.failures = 0  # writes that failed
        self._written: str | None = None  # the text of the last file written (the writer's)
        self._cv = threading.Condition()
        self._tickets = 0  # the last ticket given
        self._request: tuple[int, str, bool] | None = None  # (ticket, text, force) waiting for the writer
        self._outcomes: dict[int, SaveOutcome] = {}  # of the last KEPT_OUTCOMES tickets answered
        self._answered = 0  # the last ticket with an outcome
        self._stop = False
        self._thread = threading.Thread(target=self._run, name="param-saver", daemon=True)
        self._thread.start()
        if initial_save:
            self.save()

    def request_save(self, *, force: bool = False) -> int:
        """Snapshot the changed parameters for the writer thread; the ticket to ask :meth:`save_outcome`."""
        header = (
            f"Parameters of {self.vehicle_name or 'the vehicle'} changed from its defaults\n"
            "saved by the autopilot and loaded at its start-up"
        )
        text = format_qgc(store_entries(self.store, list(self.store.changed())), header)
        with self._cv:
            self._tickets += 1
            earlier_force = self._request is not None and self._request[2]
            self._request = (self._tickets, text, force or earlier_force)
            self._cv.notify_all()
            return self._tickets

    def save_outcome(self, ticket: int) -> SaveOutcome | None:
        """How the save of ``ticket`` went, or None while it is being written."""
        with self._cv:
            return self._outcomes.get(ticket)

    def wait(self, ticket: int, timeout_s: float = 10.0) -> SaveOutcome:
        """Block until the save of ``ticket`` is done (a failure if it takes longer than ``timeout_s``)."""
        with self._cv:
            if not self._cv.wait_for(lambda: ticket in self._outcomes, timeout_s):
                return SaveOutcome(False, f"no write within {timeout_s:g} s")
            return self._outcomes[ticket]

    def save(self) -> bool:
        """Write the changed parameters now and wait for it; False (and a report) if the write failed."""
        return self.wait(self.request_save(force=True)).ok

    def _run(self) -> None:
        while True:
            with self._cv:
                self._cv.wait_for(lambda: self._request is not None or self._stop)
                if self._request is None:
                    return
                ticket, text, force = self._request
                self._request = None
            outcome = self._write(text, force)
            with self._cv:
                for t in range(self._answered + 1, ticket + 1):  # this write answers every request merged into it
                    self._outcomes[t] = outcome
                self._answered = ticket
                for t in [t for t in self._outcomes if t <= ticket - KEPT_OUTCOMES]:
                    del self._outcomes[t]
                self._cv.notify_all()

    def _write(self, text: str, force: bool) -> SaveOutcome:
        if text == self._written and not force:
            return SaveOutcome(True)
        try:
            atomic_write_text(self.path, text)
        except OSError as exc:
            self.failures += 1
            reason = exc.strerror or str(exc)
            self.report(f"[autopilot] cannot save parameters to {self.path}: {reason}")
            return SaveOutcome(False, reason)
        self._written = text
        self.saves += 1
        return SaveOutcome(True)

    def close(self) -> None:
        """Write what is not saved yet, wait for it and stop the thread (idempotent)."""
        if self._thread.is_alive():
            self.wait(self.request_save())
            with self._cv:
                self._stop = True
                self._cv.notify_all()
            self._thread.join(timeout=5.0)


def remove_stale_temporaries(state_path: str | Path, log: Callable[[str], None] = print) -> list[Path]:
    """Delete the temporary files a write killed mid-way left beside ``state_path``; the paths removed.

    :func:`atomic_write_text` writes ``.<name>.<random>.tmp`` in the same directory; every file this
    vehicle and instance keeps there (parameters, plans, signing key) starts with the state file's
    stem (``quad_x-3``), so ``.quad_x-3.*.tmp`` are ours and other instances' are left alone.
    """
    path = Path(state_path)
    removed = []
    for tmp in sorted(path.parent.glob(f".{path.stem}.*.tmp")):
        try:
            tmp.unlink()
        except OSError as exc:
            log(f"[autopilot] cannot remove the stale temporary file {tmp}: {exc.strerror or exc}")
            continue
        removed.append(tmp)
    if removed:
        log(f"[autopilot] removed {len(removed)} temporary file(s) an interrupted save left in {path.parent}")
    return removed


def keep_corrupt(path: str | Path) -> Path:
    """Rename a damaged state file to ``<name>.corrupt`` (``<name>.N.corrupt`` if taken); the new path."""
    path = Path(path)
    kept = path.with_name(path.name + ".corrupt")
    n = 1
    while kept.exists():
        kept = path.with_name(f"{path.name}.{n}.corrupt")
        n += 1
    os.replace(path, kept)
    return kept


def load_saved_state(store: ParameterStore, path: str | Path, log: Callable[[str], None] = print) -> list[str]:
    """Apply the state file the flight controller wrote; the warnings for the ground station.

    The file is ours, written whole (:func:`atomic_write_text`): a line that cannot be read, or a
    file that cannot be read at all, means it was damaged.  Then none of it is applied (a partial
    set could mix values that belong together), it is kept as ``*.corrupt`` for the user and the
    defaults are used.  Entries the store refuses (a parameter that no longer exists, a value now out
    of range) are logged and skipped, the rest applied.
    """
    path = Path(path)
    try:
        pf = read_param_file(path, QGC)
        damage = "; ".join(f"line {p.line}: {p.reason}" for p in pf.problems[:2]) or None
    except ParamFileError as exc:
        damage = str(exc)
    if damage is not None:
        try:
            kept: Path | str = keep_corrupt(path)
        except OSError as exc:
            kept = f"nowhere ({exc.strerror or exc})"
        log(f"[autopilot] saved parameters: {path} is corrupt ({damage}); kept as {kept}, defaults used")
        return [f"Saved parameters corrupt, defaults used; file kept as {Path(kept).name}"]
    applied, problems = apply_entries(store, pf.entries)
    for p in problems:
        log(f"[autopilot] saved parameters: {path}, {p}")
    log(f"[autopilot] saved parameters: {applied} values from {path}")
    return []


def prepare_parameters(
    store: ParameterStore,
    *,
    vehicle_toml: str | Path | None = None,
    state_path: str | Path | None = None,
    params_path: str | Path | None = None,
    log: Callable[[str], None] = print,
) -> list[str]:
    """Fill the store at start-up from the vehicle defaults, the saved state and ``--params`` (in that order).

    Every problem is logged (with file and line) and skipped; nothing here stops the flight
    controller from starting.  Vehicle defaults that are refused (all or nothing) also become a
    warning.  Before the saved state is read, the temporary files an interrupted save left beside
    it are removed; a damaged state file is kept as ``*.corrupt`` (:func:`load_saved_state`).
    Returns the warnings a ground station should see (STATUSTEXT).
    """
    warnings: list[str] = []
    defaults = vehicle_defaults_file(vehicle_toml) if vehicle_toml is not None else None
    if defaults is not None and _load_logged(store, defaults, "vehicle defaults", log, as_defaults=True) == 0:
        # All or nothing: one value out of range and the vehicle would fly on the declared defaults unnoticed.
        warnings.append(f"Vehicle defaults {defaults.name} refused (see the log): declared defaults used")
    if state_path is not None:
        remove_stale_temporaries(state_path, log)
        if Path(state_path).exists():
            warnings += load_saved_state(store, state_path, log)
        else:
            log(f"[autopilot] no saved parameters yet ({state_path})")
    if params_path is not None:
        _load_logged(store, params_path, "parameter file", log)
    return warnings


def _load_logged(
    store: ParameterStore, path: str | Path, what: str, log: Callable[[str], None], *, as_defaults: bool = False
) -> int:
    """Load ``path`` (logging each problem and the count); the number of values applied."""
    applied, messages = load_file(store, path, as_defaults=as_defaults)
    for m in messages:
        log(f"[autopilot] {what}: {m}")
    log(f"[autopilot] {what}: {applied} values from {path}")
    return applied
