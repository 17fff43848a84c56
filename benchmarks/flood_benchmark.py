"""Benchmark: how much junk the flight controller absorbs while LAND is still acknowledged (issue 18, finding 5).

Starts the simulator and the flight controller at ``--speed 1`` (real time: the lockstep is paced to
the wall clock, so a flight controller that cannot keep up shows as a simulated clock running slow),
takes off to ALT_M with the bundled client on the API port, and then, for each junk rate
(``--rates``, datagrams per wall second; the mix of ``tests/link_flood.py``: random bytes, CRC-valid
frames for another system, ground-station HEARTBEATs, PARAM_REQUEST_READs to the vehicle), floods
the ground-station port from another process while a ground station on that same port sends
``--trials`` COMMAND_LONG NAV_LAND, each resent once (confirmation 1) if its COMMAND_ACK is not back
within RETRY_S (MAVSDK's command timeout), asks for a HEARTBEAT (REQUEST_MESSAGE) to see AUTO.LAND,
and stops the descent with DO_SET_MODE AUTO.LOITER the same way.

It prints per rate: the rate really sent, LANDs acknowledged at the first try / within one retry /
lost, the ack latency (median, max, ms), LANDs seen executed, the real-time factor (simulated seconds
per wall second, from ATTITUDE.time_boot_ms) and its ratio to the no-flood phase (1.00: no control
update missed), and the CPU (% of one core, /proc) of the flight controller, the simulator, the
flooder and this ground station.  The figure asked for is the highest rate at which every LAND is
acknowledged within one retry and executed and the ratio stays within 2 % of 1 (RTF_OK; above 1 is a
simulation catching up after a stall), at that rate and every lower one.  The machine is shared: a
ratio below 1 may be another program's load; run it twice.

A progress bar (stderr) counts the LAND trials of every rate and how many were acknowledged.

Usage: ``python benchmarks/flood_benchmark.py [-i 29] [--speed 1]
[--rates 0,1000,2500,5000,10000,20000] [--trials 5] [--kinds random,foreign,heartbeat,param_read]``.
"""

from __future__ import annotations

import os
import statistics
import sys
import time
from pathlib import Path

os.environ.setdefault("MAVLINK20", "1")
ROOT = Path(__file__).resolve().parents[1]
sys.path[:0] = [str(ROOT), str(ROOT / "tests")]

from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from gcs.client import VehicleClient  # noqa: E402
from gcs.launcher import Stack  # noqa: E402
from mavsim_core import ports  # noqa: E402
from mavsim_core import px4_modes as modes  # noqa: E402

from _cli import add_instance, parser  # noqa: E402
from _progress import Progress  # noqa: E402
from link_flood import KINDS, Flood, GroundStation  # noqa: E402  (tests/link_flood.py)

ALT_M = 15.0
WARMUP_S = 1.0  # the flood runs this long before the first LAND
SEEN_S = 1.5  # LAND must show in a HEARTBEAT within this (wall) time of its ack to count as executed
RTF_OK = 0.98  # real-time factor ratio to the no-flood phase (and its inverse) for "no control update missed"
LAND_MODE = modes.encode_custom_mode(modes.MAIN_AUTO, modes.SUB_AUTO_LAND)


def cpu_s(pid: int) -> float:
    """User + system CPU seconds of a process (Linux /proc)."""
    fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
    return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")


def take_off(stack: Stack, progress: Progress) -> None:
    """Arm and climb to ALT_M with the bundled client on the API port (closed afterwards)."""
    with VehicleClient(stack.api_url, timeout_s=60, idle=progress.idle(stack.check_alive)) as client:
        progress.watch(client)
        client.wait_until(lambda: client.prearm_ok(), 90, "ready to arm")
        progress.phase(f"take-off to {ALT_M:g} m")
        client.param_set("MIS_TAKEOFF_ALT", ALT_M)
        client.arm(timeout_s=10).check()
        client.takeoff().check()
        client.wait_until(lambda: client.takeoff_done(ALT_M, 1.0), 120, f"hover at {ALT_M:g} m")
        progress.watch(None)


def land_trial(gs: GroundStation, compid: int) -> dict:
    """One LAND (acknowledged? executed?) and the LOITER that stops it."""
    nan = float("nan")
    attempts, latency, result = gs.command(mavlink.MAV_CMD_NAV_LAND, (0, 0, 0, nan, nan, nan, nan), compid)
    acked = time.perf_counter()
    executed = False
    if latency is not None:  # the mode now: HEARTBEAT asked for once (REQUEST_MESSAGE)
        gs.command(mavlink.MAV_CMD_REQUEST_MESSAGE, (mavlink.MAVLINK_MSG_ID_HEARTBEAT, 0, 0, 0, 0, 0, 0), compid)
        while time.perf_counter() < acked + SEEN_S and not executed:
            executed = gs.mode_since(acked) == LAND_MODE
            time.sleep(0.005)
    loiter = (mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, modes.MAIN_AUTO, modes.SUB_AUTO_LOITER, 0, 0, 0, 0)
    gs.command(mavlink.MAV_CMD_DO_SET_MODE, loiter, compid)
    time.sleep(0.3)
    return {"attempts": attempts, "latency": latency, "result": result, "executed": executed}


