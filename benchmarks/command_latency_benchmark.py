"""Benchmark: how fast the flight controller acknowledges commands while sticks stream in.

Starts the simulator and the flight controller (real time by default: ``--speed 1``), vehicle on
the ground, disarmed.  A pymavlink-encoded client on the stack's ground-station port (UDP
14840+I, ``Stack.gcs_port``) then, for each MANUAL_CONTROL rate (``--rates``, Hz of wall time;
0 = no sticks): streams MANUAL_CONTROL with the sticks at centre from a paced thread, and sends
``--commands`` harmless COMMAND_LONGs (MAV_CMD_REQUEST_MESSAGE for AUTOPILOT_VERSION), one every
COMMAND_PERIOD_S.  Each command goes out under its own source component, which its COMMAND_ACK
echoes as ``target_component``, so acks are matched to commands even when several are
outstanding.  Latency = send -> ack on the wall clock; a command without an ack within
LOST_AFTER_S is lost.

A progress bar (stderr) counts the commands sent and acknowledged; then it prints a table: rate,
commands, acked, lost, median / p95 / max latency in ms, and the median and max in control updates
(the link updates every 20 ms of simulated time; the simulator's speed is measured from
ATTITUDE.time_boot_ms against the wall clock, so the figure holds at any ``--speed``).  The flight controller answers
what arrives at every 4 ms lockstep step (``GcsLink.poll``), so the expected median is a fraction
of one update whatever the stick rate.  The link's ``rx_dropped`` is not printed: the flight
controller process does not report it to the outside.

Usage: ``python benchmarks/command_latency_benchmark.py [-i N] [--speed S] [--rates 0,50,200]
[--commands N] [--vehicle NAME]`` (default instance 27, clear of the tests' and the other benchmarks').
"""

from __future__ import annotations

import os
import socket
import statistics
import sys
import threading
import time
from pathlib import Path

os.environ.setdefault("MAVLINK20", "1")
sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from gcs.launcher import Stack  # noqa: E402

from _cli import add_instance, parser  # noqa: E402
from _progress import Progress  # noqa: E402

GCS_SYSID, STICKS_COMPID = 255, 190
FIRST_COMMAND_COMPID = 1  # commands use source components 1..COMPIDS (never STICKS_COMPID)
COMPIDS = 150
COMMAND_PERIOD_S = 0.1
LOST_AFTER_S = 2.0
WARMUP_S = 1.0  # sticks stream this long before the first command
LINK_UPDATE_SIM_S = 0.020  # GcsLink.update period (simulated time)


