"""``gcs autotune``: tune the vehicle's rate loop in flight (MAV_CMD_DO_AUTOTUNE_ENABLE), as PX4's autotune.

Sends DO_AUTOTUNE_ENABLE param1 = 1 (again every ACK_TRY_S until a COMMAND_ACK: IN_PROGRESS starts it; a
refusal, e.g. DENIED on the ground, exits 1 with the vehicle's reason), then follows the vehicle's
STATUSTEXTs: "Autotune: roll 30 %" progress lines are printed as they come; "Autotune aborted ..." (a
mode change, a disarm, a landing) or a failed identification exits 1; one line per axis
(:mod:`mavsim_core.autotune_report`) carries the identified plant, the gains now and proposed and the
margins of both, printed as a table.  Then "Apply the new gains? [y/N]" (``--accept`` / ``--reject``
for scripts): yes sends param1 = 2 and reads the MC_*RATE_* parameters back; no sends param1 = 0 and the
gains stay.  Ctrl-C while it runs sends param1 = 0 (abort) before exiting.  Exit codes as every ``gcs``
command: 0 done (applied or rejected), 1 refused, aborted or failed, 2 usage, 3 no answer.

The vehicle is not polled with a repeated param1 = 1 (QGroundControl's way): at ``--speed max`` a poll
could land after a finished or failed run and start another one; the STATUSTEXTs carry the progress.
"""

from __future__ import annotations

import argparse
import sys
import time

from mavsim_core.autotune_report import AXES, PREFIX, AxisReport, parse_axis_line

from .client import VehicleClient, mavlink
from .errors import EXIT_OK, CommandAborted, CommandResult, NoAnswer

CMD = mavlink.MAV_CMD_DO_AUTOTUNE_ENABLE
START, ABORT, ACCEPT = 1, 0, 2  # param1
ACK_TRY_S = 0.5  # wall seconds between tries until a COMMAND_ACK comes
RUN_TIMEOUT_S = 180.0  # wall seconds for the whole run (--timeout overrides)
FAILED = ("Autotune aborted", "identification failed", "no usable model", "no gains meet")


def add_autotune_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser(
        "autotune",
        help="tune the rate loop in flight (Hold/Position): identify, propose gains, apply if accepted",
        description="In flight in Hold or Position mode: the vehicle excites roll, pitch and yaw in turn, "
        "identifies each axis' rate plant and proposes gains; the table shows them with the margins before "
        "and after.  Nothing changes until you accept.  Ctrl-C aborts the run on the vehicle.",
    )
    g = p.add_mutually_exclusive_group()
    g.add_argument("--accept", action="store_true", help="apply the proposed gains without asking")
    g.add_argument("--reject", action="store_true", help="drop the proposed gains without asking")


def send(client: VehicleClient, action: int, timeout_s: float) -> CommandResult:
    """DO_AUTOTUNE_ENABLE with param1 ``action`` until any COMMAND_ACK (IN_PROGRESS counts: it is the answer)."""
    texts_before = len(client.statustexts)
    deadline = time.monotonic() + timeout_s
    attempt = 0
    while time.monotonic() < deadline:
        client.conn.mav.command_long_send(
            client.target_system, client.target_component, CMD, min(attempt, 255), action, 0, 0, 0, 0, 0, 0
        )
        attempt += 1
        ack = client.recv("COMMAND_ACK", min(ACK_TRY_S, deadline - time.monotonic()), lambda m: m.command == CMD)
        if ack is not None:
            ok = ack.result in (mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_IN_PROGRESS)
            return CommandResult(CMD, ack.result, None if ok else client.reason_since(texts_before))
    raise NoAnswer(f"no COMMAND_ACK to MAV_CMD_DO_AUTOTUNE_ENABLE after {attempt} attempt(s) [{client.describe()}]")


class RunFollower:
    """Reads the vehicle's autotune STATUSTEXTs (from ``first`` on): prints progress, keeps the axis reports."""

    def __init__(self, client: VehicleClient, first: int) -> None:
        self.client, self.next = client, first
        self.reports: dict[str, AxisReport] = {}
        self.done = False

    def __call__(self) -> bool:
        texts = self.client.statustexts
        while self.next < len(texts):
            text = texts[self.next].text
            self.next += 1
            if not text.startswith("Autotune"):
                continue
            if any(f in text for f in FAILED):
                raise CommandAborted(text)
            report = parse_axis_line(text)
            if report is not None:
                self.reports[report.axis] = report
            elif text.startswith("Autotune done") or text.startswith("Autotune: new gains applied"):
                self.done = True
            elif text.startswith("Autotune: ") or text.startswith("Autotune started"):
                print(text, flush=True)
        return self.done


def table(reports: list[AxisReport]) -> str:
    """The per-axis table: identified model, gains now -> proposed, crossover and margins now -> proposed."""
    head = (
        f"{'axis':5} {'b':>5} {'tau ms':>6} {'P now>new':>15} {'I now>new':>15} {'D now>new':>15} "
        f"{'fc Hz':>11} {'PM deg':>11} {'GM dB':>11}"
    )
    lines = [head, "-" * len(head)]
    for r in reports:

        def pair(a: tuple[float, float], fmt: str = ".1f") -> str:
            return f"{a[0]:{fmt}}>{a[1]:{fmt}}"

        g = [f"{a:.3g}>{b:.4g}" for a, b in zip(r.gains_now, r.gains_new)]
        lines.append(
            f"{r.axis:5} {r.effectiveness:5.2f} {r.motor_tau_s * 1e3:6.1f} {g[0]:>15} {g[1]:>15} {g[2]:>15} "
            f"{pair(r.crossover_hz, '.2f'):>11} {pair(r.phase_margin_deg):>11} {pair(r.gain_margin_db):>11}"
        )
    return "\n".join(lines)


def _decide(args: argparse.Namespace) -> bool:
    if args.accept or args.reject:
        return bool(args.accept)
    try:
        answer = input("Apply the new gains? [y/N] ")
    except EOFError:
        answer = ""
    return answer.strip().lower() in ("y", "yes")


def run_autotune(client: VehicleClient, args: argparse.Namespace) -> int:
    timeout = args.timeout if args.timeout is not None else RUN_TIMEOUT_S
    first = len(client.statustexts)
    started = send(client, START, client.timeout_s)
    if started.result != mavlink.MAV_RESULT_IN_PROGRESS:
        started.check()  # (DENIED on the ground, not in Hold/Position, disabled: refused with the reason)
    follower = RunFollower(client, first)
    try:
        client.wait_until(follower, timeout, "the autotune to finish")
    except CommandAborted:  # the vehicle stopped it (and said why)
        raise
    except BaseException:  # Ctrl-C, or no end in time: the run does not go on without us
        send(client, ABORT, 5.0)
        print("autotune aborted on the vehicle: gains unchanged", file=sys.stderr)
        raise
    reports = [follower.reports[a] for a in AXES if a in follower.reports]
    print(table(reports), flush=True)
    if any(t.text.startswith(PREFIX.strip() + ": new gains applied") for t in client.statustexts[first:]):
        print("applied by the vehicle (MC_AT_APPLY 2)")
        return EXIT_OK
    if not _decide(args):
        send(client, ABORT, client.timeout_s).check()
        print("rejected: gains unchanged")
        return EXIT_OK
    send(client, ACCEPT, client.timeout_s).check()
    names = [f"MC_{a.upper()}RATE_{k}" for a in (r.axis for r in reports) for k in "PID"]
    print("applied: " + ", ".join(f"{n} {client.param_get(n):.4g}" for n in names))
    return EXIT_OK
