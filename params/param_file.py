"""Parameter files in the formats ground stations use: read, write, compare.

Two text formats, told apart automatically on reading:

* QGroundControl's (also what PX4's ``param export`` tools print): one parameter a
  line, tab-separated ``system-id  component-id  NAME  VALUE  TYPE``, where TYPE is
  the MAV_PARAM_TYPE number (6 INT32, 9 REAL32; the other integer types are read
  too).  ``#`` starts a comment.
* MAVProxy's (``param save`` / ``param load``, also ArduPilot's ``.parm``):
  ``NAME VALUE`` a line, separated by blanks or one comma, ``#`` comments.  It
  carries no type: an integer-looking value is read as an int, others as floats.

Everything here is pure (text in, records out) except :func:`read_param_file`,
which only reads a file, and :func:`atomic_write_text`, which replaces one whole
(a crash leaves the old or the new file).  Values are plain numbers in the
parameters' own units; REAL32 values are written with the fewest digits that give back the
same 32-bit float.  Problems are collected per line (:class:`LineProblem`)
instead of raised, so a caller can apply the good lines and report the rest.
"""

from __future__ import annotations

import math
import os
import re
import struct
import tempfile
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterable, Mapping

from mavsim_core.param_encoding import REAL32, TYPE_NAMES, is_integer_type

QGC, MAVPROXY = "qgc", "mavproxy"
FORMATS = (QGC, MAVPROXY)

_NAME = re.compile(r"^[A-Za-z0-9_]{1,16}$")
_INT = re.compile(r"^[+-]?\d+$")


class ParamFileError(ValueError):
    """A parameter file cannot be read at all (missing, unreadable, no parameter line)."""


@dataclass(frozen=True)
class ParamEntry:
    """One parameter of a file (or of a vehicle, to be written to one).

    ``mav_type`` is the MAV_PARAM_TYPE number when known (QGroundControl files
    carry it), else None.  ``line`` is the 1-based line it came from (0 if none).
    """

    name: str
    value: int | float
    mav_type: int | None = None
    line: int = 0
    sysid: int = 1
    compid: int = 1


@dataclass(frozen=True)
class LineProblem:
    """A line that could not be read, or an entry a consumer refused, and why."""

    line: int
    reason: str
    text: str = ""

    def __str__(self) -> str:
        where = f"line {self.line}: " if self.line else ""
        shown = f" [{self.text.strip()}]" if self.text.strip() else ""
        return f"{where}{self.reason}{shown}"


@dataclass
class ParamFile:
    """What a file held: its format, the good entries in file order and the bad lines."""

    format: str
    entries: list[ParamEntry] = field(default_factory=list)
    problems: list[LineProblem] = field(default_factory=list)
    source: str = "<text>"

    def values(self) -> dict[str, int | float]:
        """Name -> value (a later line of the same name wins)."""
        return {e.name: e.value for e in self.entries}


@dataclass(frozen=True)
class ParamDiff:
    """A name whose values differ; None where one side does not have it."""

    name: str
    ours: int | float | None
    theirs: int | float | None


# --------------------------------------------------------------------------- values


def format_value(value: int | float, mav_type: int | None) -> str:
    """Text of a value: integers exactly, REAL32 with the fewest digits that read back the same float32."""
    if mav_type is not None and is_integer_type(mav_type):
        return str(int(value))
    if mav_type is None and isinstance(value, int):
        return str(value)
    v = float(value)
    if not math.isfinite(v):
        return repr(v)
    if mav_type == REAL32 or mav_type is None:
        target = _f32(v)
        for digits in range(1, 10):
            text = f"{v:.{digits}g}"
            if _f32(float(text)) == target:
                return _plain(text)
    return _plain(repr(v))


def _plain(text: str) -> str:
    """'1e+01' -> '10' where Python's %g chose an exponent for a small integer."""
    if "e" in text:
        v = float(text)
        if v == int(v) and abs(v) < 1e15:
            return str(int(v))
    return text


def _f32(v: float) -> bytes:
    try:
        return struct.pack("<f", v)
    except OverflowError:  # beyond float32: compare as doubles
        return struct.pack("<d", v)


def same_value(a: int | float, b: int | float, mav_type: int | None = None) -> bool:
    """True if two values are the same parameter value.

    REAL32 values (and untyped floats) compare as 32-bit floats, because what a
    vehicle reports went through a float32 (0.1 in a file equals 0.1f from the
    vehicle); integers compare exactly; NaN equals NaN.
    """
    if mav_type is not None and is_integer_type(mav_type):
        return float(a) == float(b)
    fa, fb = float(a), float(b)
    if math.isnan(fa) or math.isnan(fb):
        return math.isnan(fa) and math.isnan(fb)
    return fa == fb or _f32(fa) == _f32(fb)


