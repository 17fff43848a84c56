"""``gcs param``: list, get, set, save, load and diff a vehicle's parameters.

::

    gcs param list [PATTERN ...]       # every parameter (fnmatch patterns: 'MPC_*')
    gcs param get MPC_XY_P
    gcs param set MPC_XY_P 1.2
    gcs param save tuned.params        # QGroundControl format (--format mavproxy: NAME VALUE)
    gcs param load tuned.params        # set every value that differs; each refusal with its reason
    gcs param diff tuned.params        # names whose values differ between the file and the vehicle

Files are read in either format (auto-detected, see :mod:`params.param_file`).
The full download shows a progress bar on stderr when it is a terminal and
always ends with one line saying how many parameters came in how long.
Each request is sent again every 0.5 s until the vehicle answers (a set: until it echoes the
value); a name the vehicle does not have is reported as such at once.  Exit codes as for every
``gcs`` command: 0 done, 1 refused (an unknown name, any value refused, any bad line in a file),
2 usage error, 3 no answer from the vehicle.
"""

from __future__ import annotations

import argparse
import fnmatch
import sys
import time
from typing import TextIO

from mavsim_core.param_encoding import TYPE_NAMES, is_integer_type
from params.param_file import (
    FORMATS,
    QGC,
    ParamEntry,
    ParamFileError,
    apply_in_passes,
    atomic_write_text,
    diff_params,
    format_params,
    format_value,
    read_param_file,
    same_value,
)

from . import cli_types
from .client import VehicleClient
from .errors import EXIT_OK, EXIT_REFUSED, ParamListError, ParamRefused
from .plugins.param import DownloadStats, VehicleParam, download_parameters

DOWNLOAD_TIMEOUT_S = 30.0  # wall seconds for the full download unless --timeout is given


def add_param_parser(sub: argparse._SubParsersAction) -> None:
    """The ``param`` sub-command and its own sub-commands."""
    p = sub.add_parser("param", help="list, read, write, save, load or compare parameters")
    psub = p.add_subparsers(dest="param_command", required=True, metavar="list|get|set|save|load|diff")
    s = psub.add_parser("list", help="download and print every parameter (progress on stderr)")
    s.add_argument("patterns", nargs="*", metavar="PATTERN", help="only names matching these (fnmatch, e.g. 'MPC_*')")
    g = psub.add_parser("get", help="print a parameter")
    g.add_argument("name", type=cli_types.param_name, metavar="NAME")
    s = psub.add_parser("set", help="set a parameter (its type is read from the vehicle first)")
    s.add_argument("name", type=cli_types.param_name, metavar="NAME")
    s.add_argument(
        "value", type=cli_types.finite, metavar="VALUE", help="a finite number (an integer for INT32 parameters)"
    )
    s = psub.add_parser("save", help="download every parameter and write them to FILE ('-': stdout)")
    s.add_argument("file", metavar="FILE")
    s.add_argument(
        "--format",
        choices=FORMATS,
        default=QGC,
        help="qgc: QGroundControl's tab-separated file (default); mavproxy: NAME VALUE lines",
    )
    s = psub.add_parser("load", help="set every parameter of FILE whose value differs on the vehicle")
    s.add_argument("file", metavar="FILE")
    s = psub.add_parser("diff", help="print the parameters of FILE whose values differ on the vehicle")
    s.add_argument("file", metavar="FILE")


class ProgressBar:
    """``progress(received, count)`` callback drawing ``[####....] 40/83 parameters`` on a terminal."""

    def __init__(self, stream: TextIO | None = None, width: int = 30, min_interval_s: float = 0.05) -> None:
        self.stream = stream if stream is not None else sys.stderr
        self.width = width
        self.min_interval_s = min_interval_s
        self.tty = bool(getattr(self.stream, "isatty", lambda: False)())
        self._last_draw = -1.0
        self._shown = 0

    def __call__(self, received: int, count: int) -> None:
        if not self.tty:
            return
        now = time.monotonic()
        if received < count and now - self._last_draw < self.min_interval_s:
            return
        self._last_draw = now
        filled = self.width * received // count if count else self.width
        text = f"[{'#' * filled}{'.' * (self.width - filled)}] {received}/{count} parameters"
        self.stream.write("\r" + text)
        self.stream.flush()
        self._shown = len(text)

    def finish(self, line: str) -> None:
        """Clear the bar and print a final line."""
        if self.tty and self._shown:
            self.stream.write("\r" + " " * self._shown + "\r")
        self.stream.write(line + "\n")
        self.stream.flush()


def _err(text: str) -> None:
    print(f"gcs: {text}", file=sys.stderr)


def check_file(args: argparse.Namespace) -> int | None:
    """Before connecting: ``param load`` / ``diff`` of a file that cannot be read is refused (exit 1) at once."""
    if args.param_command not in ("load", "diff"):
        return None
    try:
        read_param_file(args.file)
    except ParamFileError as exc:
        _err(f"param {args.param_command}: {exc}")
        return EXIT_REFUSED
    return None


def _download(client: VehicleClient, args: argparse.Namespace) -> list[VehicleParam]:
    bar = ProgressBar()
    stats = DownloadStats()
    try:
        params = download_parameters(client, bar, args.timeout or DOWNLOAD_TIMEOUT_S, stats)
    except BaseException:
        bar.finish("parameter download failed")
        raise
    again = f", {stats.re_requested} asked for again" if stats.re_requested else ""
    bar.finish(f"downloaded {len(params)} parameters in {stats.elapsed_s:.2f} s{again}")
    return params


def _show(value: int | float, mav_type: int | None) -> str:
    return format_value(value, mav_type)