class GroundStation:
    """One UDP socket on the ground-station port: a receiver thread notes COMMAND_ACK arrival times
    (by the echoed component) and the simulator's clock (ATTITUDE.time_boot_ms against the wall)."""

    def __init__(self, port: int, sysid: int) -> None:
        self.sysid = sysid  # the flight controller's
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("0.0.0.0", port))
        self.sock.settimeout(0.1)
        self.fc_addr: tuple[str, int] | None = None
        self.acks: dict[int, tuple[float, int]] = {}  # source component -> (wall s, MAV_RESULT)
        self.sim_clock: list[tuple[float, int]] = []  # (wall s, time_boot_ms) of ATTITUDE
        self.running = True
        self._thread = threading.Thread(target=self._receive, daemon=True)
        self._thread.start()

    def _receive(self) -> None:
        parser = mavlink.MAVLink(None)
        parser.robust_parsing = True
        while self.running:
            try:
                data, addr = self.sock.recvfrom(65536)
            except (socket.timeout, OSError):
                continue
            now = time.perf_counter()
            for msg in parser.parse_buffer(data) or []:
                mtype = msg.get_type()
                if mtype == "COMMAND_ACK" and msg.command == mavlink.MAV_CMD_REQUEST_MESSAGE:
                    if msg.target_system == GCS_SYSID:
                        self.acks.setdefault(msg.target_component, (now, msg.result))
                elif mtype == "ATTITUDE":
                    self.sim_clock.append((now, msg.time_boot_ms))
                elif mtype == "HEARTBEAT" and msg.get_srcSystem() == self.sysid:
                    self.fc_addr = addr

    def send(self, msg: mavlink.MAVLink_message, encoder: mavlink.MAVLink) -> float:
        """Send one message as its own datagram; the wall time just before the send."""
        data = msg.pack(encoder)
        t = time.perf_counter()
        self.sock.sendto(data, self.fc_addr)
        return t

    def sim_speed(self, since: float) -> float:
        """Simulated seconds per wall second since wall time ``since`` (from ATTITUDE)."""
        pts = [p for p in self.sim_clock if p[0] >= since]
        if len(pts) < 2 or pts[-1][0] <= pts[0][0]:
            return float("nan")
        return (pts[-1][1] - pts[0][1]) / 1000.0 / (pts[-1][0] - pts[0][0])

    def wait_ready(self, stack: Stack, timeout_s: float = 90.0) -> None:
        """Until the flight controller's heartbeat is heard and the simulated clock runs (lockstep)."""
        end = time.monotonic() + timeout_s
        while time.monotonic() < end:
            stack.check_alive()
            if self.fc_addr is not None and self.sim_clock and self.sim_clock[-1][1] > 2000:
                return
            time.sleep(0.1)
        raise TimeoutError("the flight controller did not start streaming")

    def close(self) -> None:
        self.running = False
        self._thread.join(timeout=1.0)
        self.sock.close()


def stream_sticks(gs: GroundStation, rate_hz: float, stop: threading.Event, sent: list[int]) -> None:
    """MANUAL_CONTROL at ``rate_hz`` (sticks centred: throttle 500), paced on the wall clock."""
    encoder = mavlink.MAVLink(None, GCS_SYSID, STICKS_COMPID)
    msg = mavlink.MAVLink_manual_control_message(gs.sysid, 0, 0, 500, 0, 0)
    t0, k = time.perf_counter(), 0
    while not stop.is_set():
        gs.send(msg, encoder)
        k += 1
        delay = t0 + k / rate_hz - time.perf_counter()
        if delay > 0:
            time.sleep(delay)
        elif delay < -0.1:  # fell behind (machine busy): no catch-up burst
            t0, k = time.perf_counter(), 0
    sent.append(k)


def run_phase(gs: GroundStation, rate_hz: float, n: int, first_compid: int, progress: Progress) -> dict:
    """Sticks at ``rate_hz`` while ``n`` commands go out; latency of each (s, None if lost)."""
    stop, sticks_sent = threading.Event(), []
    sticks = None
    phase_start = time.perf_counter()
    if rate_hz > 0:
        sticks = threading.Thread(target=stream_sticks, args=(gs, rate_hz, stop, sticks_sent), daemon=True)
        sticks.start()
        time.sleep(WARMUP_S)
    request = mavlink.MAVLink_command_long_message(
        gs.sysid, 1, mavlink.MAV_CMD_REQUEST_MESSAGE, 0, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION, 0, 0, 0, 0, 0, 0
    )
    sent: dict[int, float] = {}
    for k in range(n):
        compid = FIRST_COMMAND_COMPID + (first_compid + k) % COMPIDS
        gs.acks.pop(compid, None)
        sent[compid] = gs.send(request, mavlink.MAVLink(None, GCS_SYSID, compid))
        progress.note(f"{sum(1 for c in sent if c in gs.acks)}/{k + 1} acked")
        progress.done()
        time.sleep(COMMAND_PERIOD_S)
    end = time.perf_counter() + LOST_AFTER_S
    while time.perf_counter() < end and any(c not in gs.acks for c in sent):
        time.sleep(0.01)
    stop.set()
    progress.note(f"{sum(1 for c in sent if c in gs.acks)}/{n} acked")
    if sticks is not None:
        sticks.join()
    wall = time.perf_counter() - phase_start
    latencies = []
    for compid, t in sent.items():
        ack = gs.acks.get(compid)
        latencies.append(ack[0] - t if ack is not None and ack[0] - t <= LOST_AFTER_S else None)
    results = {gs.acks[c][1] for c in sent if c in gs.acks}
    stick_rate = sticks_sent[0] / wall if sticks_sent else 0.0  # as sent (the thread ran the whole phase)
    return {
        "rate": rate_hz, "latencies": latencies, "results": results,
        "speed": gs.sim_speed(phase_start), "stick_rate": stick_rate,
    }  # fmt: skip


