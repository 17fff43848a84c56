"""``gcs status`` and ``gcs watch``: the vehicle's state as lines of text.

- ``gcs status``: a line a second (mode, arming, N/E/altitude from home, ground speed, battery, GPS),
  scrolling; ``--once`` prints one and exits.
- ``gcs watch``: one line refreshed in place (carriage return, cut to the terminal's width): mode,
  armed, latitude/longitude, altitude above home, battery, GPS fix and satellites, and the vehicle's
  last STATUSTEXT since the watch began.  Until Ctrl-C (exit 0, quietly) or ``--count`` refreshes;
  when stdout is not a terminal (a pipe, a file), one line per refresh instead.

Both read what the telemetry plugin (:mod:`gcs.plugins.telemetry`) has cached; they ask at once for
the slow messages (home, GPS, battery) so the first line is complete.  Wall-clock periods.
"""

from __future__ import annotations

import argparse
import os
import shutil
import sys
import time
from typing import Callable, TextIO

from pymavlink.dialects.v20 import common as mavlink

from .client import VehicleClient
from .errors import EXIT_OK, GcsTimeout
from .plugins.telemetry import GPS_FIX_NAMES

SLOW_MESSAGES = (
    mavlink.MAVLINK_MSG_ID_HOME_POSITION,
    mavlink.MAVLINK_MSG_ID_GPS_RAW_INT,
    mavlink.MAVLINK_MSG_ID_BATTERY_STATUS,
)
FIRST_LINE_WAIT_S = 3.0  # at most this long for the telemetry to fill the first line
SILENT_NOTE_S = 3.0  # a line says when no heartbeat came for longer than this


def run_status(client: VehicleClient, args: argparse.Namespace) -> int:
    """``gcs status``: one line (``--once``) or a line a second until Ctrl-C."""
    if args.once:
        _wait_for_telemetry(client, args.timeout)
        print(status_line(client), flush=True)
        return EXIT_OK
    return _every(client, 1.0, None, lambda: print(status_line(client), flush=True))


def run_watch(client: VehicleClient, args: argparse.Namespace, out: TextIO | None = None) -> int:
    """``gcs watch``: the refreshing line (one line per refresh when ``out`` is not a terminal)."""
    out = out if out is not None else sys.stdout
    tty = bool(getattr(out, "isatty", lambda: False)())
    first_text = len(client.statustexts)
    try:
        _wait_for_telemetry(client, args.timeout)
    except KeyboardInterrupt:
        return EXIT_OK
    shown = 0

    def refresh() -> None:
        nonlocal shown
        line = watch_line(client, first_text)
        if not tty:
            out.write(line + "\n")
        else:
            line = line[: max(shutil.get_terminal_size().columns - 1, 20)]
            out.write("\r" + line + " " * max(shown - len(line), 0))
            shown = len(line)
        out.flush()

    try:
        return _every(client, args.period, args.count, refresh)
    except BrokenPipeError:  # `gcs watch | head -3`: the reader has had enough
        if out is sys.stdout:  # (so the interpreter's last flush does not complain)
            sys.stdout = open(os.devnull, "w")
        return EXIT_OK
    finally:
        if tty and shown:
            out.write("\n")
            out.flush()


def _every(client: VehicleClient, period_s: float, count: int | None, show: Callable[[], None]) -> int:
    """Call ``show`` every ``period_s`` wall seconds (``count`` times, None: until Ctrl-C) while receiving."""
    done = 0
    next_show = time.monotonic()
    try:
        while count is None or done < count:
            now = time.monotonic()
            if now >= next_show:
                show()
                done += 1
                next_show = max(next_show + period_s, now)
                continue
            client.pump(min(0.1, next_show - now))
    except KeyboardInterrupt:
        pass
    return EXIT_OK


def _wait_for_telemetry(client: VehicleClient, timeout_s: float | None) -> None:
    """Ask for the slow messages, then give the streams a moment (at most FIRST_LINE_WAIT_S)."""
    for mid in SLOW_MESSAGES:
        client.telemetry.request_message(mid)
    wanted = ("GLOBAL_POSITION_INT", "SYS_STATUS", "GPS_RAW_INT", "HOME_POSITION")
    try:
        client.wait_until(
            lambda: all(client.latest(t) for t in wanted), min(timeout_s or FIRST_LINE_WAIT_S, FIRST_LINE_WAIT_S)
        )
    except GcsTimeout:
        pass


def _battery(client: VehicleClient) -> str:
    volts, pct = client.battery()
    return "batt " + (f"{volts:.1f} V" if volts is not None else "? V") + " " + (f"{pct}%" if pct is not None else "?%")


def _gps(client: VehicleClient) -> str:
    gps = client.gps()
    return f"GPS {GPS_FIX_NAMES.get(gps[0], gps[0])} {gps[1]} sats" if gps is not None else "GPS ?"


def _silence(client: VehicleClient) -> list[str]:
    silent = client.age_s("HEARTBEAT")
    return [f"(no heartbeat for {silent:.0f} s)"] if silent is not None and silent > SILENT_NOTE_S else []


def watch_line(client: VehicleClient, first_text: int = 0) -> str:
    """One line of vehicle state (what ``gcs watch`` refreshes): mode, armed, lat/lon, altitude above home,
    battery, GPS, the last STATUSTEXT after the first ``first_text``."""
    c = client
    fields = [f"{c.mode_name() or '?':<9}", "ARMED   " if c.armed() else "disarmed"]
    pos, alt = c.global_position(), c.relative_alt_m()
    fields.append(f"{pos[0]:.7f} {pos[1]:.7f}" if pos is not None else "lat/lon ?")
    fields.append(f"alt {alt:6.2f} m" if alt is not None else "alt ? m")
    fields += [_battery(c), _gps(c), *_silence(c)]
    texts = c.statustexts[first_text:]
    if texts:
        fields.append(f"| {texts[-1].severity_name.lower()}: {texts[-1].text}")
    return "  ".join(fields)


def status_line(client: VehicleClient) -> str:
    """One human-readable line of vehicle state (what ``gcs status`` prints)."""
    c = client
    t = c.sim_time_s()
    fields = [
        f"t {t:8.2f} s" if t is not None else "t      ? s",
        f"{c.mode_name() or '?':<10}",
        "ARMED   " if c.armed() else "disarmed",
    ]
    pos = c.position_ned()
    if pos is not None:
        fields.append(f"N {pos[0]:7.2f} E {pos[1]:7.2f} alt {-pos[2]:6.2f} m")
    elif c.relative_alt_m() is not None:
        fields.append(f"N       ? E       ? alt {c.relative_alt_m():6.2f} m")
    else:
        fields.append("position ?")
    gs = c.ground_speed_m_s()
    fields.append(f"gs {gs:4.1f} m/s" if gs is not None else "gs ? m/s")
    fields += [_battery(c), _gps(c)]
    if not c.prearm_ok() and not c.armed() and c.latest("SYS_STATUS") is not None:
        fields.append("not ready")
    return "  ".join(fields + _silence(c))
