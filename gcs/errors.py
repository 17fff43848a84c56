"""The ground-station client's public errors and the records that explain them.

Every error the client raises derives from :class:`GcsError`.  A refusal carries
the vehicle's own words: :class:`CommandResult` (the COMMAND_ACK result and the
STATUSTEXT that came with it) and :class:`StatusText` (one joined STATUSTEXT).
Times in :class:`StatusText` are the vehicle's simulated seconds and the
client's wall-clock (``time.monotonic``) seconds.
"""

from __future__ import annotations

from dataclasses import dataclass

from pymavlink import mavutil

# the ``gcs`` CLI's exit codes are those of every console script (mavsim_core/cli_args.py)
from mavsim_core.cli_args import EXIT_FAILED as EXIT_REFUSED
from mavsim_core.cli_args import EXIT_NO_ANSWER, EXIT_OK, EXIT_USAGE  # noqa: F401 - EXIT_OK: for the CLI modules

mavlink = mavutil.mavlink


class GcsError(Exception):
    """Base class of the errors this client raises."""


class GcsTimeout(GcsError):
    """Something did not happen within its (wall-clock) timeout; the message says what."""


class NoAnswer(GcsTimeout):
    """The vehicle did not answer at all: no HEARTBEAT, or no reply to any of the tries of a request
    (COMMAND_ACK, PARAM_VALUE), nor the effect a command asked for.  The ``gcs`` CLI exits 3."""


class CommandRefused(GcsError):
    """The vehicle answered a command with a result other than ACCEPTED."""

    def __init__(self, result: "CommandResult") -> None:
        super().__init__(result.describe())
        self.result = result


class CommandAborted(GcsError):
    """The vehicle stopped carrying out a command before it was done (it left the mode the command put it
    in, or disarmed).  The ``gcs`` CLI exits 1."""


class ParamRefused(GcsError):
    """A PARAM_SET was not applied (the vehicle echoed another value), or the parameter does not exist."""


class ParamUnknown(ParamRefused):
    """The vehicle has no parameter of that name (it said so: PARAM_ERROR or its STATUSTEXT)."""


class ParamListError(GcsError):
    """The vehicle's parameter stream was inconsistent (count changed, an index renamed...)."""


def command_name(command: int) -> str:
    """``MAV_CMD_NAV_TAKEOFF`` for 22, or ``MAV_CMD_<n>`` if unknown."""
    entry = mavlink.enums["MAV_CMD"].get(command)
    return entry.name if entry is not None else f"MAV_CMD_{command}"


def result_name(result: int) -> str:
    """``DENIED`` for MAV_RESULT_DENIED (the MAV_RESULT name without prefix)."""
    entry = mavlink.enums["MAV_RESULT"].get(result)
    name = entry.name if entry is not None else f"MAV_RESULT_{result}"
    return name.removeprefix("MAV_RESULT_")


@dataclass(frozen=True)
class StatusText:
    """One STATUSTEXT from the vehicle (chunks already joined)."""

    severity: int  # MAV_SEVERITY: 0 emergency .. 7 debug
    text: str
    sim_time_s: float | None  # vehicle time when it arrived, if known
    wall_time_s: float  # time.monotonic() when it arrived

    @property
    def severity_name(self) -> str:
        entry = mavlink.enums["MAV_SEVERITY"].get(self.severity)
        return entry.name.removeprefix("MAV_SEVERITY_") if entry is not None else str(self.severity)


@dataclass(frozen=True)
class CommandResult:
    """The outcome of a COMMAND_LONG / COMMAND_INT: the ACK result and, on refusal, the reason."""

    command: int
    result: int  # MAV_RESULT
    reason: str | None = None  # text of the latest STATUSTEXT received with a refusal
    # False: no COMMAND_ACK came back (lost), but the vehicle was seen doing what the command asked
    acknowledged: bool = True

    @property
    def accepted(self) -> bool:
        return self.result == mavlink.MAV_RESULT_ACCEPTED

    @property
    def command_name(self) -> str:
        return command_name(self.command)

    @property
    def result_name(self) -> str:
        return result_name(self.result)

    def describe(self) -> str:
        text = f"{self.command_name}: {self.result_name}"
        if self.reason:
            text += f" ({self.reason})"
        return text

    def check(self) -> "CommandResult":
        """Return self if accepted, else raise :class:`CommandRefused`."""
        if not self.accepted:
            raise CommandRefused(self)
        return self


def report_error(exc: BaseException, command: str) -> int:
    """Print ``exc`` as the ``gcs`` CLI's one line on stderr; its exit code (see EXIT_*): refusals and
    failures 1, a connection URL that cannot be opened 2 (a usage error), no answer from the vehicle 3."""
    import sys

    if isinstance(exc, CommandRefused):
        res = exc.result
        reason = f": {res.reason}" if res.reason else " (the vehicle gave no reason)"
        text, code = f"{command} refused: {res.result_name} ({res.command_name}){reason}", EXIT_REFUSED
    elif isinstance(exc, ParamUnknown):
        text, code = f"{command}: {exc}", EXIT_REFUSED
    elif isinstance(exc, ParamRefused):
        text, code = f"{command} refused: {exc}", EXIT_REFUSED
    elif isinstance(exc, NoAnswer):
        text, code = f"{command}: no answer from the vehicle: {exc}", EXIT_NO_ANSWER
    elif isinstance(exc, (GcsTimeout, CommandAborted)):  # the vehicle answers but did not do it (in time)
        text, code = f"{command} failed: {exc}", EXIT_REFUSED
    elif isinstance(exc, (OSError, OverflowError)):  # the connection: a device, socket or port that cannot open
        text, code = f"cannot open the connection: {exc}", EXIT_USAGE
    else:  # a bad parameter value or name (ValueError), another client error
        text, code = f"error: {exc}", EXIT_REFUSED
    print(f"gcs: {text}", file=sys.stderr)
    return code
