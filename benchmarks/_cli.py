"""The command line every benchmark shares: its docstring as ``--help``, the defaults shown, ``-i/--instance``.

Not a benchmark itself (the leading underscore): the scripts beside it import it.
"""

from __future__ import annotations

import argparse

from mavsim_core.cli_args import add_instance_option, instance_number

__all__ = ["add_instance", "instance_number", "parser"]

PROGRESS = "Progress shows as a bar on stderr while it runs; the figures go to stdout.\n"
README = "What each benchmark measures, how long it takes and its last figures on this machine: benchmarks/README.md."


class _Formatter(argparse.RawDescriptionHelpFormatter, argparse.ArgumentDefaultsHelpFormatter):
    """The docstring as written (paragraphs, lists), and each option's default after its help (not an empty
    one: a flag's False, a repeatable option's [])."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        if action.default in (None, False, []):
            return action.help
        return super()._get_help_string(action)


def parser(doc: str | None, progress: bool = True) -> argparse.ArgumentParser:
    """A parser whose ``--help`` describes the benchmark: its module docstring without the Usage paragraph
    (argparse prints its own usage line); ``progress``: it shows a progress bar (a tool of a few seconds does not)."""
    paragraphs = (doc or "").strip().split("\n\n")
    description = "\n\n".join(p for p in paragraphs if not p.lstrip().startswith("Usage:"))
    epilog = (PROGRESS if progress else "") + README
    return argparse.ArgumentParser(description=description, formatter_class=_Formatter, epilog=epilog)


def add_instance(ap: argparse.ArgumentParser, default: int) -> None:
    """``-i/--instance N`` (0-99) of the stack the benchmark starts; the default keeps clear of people's 0-9,
    of 10 and of the tests' 30-99 (tests/instances.py)."""
    add_instance_option(
        ap,
        default=default,
        help="instance number of the stack it starts (PX4's -i: system id 1+N, TCP 4560+N, UDP 14540+N ...)",
    )