def _number(text: str) -> int | float:
    """int for integer-looking text, else float; ValueError if neither or not finite."""
    if _INT.match(text):
        return int(text)
    v = float(text)
    if not math.isfinite(v):
        raise ValueError(f"{text} is not a finite number")
    return v


# --------------------------------------------------------------------------- reading


def _strip_comment(line: str) -> str:
    i = line.find("#")
    return (line if i < 0 else line[:i]).strip()


def _looks_qgc(fields: list[str]) -> bool:
    return len(fields) == 5 and bool(_INT.match(fields[0])) and bool(_INT.match(fields[1]))


def detect_format(text: str) -> str | None:
    """QGC or MAVPROXY from the first parameter line, or None if there is none."""
    for raw in text.splitlines():
        line = _strip_comment(raw)
        if not line:
            continue
        if _looks_qgc(line.split()):
            return QGC
        if len(re.split(r"[\s,]+", line)) == 2:
            return MAVPROXY
    return None


def parse_param_text(text: str, source: str = "<text>", fmt: str | None = None) -> ParamFile:
    """Read parameter lines (format auto-detected unless ``fmt`` is given).

    Raises :class:`ParamFileError` only when no line is a parameter line of
    either format; bad lines otherwise become :class:`LineProblem` entries.
    """
    fmt = fmt or detect_format(text)
    if fmt is None:
        raise ParamFileError(
            f"{source}: no parameter line found (expected QGroundControl's "
            "'SYSID<TAB>COMPID<TAB>NAME<TAB>VALUE<TAB>TYPE' or MAVProxy's 'NAME VALUE')"
        )
    if fmt not in FORMATS:
        raise ParamFileError(f"unknown parameter file format {fmt!r} (known: {', '.join(FORMATS)})")
    out = ParamFile(fmt, source=source)
    for number, raw in enumerate(text.splitlines(), start=1):
        line = _strip_comment(raw)
        if not line:
            continue
        try:
            out.entries.append(_parse_qgc(line, number) if fmt == QGC else _parse_mavproxy(line, number))
        except ValueError as exc:
            out.problems.append(LineProblem(number, str(exc), raw))
    return out


def _check_name(name: str) -> str:
    if not _NAME.match(name):
        raise ValueError(f"bad parameter name {name!r} (1-16 letters, digits or _)")
    return name


def _parse_qgc(line: str, number: int) -> ParamEntry:
    fields = line.split("\t") if line.count("\t") == 4 else line.split()
    fields = [f.strip() for f in fields]
    if len(fields) != 5:
        raise ValueError(f"expected 5 fields 'SYSID COMPID NAME VALUE TYPE', got {len(fields)}")
    sysid_t, compid_t, name, value_t, type_t = fields
    if not (_INT.match(sysid_t) and _INT.match(compid_t) and _INT.match(type_t)):
        raise ValueError("system id, component id and type must be integers")
    mav_type = int(type_t)
    if mav_type != REAL32 and not is_integer_type(mav_type):
        raise ValueError(f"unsupported MAV_PARAM_TYPE {mav_type} (6 INT32 and 9 REAL32 are used)")
    _check_name(name)
    try:
        value = _number(value_t)
    except ValueError:
        raise ValueError(f"{name}: value {value_t!r} is not a number") from None
    if is_integer_type(mav_type):
        if float(value) != int(value):
            raise ValueError(f"{name}: {TYPE_NAMES[mav_type]} value {value_t} is not an integer")
        value = int(value)
    else:
        value = float(value)
    return ParamEntry(name, value, mav_type, number, int(sysid_t), int(compid_t))


def _parse_mavproxy(line: str, number: int) -> ParamEntry:
    fields = [f for f in re.split(r"[\s,]+", line) if f]
    if len(fields) != 2:
        raise ValueError(f"expected 'NAME VALUE', got {len(fields)} fields")
    name, value_t = fields
    _check_name(name)
    try:
        value = _number(value_t)
    except ValueError:
        raise ValueError(f"{name}: value {value_t!r} is not a number") from None
    return ParamEntry(name, value, None, number)


