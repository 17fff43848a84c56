"""argparse ``type`` functions of the ``gcs`` command line: each checks one kind of value.

A value that does not fit raises :class:`argparse.ArgumentTypeError` with a message naming the allowed
range, so argparse prints one ``gcs ...: error: argument NAME: ...`` line and exits 2 (a usage error)
before anything is sent to the vehicle.
"""

from __future__ import annotations

import argparse
import math

from mavsim_core import px4_modes as modes

PARAM_ID_LEN = 16  # bytes of a MAVLink parameter name


def _number(text: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"not a number: {text!r}") from None


def finite(text: str) -> float:
    """A finite number (no nan, no inf)."""
    value = _number(text)
    if not math.isfinite(value):
        raise argparse.ArgumentTypeError(f"must be a finite number, not {text!r}")
    return value


def positive(text: str) -> float:
    """A finite number > 0 (seconds, m/s, Hz)."""
    value = finite(text)
    if not value > 0:
        raise argparse.ArgumentTypeError(f"must be > 0, not {text!r}")
    return value


def positive_int(text: str) -> int:
    """A whole number >= 1 (a count, a resolution)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a whole number >= 1, not {text!r}") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"must be a whole number >= 1, not {value}")
    return value


def fraction(text: str) -> float:
    """A number 0..1 (a stick deflection)."""
    value = finite(text)
    if not 0.0 <= value <= 1.0:
        raise argparse.ArgumentTypeError(f"must be 0-1, not {text!r}")
    return value


def altitude(text: str) -> float:
    """Metres: a finite number, or ``nan`` for "the vehicle's default"."""
    value = _number(text)
    if math.isinf(value):
        raise argparse.ArgumentTypeError(f"must be a finite number of metres (or nan: the default), not {text!r}")
    return value


def latitude(text: str) -> float:
    """Degrees -90..90."""
    value = finite(text)
    if not -90.0 <= value <= 90.0:
        raise argparse.ArgumentTypeError(f"latitude must be -90..90 degrees, not {text}")
    return value


def longitude(text: str) -> float:
    """Degrees -180..180."""
    value = finite(text)
    if not -180.0 <= value <= 180.0:
        raise argparse.ArgumentTypeError(f"longitude must be -180..180 degrees, not {text}")
    return value


def heading_deg(text: str) -> float:
    """A heading, degrees -360..360 (0 north, 90 east)."""
    value = finite(text)
    if not -360.0 <= value <= 360.0:
        raise argparse.ArgumentTypeError(f"must be -360..360 degrees, not {text}")
    return value


def param_name(text: str) -> str:
    """A MAVLink parameter name: 1-16 ASCII characters."""
    if not text or not text.isascii() or len(text) > PARAM_ID_LEN:
        raise argparse.ArgumentTypeError(f"a parameter name is 1-{PARAM_ID_LEN} ASCII characters, not {text!r}")
    return text


def mode_name(text: str) -> str:
    """A PX4 mode name the mode table knows (any accepted spelling); the text as given."""
    try:
        modes.lookup_mode(text)
    except modes.UnknownModeError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None
    return text
