"""``campaign``: run a campaign of randomised flights and report on its results.

Examples::

    campaign run benchmarks/campaigns/landing_quick.toml                 # all local cores
    campaign run landing.toml --out results.csv --jobs 2                 # two runs at a time
    campaign run landing.toml --out results.csv --resume                 # go on after a Ctrl-C or a kill
    campaign run landing.toml --ray auto                                 # a local Ray instance (joined or started)
    campaign run landing.toml --ray 10.0.0.5:6379                        # a Ray cluster
    campaign report results.csv --plots plots/                           # the table per cell, and PNGs

Each run is its own simulator + flight controller on an instance number leased from the shared pool
(30-99, gcs/launcher/instance_pool.py: never one that the tests, another campaign or a person's
stack holds).  Results go to one CSV (``--out``, default ``<campaign name>.csv`` in the working
directory), a row appended as each run ends.  Paths are relative to the working directory.
"""

from __future__ import annotations

import argparse
import signal
import sys
from pathlib import Path

from mavsim_core.cli_args import EXIT_CODES_EPILOG, EXIT_FAILED, EXIT_OK, EXIT_USAGE, add_version_option
from mavsim_core.cli_checks import positive_int

from . import report, runner, spec
from .results import ResultsError

EXIT_INTERRUPTED = 130


def instance_range(text: str) -> tuple[int, int]:
    """argparse ``type`` of ``--instances LOW-HIGH`` (0-99)."""
    try:
        low, high = (int(x) for x in text.split("-"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"must be LOW-HIGH, e.g. 30-99, not {text!r}") from None
    if not 0 <= low <= high <= 99:
        raise argparse.ArgumentTypeError(f"must have 0 <= LOW <= HIGH <= 99, not {text!r}")
    return low, high


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(
        prog="campaign",
        description=__doc__.split("\n\n")[0],
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog=EXIT_CODES_EPILOG + " 130 interrupted (the results file keeps what ended; --resume goes on).",
    )
    add_version_option(ap)
    sub = ap.add_subparsers(dest="command", required=True, metavar="{run,report}")
    r = sub.add_parser("run", help="run a campaign file", description="Run every run of a campaign file.")
    r.add_argument("file", type=Path, help="the campaign file (TOML; see benchmarks/campaigns/)")
    r.add_argument("--out", type=Path, help="results CSV (default: <campaign name>.csv here)")
    r.add_argument("--resume", action="store_true", help="skip the runs the results file has done")
    r.add_argument("--jobs", type=positive_int, default=None, help="local runs at a time (default: all cores)")
    r.add_argument("--ray", metavar="ADDRESS", help="run on Ray: 'auto' (join or start a local one) or an address")
    r.add_argument("--instances", type=instance_range, help="lease instance numbers from LOW-HIGH (default 30-99)")
    r.add_argument("--keep-logs", type=Path, metavar="DIR", help="keep each run's logs in DIR/<run id>")
    r.add_argument("--dry-run", action="store_true", help="print the cells and run count, run nothing")
    p = sub.add_parser("report", help="the table per cell of a results file", description="Report on results.")
    p.add_argument("results", type=Path, help="a results CSV written by 'campaign run'")
    p.add_argument("--plots", type=Path, metavar="DIR", help="write the PNG plots into DIR")
    return ap


def _interrupt(signum: int, frame: object) -> None:
    """SIGTERM (``kill PID``, a batch system's time limit) stops a campaign as Ctrl-C does: no new run starts,
    the results file keeps what ended; the pool's workers then end with it (:mod:`.executors`)."""
    raise KeyboardInterrupt


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    signal.signal(signal.SIGTERM, _interrupt)
    try:
        return cmd_run(args) if args.command == "run" else cmd_report(args)
    except KeyboardInterrupt:
        print("campaign: interrupted: the results file keeps every run that ended; --resume goes on", file=sys.stderr)
        return EXIT_INTERRUPTED


def cmd_run(args: argparse.Namespace) -> int:
    try:
        campaign = spec.load(args.file)
    except OSError as exc:
        return _fail(f"{args.file}: {exc.strerror or exc}", EXIT_USAGE)
    except spec.SpecError as exc:
        return _fail(f"{args.file}: {exc}", EXIT_USAGE)
    if args.dry_run:
        from .plan import expand

        runs = expand(campaign)
        for label in dict.fromkeys(r.label for r in runs):
            print(label)
        print(f"{len(runs)} runs ({campaign.runs} per cell), results tag {campaign.name}:{campaign.digest()}")
        return EXIT_OK
    options = runner.Options(out=(args.out or Path(f"{campaign.name}.csv")).resolve(), resume=args.resume)
    if args.jobs is not None:
        options.jobs = args.jobs
    options.ray, options.log_dir = args.ray, args.keep_logs
    if args.instances is not None:
        options.instances = args.instances
    try:
        outcome = runner.run(campaign, options)
    except ResultsError as exc:
        return _fail(str(exc), EXIT_FAILED)
    s = outcome.statuses
    print(
        f"{outcome.total} runs: {outcome.skipped} done before, {sum(s.values())} now "
        f"({s['ok']} ok, {s['flight_failed']} flight failed, {s['infra_failed']} infra failed); results: {options.out}"
    )
    return EXIT_OK


def cmd_report(args: argparse.Namespace) -> int:
    try:
        text, plots = report.report(args.results, args.plots)
    except OSError as exc:
        return _fail(f"{args.results}: {exc.strerror or exc}", EXIT_FAILED)
    except (ValueError, KeyError) as exc:
        return _fail(f"{args.results}: not a campaign results file ({exc})", EXIT_FAILED)
    print(text)
    for path in plots:
        print(f"plot: {path}")
    return EXIT_OK


def _fail(message: str, code: int) -> int:
    print(f"campaign: {message}", file=sys.stderr)
    return code


if __name__ == "__main__":
    sys.exit(main())
