"""Checked option values and one-line start-up failures, shared by the console scripts.

:mod:`mavsim_core.cli_args` gives every script the same ``-i/--instance``, ``--version`` and exit
codes; this module gives them the same checks of the other values, so a bad value is argparse's one
``error:`` line naming the option (exit 2) at parse time, before anything starts:

- argparse ``type`` functions: :func:`finite_number`, :func:`number_in`, :func:`positive_number`,
  :func:`non_negative_number`, :func:`non_negative_int`, :func:`positive_int`, :func:`port_or_zero`, :func:`system_id`,
  :func:`host_address`;
- :func:`startup_failed`: what a script prints when starting fails anyway (a port already in use,
  a directory that cannot be created, a file that cannot be read): one line, exit 1, never a
  traceback.  Only the start-up is wrapped so: a bug inside the running loop keeps its traceback.
"""

from __future__ import annotations

import argparse
import errno
import math
import socket
import sys
from pathlib import Path

from mavsim_core.cli_args import EXIT_FAILED, port_number

EXIT_INTERRUPTED = 130  # Ctrl-C, as a shell reports it


def finite_number(text: str) -> float:
    """argparse ``type``: a finite number (no nan, no inf)."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number, not {text!r}") from None
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number, not {text!r}")
    return value


def positive_number(text: str) -> float:
    """argparse ``type``: a finite number > 0."""
    value = finite_number(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, not {text}")
    return value


def number_in(text: str, low: float, high: float, what: str = "") -> float:
    """A finite number ``low``..``high``; ``what`` names it in the message ("latitude")."""
    value = finite_number(text)
    if not low <= value <= high:
        raise argparse.ArgumentTypeError(f"{what + ' ' if what else ''}must be {low:g}..{high:g}, not {text}")
    return value


def non_negative_number(text: str) -> float:
    """argparse ``type``: a finite number >= 0."""
    value = finite_number(text)
    if value < 0:
        raise argparse.ArgumentTypeError(f"must be >= 0, not {text}")
    return value


def _integer(text: str, low: int, high: int | None, what: str) -> int:
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be {what}, not {text!r}") from None
    if value < low or (high is not None and value > high):
        raise argparse.ArgumentTypeError(f"must be {what}, not {value}")
    return value


def non_negative_int(text: str) -> int:
    """argparse ``type``: an integer >= 0 (a seed, a camera index, a marker id)."""
    return _integer(text, 0, None, "an integer >= 0")


def positive_int(text: str) -> int:
    """argparse ``type``: an integer >= 1 (a count)."""
    return _integer(text, 1, None, "an integer >= 1")


def system_id(text: str) -> int:
    """argparse ``type``: a MAVLink system id 1-255."""
    return _integer(text, 1, 255, "a MAVLink system id 1-255")


def port_or_zero(text: str) -> int:
    """argparse ``type``: a port number 1-65535, or 0 (the option's "none" or "any": its help says which)."""
    if text.strip() == "0":
        return 0
    try:
        return port_number(text)
    except argparse.ArgumentTypeError:
        raise argparse.ArgumentTypeError(f"must be 0 or a port number 1-65535, not {text!r}") from None


def host_address(text: str) -> str:
    """argparse ``type``: a host name or IPv4 address that resolves (returned as given)."""
    try:
        socket.getaddrinfo(text, None, socket.AF_INET)
    except (socket.gaierror, UnicodeError) as exc:
        reason = exc.strerror if isinstance(exc, socket.gaierror) else str(exc)
        raise argparse.ArgumentTypeError(f"cannot resolve {text!r}: {reason}") from None
    return text


def in_use_hint(instance: int | None) -> str:
    """What to do about a port already in use (appended to the message that names the port)."""
    if instance is None:
        return "is another program using it?"
    return f"is another stack running as instance {instance}? choose another -i"


def failure_text(exc: BaseException, instance: int | None = None) -> str:
    """An OSError or ValueError met while starting, as one line (the file or port it names first)."""
    if isinstance(exc, OSError):
        reason = exc.strerror or str(exc)
        text = f"{exc.filename}: {reason}" if exc.filename else reason
        if exc.errno == errno.EADDRINUSE:
            text = f"{text}: {in_use_hint(instance)}"
    else:
        text = str(exc) or type(exc).__name__
    return " ".join(text.split())  # one line, whatever the message held


def startup_failed(prog: str, exc: BaseException, instance: int | None = None) -> int:
    """Print ``PROG: MESSAGE`` for a failed start (one line on stderr); the exit code (1, 130 for Ctrl-C)."""
    if isinstance(exc, KeyboardInterrupt):
        return EXIT_INTERRUPTED
    print(f"{prog}: {failure_text(exc, instance)}", file=sys.stderr, flush=True)
    return EXIT_FAILED


def make_dir(option: str, path: str) -> None:
    """Create an output directory option's directory (and its parents); OSError naming the option if not."""
    try:
        Path(path).mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise OSError(exc.errno, f"{option} {path}: cannot create the directory: {exc.strerror or exc}") from None


def check_readable(option: str, path: str) -> None:
    """Open an input file option's file once; OSError naming the option if it cannot be read."""
    try:
        with open(path, "rb"):
            pass
    except OSError as exc:
        raise OSError(exc.errno, f"{option} {path}: cannot read it: {exc.strerror or exc}") from None