def read_param_file(path: str | Path, fmt: str | None = None) -> ParamFile:
    """Read a parameter file (format auto-detected); ParamFileError if it cannot be read at all."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8", errors="replace")
    except OSError as exc:
        raise ParamFileError(f"cannot read parameter file {path}: {exc.strerror or exc}") from None
    return parse_param_text(text, str(path), fmt)


# --------------------------------------------------------------------------- writing


def format_qgc(entries: Iterable[ParamEntry], header: str = "") -> str:
    """QGroundControl's format: a comment header, then ``sysid compid name value type`` by tabs.

    Every entry needs its ``mav_type``.  ``header`` lines are added as comments.
    """
    lines = [f"# {h}" if h else "#" for h in header.splitlines()] if header else []
    lines.append("# Vehicle-Id\tComponent-Id\tName\tValue\tType")
    for e in entries:
        if e.mav_type is None:
            raise ValueError(f"{e.name}: QGroundControl's format needs the parameter type")
        lines.append(f"{e.sysid}\t{e.compid}\t{e.name}\t{format_value(e.value, e.mav_type)}\t{e.mav_type}")
    return "\n".join(lines) + "\n"


def format_mavproxy(entries: Iterable[ParamEntry], header: str = "") -> str:
    """MAVProxy's format: ``NAME VALUE`` a line (name padded to 16 characters)."""
    lines = [f"# {h}" if h else "#" for h in header.splitlines()] if header else []
    lines += [f"{e.name:<16} {format_value(e.value, e.mav_type)}" for e in entries]
    return "\n".join(lines) + "\n"


def format_params(entries: Iterable[ParamEntry], fmt: str = QGC, header: str = "") -> str:
    """Text of a parameter file in ``fmt`` (QGC or MAVPROXY)."""
    if fmt == QGC:
        return format_qgc(entries, header)
    if fmt == MAVPROXY:
        return format_mavproxy(entries, header)
    raise ValueError(f"unknown parameter file format {fmt!r} (known: {', '.join(FORMATS)})")


# --------------------------------------------------------------------------- comparing and applying


def diff_params(
    ours: Mapping[str, int | float],
    theirs: Mapping[str, int | float],
    types: Mapping[str, int] | None = None,
    only_ours: bool = False,
) -> list[ParamDiff]:
    """Names whose values differ, in name order (see :func:`same_value`; ``types`` gives MAV_PARAM_TYPEs).

    A name missing on one side is a difference with None there; with
    ``only_ours`` names that only ``theirs`` has are left out (a partial file
    compared with a vehicle's full set).
    """
    types = types or {}
    names = set(ours) if only_ours else set(ours) | set(theirs)
    out = []
    for name in sorted(names):
        a, b = ours.get(name), theirs.get(name)
        if a is None or b is None or not same_value(a, b, types.get(name)):
            out.append(ParamDiff(name, a, b))
    return out


def apply_in_passes(
    entries: Iterable[ParamEntry],
    apply: Callable[[ParamEntry], object],
    refused: type[BaseException] | tuple[type[BaseException], ...] = ValueError,
) -> list[tuple[ParamEntry, str]]:
    """Apply each entry with ``apply``; retry the refused ones while others succeed.

    Cross-parameter rules can refuse a value that becomes valid once another
    entry of the same file is applied (a higher MPC_LAND_SPEED waits for a
    higher MPC_Z_VEL_MAX_DN), so refused entries are retried in further passes
    until a pass makes no progress.  Returns the entries still refused, each
    with the text of its last refusal (``refused`` exceptions), in file order.
    """
    pending = list(entries)
    reasons: dict[int, str] = {}
    while pending:
        still = []
        for entry in pending:
            try:
                apply(entry)
            except refused as exc:
                reasons[id(entry)] = str(exc)
                still.append(entry)
        if len(still) == len(pending):
            break
        pending = still
    return [(e, reasons[id(e)]) for e in pending]


def atomic_write_text(path: str | Path, text: str) -> None:
    """Replace ``path`` by ``text`` so that a crash at any point leaves the old or the new file, whole.

    Writes a temporary file in the same directory, flushes it to the disk,
    renames it over ``path`` (atomic on POSIX and Windows) and flushes the
    directory entry (POSIX).  On error the temporary file is removed and the
    old file is untouched.
    """
    path = Path(path)
    fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
    try:
        with os.fdopen(fd, "w", encoding="utf-8") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
        os.replace(tmp, path)
    except BaseException:
        try:
            os.unlink(tmp)
        except OSError:
            pass
        raise
    try:
        dir_fd = os.open(path.parent, os.O_RDONLY)
    except OSError:
        return  # not possible on this OS (Windows); the rename is still atomic
    try:
        os.fsync(dir_fd)
    except OSError:
        pass
    finally:
        os.close(dir_fd)
