"""Benchmark: how fast a flight's ULog downloads over the MAVLink log protocol.

Starts the stack (``--speed 1`` or ``max``), flies a take-off to 5 m, a hover of ``--hover``
simulated seconds and a landing, waits for the flight's logs to close, then downloads the ULog
twice over the API link: with MAVSDK's LogFiles plugin (46 kB requests, one after the other) and
with pymavlink asking for the whole file in one LOG_REQUEST_DATA.  Both copies are compared with
the file on disk.  Prints the log's size and simulated duration and each download's wall time and
rate.

A progress bar (stderr) counts the phases (ready, take-off, hover, landing, logs closed, the two
downloads) and shows the simulated seconds flown.

Usage: ``python benchmarks/log_download_benchmark.py [--speed 1|max] [--hover S] [-i N]``
"""

from __future__ import annotations

import asyncio
import os
import sys
import tempfile
import time
from pathlib import Path

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gcs.client import VehicleClient  # noqa: E402
from gcs.launcher import Stack  # noqa: E402

from _cli import add_instance, parser  # noqa: E402
from _progress import Progress  # noqa: E402

ALT_M = 5.0
PHASES = 7  # ready, take-off, hover, landed, logs closed, MAVSDK's download, pymavlink's


def fly(stack: Stack, hover_s: float, progress: Progress) -> None:
    """Take off, hover ``hover_s`` simulated seconds, land; wait until the flight's logs are closed."""
    client = VehicleClient(stack.api_url, timeout_s=120, idle=progress.idle(stack.check_alive))
    progress.watch(client)
    try:
        client.wait_until(client.prearm_ok, 120, "ready to arm")
        progress.done(phase="take-off")
        client.arm().check()
        client.takeoff(client.home().alt_amsl_m + ALT_M).check()
        client.wait_until(lambda: client.takeoff_done(ALT_M), 120, "take-off")
        progress.done(phase=f"hover {hover_s:g} s")
        client.wait_sim_time(hover_s)
        progress.done(phase="landing")
        client.land().check()
        client.wait_until(client.landed_and_disarmed, 180, "landed and disarmed")
        progress.done(phase="closing the logs")
    finally:
        progress.watch(None)
        client.close()
    deadline = time.monotonic() + 60
    while "flight log closed" not in stack.log_path("autopilot").read_text():
        if time.monotonic() > deadline:
            raise RuntimeError("the flight's logs did not close")
        time.sleep(0.1)


async def mavsdk_download(stack: Stack, path: Path) -> tuple[int, float]:
    from mavsdk.asyncio import ComponentType, Configuration, Mavsdk
    from mavsdk.asyncio.plugins.log_files import LogFilesAsync

    async with Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION)) as sdk:
        await sdk.add_any_connection(f"udpin://0.0.0.0:{stack.api_port}")
        system = await sdk.first_autopilot(timeout_s=30.0)
        log_files = LogFilesAsync(system)  # one plugin: it downloads only entries it listed
        entries = await log_files.get_entries()
        wall0 = time.monotonic()
        async for _ in log_files.download_log_file(entries[-1], str(path)):
            pass
        return entries[-1].size_bytes, time.monotonic() - wall0


def pymavlink_download(stack: Stack) -> tuple[bytes, float]:
    conn = mavutil.mavlink_connection(stack.api_url, source_system=255, source_component=190, dialect="common")
    try:
        conn.wait_heartbeat(timeout=30)
        conn.mav.log_request_list_send(stack.sysid, 1, 0, 0xFFFF)
        entry = conn.recv_match(type="LOG_ENTRY", blocking=True, timeout=10)
        while entry.id != entry.num_logs - 1:
            entry = conn.recv_match(type="LOG_ENTRY", blocking=True, timeout=10)
        data, have = bytearray(entry.size), bytearray(-(-entry.size // 90))  # 90-byte bins received
        wall0 = time.monotonic()
        while (first := have.find(0)) >= 0:  # ask from the first gap to the end (datagrams may be lost)
            conn.mav.log_request_data_send(stack.sysid, 1, entry.id, first * 90, 0xFFFFFFFF)
            while (m := conn.recv_match(type="LOG_DATA", blocking=True, timeout=0.5)) is not None and m.count:
                data[m.ofs : m.ofs + m.count] = bytes(m.data[: m.count])
                have[m.ofs // 90] = 1
                if m.ofs + m.count >= entry.size:
                    break
        return bytes(data), time.monotonic() - wall0
    finally:
        conn.close()


def main(argv: list[str] | None = None) -> int:
    ap = parser(__doc__)
    ap.add_argument("--speed", default="max", help="1 (real time) or max (lockstep as fast as it goes)")
    ap.add_argument("--hover", type=float, default=30.0, help="hover duration, simulated seconds")
    add_instance(ap, 28)
    args = ap.parse_args(argv)
    with tempfile.TemporaryDirectory(prefix="log-download-") as tmp, Progress(PHASES, "phase") as progress:
        progress.label(f"speed {args.speed}")
        progress.phase("starting the stack")
        path = Path(tmp) / "flight.ulg"
        with Stack(instance=args.instance, speed=args.speed) as stack:
            fly(stack, args.hover, progress)
            on_disk = sorted(stack.log_dir.glob("*.ulg"))[-1].read_bytes()
            progress.done(phase="MAVSDK download")
            size, mavsdk_s = asyncio.run(mavsdk_download(stack, path))
            assert path.read_bytes() == on_disk, "MAVSDK's copy differs from the file"
            progress.done(phase="pymavlink download")
            data, pymavlink_s = pymavlink_download(stack)
            assert data == on_disk, "pymavlink's copy differs from the file"
            progress.done(phase="done")
        from pyulog import ULog

        log = ULog(str(path))
    duration_s = (log.last_timestamp - log.start_timestamp) / 1e6
    print(f"speed {args.speed}: ULog of {size / 1e6:.2f} MB for {duration_s:.0f} simulated seconds of flight")
    print(f"MAVSDK LogFiles: {mavsdk_s:.2f} s wall, {size / mavsdk_s / 1e6:.2f} MB/s")
    print(f"pymavlink, whole-file requests: {pymavlink_s:.2f} s wall, {size / pymavlink_s / 1e6:.2f} MB/s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
