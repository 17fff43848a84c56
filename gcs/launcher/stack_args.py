"""The command lines of the stack's two children, every path in them made absolute.

:class:`~gcs.launcher.stack.Stack` runs ``sitl`` and ``autopilot`` with the checkout as their working
directory (so ``python -m`` finds this code, whatever the caller's directory holds), so a relative
path given by the caller (``--vehicle ./my.toml``, ``--params my.params``, ``--log-dir demo``) would
be read in the wrong place.  :func:`absolute_paths` resolves the path options of the children's
command lines against the caller's working directory when the Stack is made: the ones in
:data:`SITL_PATH_OPTIONS` and :data:`AUTOPILOT_PATH_OPTIONS`, given as ``--opt VALUE`` or
``--opt=VALUE``.  ``--vehicle`` and ``--scenario`` also take the name of a shipped file (``quad_x``,
``windy``): a value without a directory part and without ``.toml`` is such a name and stays as it is.
"""

from __future__ import annotations

import os
from pathlib import Path
from typing import Sequence

SITL_PATH_OPTIONS = frozenset({"--vehicle", "--scenario", "--log-dir", "--save-frames"})
AUTOPILOT_PATH_OPTIONS = frozenset({"--vehicle", "--params", "--state-dir", "--log-dir"})
NAME_OR_PATH_OPTIONS = frozenset({"--vehicle", "--scenario"})  # a bare name means a shipped file


def is_path(text: str) -> bool:
    """True for a value of ``--vehicle``/``--scenario`` that names a file (``.toml`` or a directory part)."""
    p = Path(text)
    return p.suffix == ".toml" or len(p.parts) > 1


def path_value(option: str, value: str) -> str:
    """``value`` of ``option`` resolved against the working directory (names of shipped files kept)."""
    if option in NAME_OR_PATH_OPTIONS and not is_path(value):
        return value
    return os.path.abspath(os.path.expanduser(value))


def absolute_paths(args: Sequence[str], options: frozenset[str]) -> list[str]:
    """``args`` with the value of every option in ``options`` made absolute (``--opt V`` and ``--opt=V``)."""
    out: list[str] = []
    pending: str | None = None  # the option whose value comes next
    for arg in args:
        if pending is not None:
            out.append(path_value(pending, arg))
            pending = None
            continue
        option, eq, value = arg.partition("=")
        if arg in options:
            pending = arg
            out.append(arg)
        elif eq and option in options:
            out.append(f"{option}={path_value(option, value)}")
        else:
            out.append(arg)
    return out


def sitl_command(stack) -> list[str]:
    """``python -m sitl ...`` of a :class:`~gcs.launcher.stack.Stack` (its vehicle, speed, instance, ...)."""
    cmd = [stack.python, "-m", *stack.sitl_module, "--vehicle", stack.vehicle, "--speed", stack.speed]
    cmd += ["--instance", str(stack.instance)]
    if stack.home is not None:
        cmd += ["--home", stack.home]
    if stack.seed is not None:
        cmd += ["--seed", str(stack.seed)]
    return cmd + log_dir_args(stack, "sitl") + stack.extra_sitl_args


def autopilot_command(stack) -> list[str]:
    """``python -m autopilot ...`` of a :class:`~gcs.launcher.stack.Stack`."""
    cmd = [stack.python, "-m", *stack.autopilot_module, "--vehicle", stack.vehicle, "--instance", str(stack.instance)]
    return cmd + ["--gcs-port", str(stack.gcs_port)] + log_dir_args(stack, "autopilot") + stack.extra_autopilot_args


def log_dir_args(stack, child: str) -> list[str]:
    """``--log-dir`` for the flight logs once the stack has its log directory (at start); ``--no-log`` if off."""
    if not stack.flight_logs:
        return ["--no-log"] if child == "autopilot" else []
    return ["--log-dir", str(stack.log_dir)] if stack.log_dir is not None else []
