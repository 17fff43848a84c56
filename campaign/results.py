"""The results file: one CSV, a row appended and flushed as each run ends, so a campaign can resume.

Columns: ``run_id, cell, index, label``, the cell's axis values, the run's random draws, ``status``
(ok / flight_failed / infra_failed), ``reason``, ``attempts``, the recorded figures, then ``instance``,
``host`` (where it ran: they differ between executors) and ``campaign`` (the campaign's
name:digest, :meth:`~campaign.spec.Campaign.digest`).  Floats are written in full (Python's
shortest round-trip repr), so two files can be compared exactly.

Resuming (:meth:`ResultsFile.open` with ``resume``): the runs whose row says ok or flight_failed are
done; an infra_failed run is run again (its newer row counts: :func:`read` keeps the last row of
each run id).  A row cut short by a kill is ignored.  A file written by another campaign (another
digest or other columns) is refused.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path
from typing import Any

from .plan import Run
from .spec import Campaign

DONE = ("ok", "flight_failed")
# Columns that depend on where and how fast a run went, not on what it flew (left out of comparisons).  A landing's
# detections per second divide by every frame the camera took until its stack was stopped, a wall-clock moment
# after the flight (a frame more or less: 4.778 against 4.765 a second, the suite, 2026-12-06).
WALL_COLUMNS = ("wall_s", "real_time_factor", "instance", "host", "attempts", "detections_per_s")


class ResultsError(RuntimeError):
    """A results file that does not belong to this campaign, or cannot be written."""


def columns(campaign: Campaign, runs: list[Run]) -> list[str]:
    kind = campaign.kind_()
    axes = [a.name for a in kind.axes]
    draws = [r.name for r in kind.ranges]
    head = ["run_id", "cell", "index", "label", *axes, *draws, "status", "reason", "attempts"]
    return head + list(campaign.record) + ["instance", "host", "campaign"]


def tag(campaign: Campaign) -> str:
    return f"{campaign.name}:{campaign.digest()}"


def read(path: Path) -> list[dict[str, str]]:
    """The complete rows of a results file (the last one of each run id), as strings; [] if none."""
    try:
        text = path.read_text()
    except FileNotFoundError:
        return []
    if not text.endswith("\n"):  # the last row was cut short by a kill: drop it
        text = text[: text.rfind("\n") + 1]
    reader = csv.DictReader(io.StringIO(text))
    rows: dict[str, dict[str, str]] = {}
    for row in reader:
        if None in row or None in row.values():  # too many or too few fields: a row cut short
            continue
        rows[row["run_id"]] = row
    return list(rows.values())


def value(text: str) -> Any:
    """A CSV cell back as a number, a bool or the string itself."""
    if text in ("True", "False"):
        return text == "True"
    try:
        return int(text)
    except ValueError:
        pass
    try:
        return float(text)
    except ValueError:
        return text


class ResultsFile:
    """The CSV of one campaign, open for appending rows."""

    def __init__(self, path: Path, fieldnames: list[str]) -> None:
        self.path = path
        self.fieldnames = fieldnames
        self._f: io.TextIOWrapper | None = None
        self._w: csv.DictWriter | None = None

    @classmethod
    def open(cls, path: Path, campaign: Campaign, runs: list[Run], resume: bool) -> tuple["ResultsFile", set[str]]:
        """The file, ready to append, and the run ids already done (empty unless ``resume``)."""
        names = columns(campaign, runs)
        results = cls(path, names)
        done: set[str] = set()
        exists = path.exists() and path.stat().st_size > 0
        if exists and not resume:
            raise ResultsError(f"{path} exists: add --resume to go on with it, or choose another --out")
        if exists:
            with path.open(newline="") as f:
                header = next(csv.reader(f), [])
            if header != names:
                raise ResultsError(f"{path} has other columns than this campaign's: not its results file")
            rows = read(path)
            if any(r["campaign"] != tag(campaign) for r in rows):
                raise ResultsError(f"{path} was written by another campaign file (not {tag(campaign)})")
            done = {r["run_id"] for r in rows if r["status"] in DONE}
            data = path.read_bytes()
            if not data.endswith(b"\n"):  # a row cut short by a kill: drop it
                path.write_bytes(data[: data.rfind(b"\n") + 1])
        path.parent.mkdir(parents=True, exist_ok=True)
        results._f = path.open("a", newline="")
        results._w = csv.DictWriter(results._f, fieldnames=names)
        if not exists:
            results._w.writeheader()
            results._f.flush()
        return results, done

    def append(self, row: dict[str, Any]) -> None:
        assert self._w is not None and self._f is not None
        self._w.writerow({k: _text(v) for k, v in row.items()})
        self._f.flush()

    def close(self) -> None:
        if self._f is not None:
            self._f.close()
            self._f = None

    def __enter__(self) -> "ResultsFile":
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _text(v: Any) -> Any:
    if isinstance(v, float) and math.isnan(v):
        return "nan"
    return v