def run_param_command(client: VehicleClient, args: argparse.Namespace) -> int:
    """Run ``gcs param ...``; the exit code (timeouts and refused single sets propagate as exceptions)."""
    command = args.param_command
    try:
        if command == "get":
            value = client.param_get(args.name)
            print(f"{args.name} = {_show(value, client.param.type_of(args.name))}")
            return EXIT_OK
        if command == "set":
            value = args.value
            if value == int(value):
                value = int(value)
            got = client.param_set(args.name, value)
            print(f"{args.name} = {_show(got, client.param.type_of(args.name))}")
            return EXIT_OK
        if command == "list":
            return _list(client, args)
        if command == "save":
            return _save(client, args)
        if command == "load":
            return _load(client, args)
        if command == "diff":
            return _diff(client, args)
    except ParamListError as exc:
        _err(str(exc))
        return EXIT_REFUSED
    except ParamFileError as exc:
        _err(str(exc))
        return EXIT_REFUSED
    raise ValueError(f"unknown param command {command!r}")


def _list(client: VehicleClient, args: argparse.Namespace) -> int:
    params = _download(client, args)
    patterns = [p.upper() for p in args.patterns]
    for p in params:
        if not patterns or any(fnmatch.fnmatchcase(p.name, pat) for pat in patterns):
            print(f"{p.name:<16} {_show(p.value, p.mav_type)}")
    return EXIT_OK


def _save(client: VehicleClient, args: argparse.Namespace) -> int:
    params = _download(client, args)
    entries = [
        ParamEntry(p.name, p.value, p.mav_type, 0, client.target_system, client.target_component) for p in params
    ]
    header = (
        f"Onboard parameters for Vehicle {client.target_system}\n\nSaved by gcs param save ({len(entries)} parameters)"
    )
    text = format_params(entries, args.format, header)
    if args.file == "-":
        sys.stdout.write(text)
        return EXIT_OK
    try:  # atomic: a crash mid-save keeps the old file
        atomic_write_text(args.file, text)
    except OSError as exc:
        _err(f"cannot write {args.file}: {exc.strerror or exc}")
        return EXIT_REFUSED
    fmt = "QGroundControl" if args.format == QGC else "MAVProxy"
    print(f"saved {len(entries)} parameters to {args.file} ({fmt} format)")
    return EXIT_OK


def _read_file(client: VehicleClient, path: str) -> tuple[list[ParamEntry], int]:
    """The entries of a file meant for this component, and how many bad lines were reported."""
    pf = read_param_file(path)
    for problem in pf.problems:
        _err(f"{path}, {problem}")
    entries = []
    for e in pf.entries:
        if pf.format == QGC and e.compid != client.target_component:
            print(f"{path}, line {e.line}: {e.name} is for component {e.compid}, skipped", file=sys.stderr)
            continue
        entries.append(e)
    return entries, len(pf.problems)


def _typed(entry: ParamEntry, vp: VehicleParam) -> int | float:
    """The file's value in the vehicle's type; ValueError saying why it does not fit."""
    if entry.mav_type is not None and entry.mav_type != vp.mav_type:
        have = TYPE_NAMES.get(entry.mav_type, str(entry.mav_type))
        raise ValueError(
            f"{entry.name} is {TYPE_NAMES.get(vp.mav_type, vp.mav_type)} on the vehicle, {have} in the file"
        )
    if is_integer_type(vp.mav_type):
        if float(entry.value) != int(entry.value):
            raise ValueError(f"{entry.name} is an integer on the vehicle, {entry.value} is not")
        return int(entry.value)
    return float(entry.value)


def _load(client: VehicleClient, args: argparse.Namespace) -> int:
    entries, failures = _read_file(client, args.file)
    on_vehicle = {p.name: p for p in _download(client, args)}
    to_set: list[ParamEntry] = []
    unchanged = 0
    for e in entries:
        vp = on_vehicle.get(e.name)
        if vp is None:
            _err(f"{args.file}, line {e.line}: {e.name} refused: the vehicle has no such parameter")
            failures += 1
            continue
        try:
            value = _typed(e, vp)
        except ValueError as exc:
            _err(f"{args.file}, line {e.line}: {e.name} refused: {exc}")
            failures += 1
            continue
        if same_value(value, vp.value, vp.mav_type):
            unchanged += 1
        else:
            to_set.append(ParamEntry(e.name, value, vp.mav_type, e.line))

    def apply(e: ParamEntry) -> None:
        got = client.param_set(e.name, e.value, e.mav_type)
        print(f"{e.name}: {_show(on_vehicle[e.name].value, e.mav_type)} -> {_show(got, e.mav_type)}")

    refused = apply_in_passes(to_set, apply, ParamRefused)
    for e, reason in refused:
        _err(f"{args.file}, line {e.line}: {e.name} refused: {reason}")
    failures += len(refused)
    print(
        f"loaded {args.file}: {len(to_set) - len(refused)} set, {unchanged} unchanged, {failures} refused or unreadable"
    )
    return EXIT_REFUSED if failures else EXIT_OK


def _diff(client: VehicleClient, args: argparse.Namespace) -> int:
    entries, failures = _read_file(client, args.file)
    params = _download(client, args)
    types = {p.name: p.mav_type for p in params}
    ours = {e.name: e.value for e in entries}
    diffs = diff_params(ours, {p.name: p.value for p in params}, types, only_ours=True)
    if diffs:
        print(f"{'NAME':<16} {'FILE':>14} {'VEHICLE':>14}")
    for d in diffs:
        mav_type = types.get(d.name)
        vehicle = _show(d.theirs, mav_type) if d.theirs is not None else "(none)"
        print(f"{d.name:<16} {_show(d.ours, mav_type):>14} {vehicle:>14}")
    print(f"{len(diffs)} of {len(ours)} parameters differ", file=sys.stderr)
    return EXIT_REFUSED if failures else EXIT_OK
