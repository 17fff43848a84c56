"""What every console script's command line shares: ``-i/--instance``, ``--version``, the exit codes.

Each console script (``sitl``, ``autopilot``, ``gcs``, ``flight-demo``, ``python -m vision``) builds its
argparse parser with these, so a bad invocation is one line that names the option and its allowed
range (argparse's own ``usage`` + ``error:`` lines, exit 2) and never a traceback.

Exit codes (the same in every script, printed by each ``--help``):

- 0 done;
- 1 refused or failed (the vehicle refused a command, a file could not be read, a port is taken);
- 2 usage error (argparse's own code);
- 3 no answer from the vehicle (``gcs``: the heartbeat, the acknowledgement or the effect did not come).
"""

from __future__ import annotations

import argparse
from importlib import metadata

from mavsim_core import ports

EXIT_OK = 0
EXIT_FAILED = 1
EXIT_USAGE = 2
EXIT_NO_ANSWER = 3

EXIT_CODES_EPILOG = "Exit codes: 0 done, 1 refused or failed, 2 usage error, 3 no answer from the vehicle."

DISTRIBUTION = "mavsim-flight"  # the name in pyproject.toml


def version() -> str:
    """The installed version of this project (``pyproject.toml``), or ``"unknown"`` when run from a bare tree."""
    try:
        return metadata.version(DISTRIBUTION)
    except metadata.PackageNotFoundError:
        return "unknown"


def instance_number(text: str) -> int:
    """argparse ``type`` of ``-i/--instance``: an integer 0-99 (PX4's port scheme leaves room for no more)."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be an integer 0-{ports.MAX_INSTANCE}, not {text!r}") from None
    if not 0 <= value <= ports.MAX_INSTANCE:
        raise argparse.ArgumentTypeError(
            f"must be 0-{ports.MAX_INSTANCE} (PX4's port scheme leaves room for no more), not {value}"
        )
    return value


def port_number(text: str) -> int:
    """argparse ``type`` of a UDP/TCP port option: an integer 1-65535."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be a port number 1-65535, not {text!r}") from None
    if not 1 <= value <= 65535:
        raise argparse.ArgumentTypeError(f"must be a port number 1-65535, not {value}")
    return value


def add_instance_option(parser: argparse.ArgumentParser, *, default: int | None = 0, help: str) -> None:
    """``-i N`` / ``--instance N`` (0-99), as PX4's ``-i``; ``help`` says what N selects for this script."""
    parser.add_argument("-i", "--instance", type=instance_number, default=default, metavar="N", help=help)


def add_version_option(parser: argparse.ArgumentParser) -> None:
    """``--version``: prints ``PROG VERSION`` (this project's installed version) and exits 0."""
    parser.add_argument("--version", action="version", version=f"%(prog)s {version()}")