def run_phase(
    gs: GroundStation, flood: Flood, stack: Stack, rate: float, trials: int, first_compid: int, progress: Progress
) -> dict:
    """``trials`` LAND trials under ``rate`` junk datagrams per second; the figures of the phase."""
    flood.rate_hz = rate
    time.sleep(WARMUP_S)
    pids = stack.procs["autopilot"].pid, stack.procs["sitl"].pid, flood.pid, os.getpid()
    t0, sent0, cpu0 = time.perf_counter(), flood.sent, [cpu_s(p) for p in pids]
    rows = []
    for _ in range(trials):
        rows.append(land_trial(gs, 1 + (first_compid + len(rows)) % 150))
        progress.note(f"{sum(r['latency'] is not None for r in rows)}/{len(rows)} acked")
        progress.done()
    t1, sent1, cpu1 = time.perf_counter(), flood.sent, [cpu_s(p) for p in pids]
    flood.rate_hz = 0
    stack.check_alive()
    return {
        "rate": rate, "sent_hz": (sent1 - sent0) / (t1 - t0), "trials": rows,
        "rtf": gs.sim_speed(t0, t1), "cpu": [100 * (b - a) / (t1 - t0) for a, b in zip(cpu0, cpu1)],
    }  # fmt: skip


def report(phases: list[dict]) -> None:
    base = next((p["rtf"] for p in phases if p["rate"] == 0), float("nan"))
    print()
    print(
        "rate/s  sent/s  LANDs  1st try  1 retry  lost  median ms  max ms  executed  RTF    ratio  CPU% FC/sim/flood/gs"
    )
    best, failed = 0.0, False
    for p in sorted(phases, key=lambda p: p["rate"]):
        rows = p["trials"]
        lat = [r["latency"] * 1e3 for r in rows if r["latency"] is not None]
        first = sum(r["attempts"] == 1 and r["latency"] is not None for r in rows)
        acked, executed = len(lat), sum(r["executed"] for r in rows)
        ratio = p["rtf"] / base
        cpu = "/".join(f"{c:.0f}" for c in p["cpu"])
        figures = f"{statistics.median(lat):9.1f}  {max(lat):6.1f}" if lat else f"{'-':>9}  {'-':>6}"
        print(
            f"{p['rate']:6.0f}  {p['sent_hz']:6.0f}  {len(rows):5d}  {first:7d}  {acked - first:7d}"
            f"  {len(rows) - acked:4d}  {figures}  {executed:8d}  {p['rtf']:5.3f}  {ratio:5.3f}  {cpu:>12}"
        )
        failed = failed or not (acked == executed == len(rows) and abs(ratio - 1) <= 1 - RTF_OK)
        best = best if failed else p["sent_hz"]
    results = sorted({r["result"] for p in phases for r in p["trials"] if r["result"] is not None})
    print(f"ack results: {results} (0 = ACCEPTED)")
    print(f"absorbed: {best:.0f} junk datagrams/s (and every lower rate) with every LAND acknowledged within one "
          f"retry and executed, the real-time factor within {1 - RTF_OK:.0%} of the no-flood phase's")  # fmt: skip


def main(argv: list[str] | None = None) -> int:
    ap = parser(__doc__)
    add_instance(ap, 29)
    ap.add_argument("--speed", default="1", help="simulator speed: N x real time, or max")
    ap.add_argument(
        "--rates", default="0,1000,2500,5000,10000,20000", help="junk datagrams per second, comma-separated"
    )
    ap.add_argument("--trials", type=int, default=5, help="LAND commands per rate")
    ap.add_argument("--kinds", default=",".join(KINDS), help=f"junk kinds, comma-separated, of {', '.join(KINDS)}")
    args = ap.parse_args(argv)
    try:
        rates = [float(x) for x in args.rates.split(",") if x.strip()]
    except ValueError:
        ap.error(f"argument --rates: comma-separated numbers, not {args.rates!r}")
    kinds = tuple(k.strip() for k in args.kinds.split(",") if k.strip())
    if unknown := set(kinds) - set(KINDS):
        ap.error(f"argument --kinds: {', '.join(sorted(unknown))} not one of {', '.join(KINDS)}")
    phases = []
    progress = Progress(len(rates) * args.trials, "LAND", "starting the stack")
    with progress, Stack(instance=args.instance, speed=args.speed, flight_logs=False) as stack:
        gs = GroundStation(stack.gcs_port, stack.sysid)
        fc = ("127.0.0.1", ports.gcs_local_port(args.instance))
        try:
            progress.label("take-off")
            take_off(stack, progress)
            progress.say(
                f"hovering at {ALT_M:g} m (instance {args.instance}, speed {args.speed}); logs in {stack.log_dir}"
            )
            with Flood(fc, stack.sysid, kinds) as flood:
                for i, rate in enumerate(rates):
                    progress.label(f"flood {rate:g}/s")
                    progress.phase("")
                    phases.append(run_phase(gs, flood, stack, rate, args.trials, i * args.trials, progress))
                    p = phases[-1]
                    acked = sum(r["latency"] is not None for r in p["trials"])
                    progress.say(
                        f"  {rate:g}/s: sent {p['sent_hz']:.0f}/s, RTF {p['rtf']:.3f}, {acked}/{args.trials} acked"
                    )
        finally:
            gs.close()
    report(phases)
    return 0


if __name__ == "__main__":
    sys.exit(main())