def percentile(values: list[float], q: float) -> float:
    s = sorted(values)
    return s[min(len(s) - 1, max(0, round(q * (len(s) - 1))))]


def report(rows: list[dict]) -> None:
    print()
    print("rate Hz  sent Hz  commands  acked  lost  median ms  p95 ms  max ms  median upd  max upd  sim speed")
    for r in rows:
        ok = [x for x in r["latencies"] if x is not None]
        lost = len(r["latencies"]) - len(ok)
        if ok:
            med, p95, mx = statistics.median(ok) * 1e3, percentile(ok, 0.95) * 1e3, max(ok) * 1e3
            per_update = r["speed"] / LINK_UPDATE_SIM_S / 1e3  # updates per ms of wall time
            figures = f"{med:9.1f}  {p95:6.1f}  {mx:6.1f}  {med * per_update:10.2f}  {mx * per_update:7.2f}"
        else:
            figures = f"{'-':>9}  {'-':>6}  {'-':>6}  {'-':>10}  {'-':>7}"
        print(
            f"{r['rate']:7g}  {r['stick_rate']:7.0f}  {len(r['latencies']):8d}  {len(ok):5d}  {lost:4d}  "
            f"{figures}  {r['speed']:8.2f}x"
        )
    names = {v: k[len("MAV_RESULT_") :] for k, v in vars(mavlink).items() if k.startswith("MAV_RESULT_")}
    results = sorted({names.get(x, str(x)) for r in rows for x in r["results"]})
    print(f"ack results: {', '.join(results) or 'none'}")


def main(argv: list[str] | None = None) -> int:
    ap = parser(__doc__)
    add_instance(ap, 27)
    ap.add_argument("--speed", default="1", help="simulator speed: N x real time, or max")
    ap.add_argument("--rates", default="0,50,200", help="MANUAL_CONTROL rates, Hz (wall), comma-separated (0: none)")
    ap.add_argument("--commands", type=int, default=50, help="commands (REQUEST_MESSAGE) sent per rate")
    ap.add_argument("--vehicle", default="quad_x", help="vehicle file name (params/vehicles/) or path")
    args = ap.parse_args(argv)
    try:
        rates = [float(x) for x in args.rates.split(",") if x.strip()]
    except ValueError:
        ap.error(f"argument --rates: comma-separated numbers, not {args.rates!r}")
    rows = []
    progress = Progress(len(rates) * args.commands, "cmd", "starting the stack")
    with progress, Stack(instance=args.instance, speed=args.speed, vehicle=args.vehicle, flight_logs=False) as stack:
        gs = GroundStation(stack.gcs_port, stack.sysid)
        try:
            gs.wait_ready(stack)
            progress.say(f"stack up (instance {args.instance}, speed {args.speed}); logs in {stack.log_dir}")
            for i, rate in enumerate(rates):
                progress.label(f"MANUAL_CONTROL {rate:g} Hz")
                progress.say(f"MANUAL_CONTROL at {rate:g} Hz, {args.commands} commands every {COMMAND_PERIOD_S} s")
                rows.append(run_phase(gs, rate, args.commands, i * args.commands, progress))
                stack.check_alive()
        finally:
            gs.close()
    report(rows)
    return 0


if __name__ == "__main__":
    sys.exit(main())
