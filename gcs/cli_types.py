"""argparse ``type`` functions of the ``gcs`` command line: each checks one kind of value.

A value that does not fit raises :class:`argparse.ArgumentTypeError` with a message naming the allowed
range, so argparse prints one ``gcs ...: error: argument NAME: ...`` line and exits 2 (a usage error)
before anything is sent to the vehicle.
"""

from __future__ import annotations

import argparse
import math

from mavsim_core import px4_modes as modes
from mavsim_core.cli_checks import finite_number, number_in, positive_int, positive_number

__all__ = ["altitude", "finite", "fraction", "heading_deg", "latitude", "longitude", "mode_name", "param_name"]
__all__ += ["positive", "positive_int"]

PARAM_ID_LEN = 16  # bytes of a MAVLink parameter name


finite = finite_number
positive = positive_number  # seconds, m/s, Hz


def fraction(text: str) -> float:
    """A number 0..1 (a stick deflection)."""
    return number_in(text, 0.0, 1.0)


def altitude(text: str) -> float:
    """Metres: a finite number, or ``nan`` for "the vehicle's default"."""
    try:
        value = float(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a number of metres (or nan: the default), not {text!r}") from None
    if math.isinf(value):
        raise argparse.ArgumentTypeError(f"must be a finite number of metres (or nan: the default), not {text!r}")
    return value


def latitude(text: str) -> float:
    """Degrees -90..90."""
    return number_in(text, -90.0, 90.0, "latitude")


def longitude(text: str) -> float:
    """Degrees -180..180."""
    return number_in(text, -180.0, 180.0, "longitude")


def heading_deg(text: str) -> float:
    """A heading, degrees -360..360 (0 north, 90 east)."""
    return number_in(text, -360.0, 360.0, "heading")


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
