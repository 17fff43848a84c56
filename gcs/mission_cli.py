"""``gcs mission``: upload, download, start, pause, clear and follow a vehicle's plans.

``upload FILE`` sends what a QGroundControl ``.plan`` holds (mission, geofence and rally points;
a section the file does not have is cleared on the vehicle, so the vehicle then holds exactly the
file) or a ``QGC WPL 110`` file (the mission only).  ``download [FILE]`` fetches the three plans and
prints them, or writes them (``.plan``: all three; ``.waypoints``/``.txt``/``.wpl``: the mission).
``start`` switches to AUTO.MISSION and arms when disarmed (the mission takes off by itself, as PX4's
does), ``pause`` switches to AUTO.LOITER (``start`` resumes at the same item), ``clear`` clears the
plans (``--type``), ``status`` prints the current item and the state once a second (``--once``).
A broken file is refused before anything is sent, naming the line and the field.
"""

from __future__ import annotations

import argparse
import sys
import time

from gcs.client import VehicleClient
from gcs.errors import EXIT_NO_ANSWER, EXIT_OK, EXIT_REFUSED
from gcs.mission_files import Plan, PlanFileError, read_plan_file, write_plan_file
from gcs.mission_transfer import MissionRefused, download, upload
from mavsim_core import mission_items as mi

STATES = {0: "unknown", 1: "no mission", 2: "not started", 3: "active", 4: "paused", 5: "complete"}
TYPES = {"mission": (mi.MISSION,), "fence": (mi.FENCE,), "rally": (mi.RALLY,), "all": (mi.MISSION, mi.FENCE, mi.RALLY)}


def add_mission_parser(sub: argparse._SubParsersAction) -> None:
    p = sub.add_parser("mission", help="upload/download/start/pause/clear missions, geofence and rally points")
    msub = p.add_subparsers(dest="mission_command", required=True, metavar="ACTION")
    u = msub.add_parser("upload", help="upload a QGroundControl .plan (mission, fence, rally) or a QGC WPL 110 file")
    u.add_argument("file")
    d = msub.add_parser("download", help="print the vehicle's plans, or write them to FILE (.plan or .waypoints)")
    d.add_argument("file", nargs="?")
    msub.add_parser("start", help="fly the mission (AUTO.MISSION; arms when disarmed and takes off)")
    msub.add_parser("pause", help="hold position (AUTO.LOITER); start resumes at the current item")
    c = msub.add_parser("clear", help="clear the vehicle's plans")
    c.add_argument("--type", choices=sorted(TYPES), default="all", help="which plan (default all)")
    s = msub.add_parser("status", help="current item, total and state, once a second")
    s.add_argument("--once", action="store_true", help="print one line and exit")


def load_file(path: str) -> Plan | None:
    """The plan in ``path``, or None after printing what is wrong with it."""
    try:
        return read_plan_file(path)
    except PlanFileError as exc:
        print(f"gcs: mission upload: {exc}", file=sys.stderr)
    except OSError as exc:
        print(f"gcs: mission upload: cannot read {path}: {exc.strerror}", file=sys.stderr)
    return None


def run_mission_command(client: VehicleClient, args: argparse.Namespace) -> int:
    action = args.mission_command
    try:
        if action == "upload":
            return _upload(client, args.file, args.plan)
        if action == "download":
            return _download(client, args.file)
        if action == "clear":
            for mtype in TYPES[args.type]:
                upload(client, [], mtype)
            print(f"cleared: {args.type}")
            return EXIT_OK
        if action == "start":
            client.set_mode("MISSION").check()
            if not client.armed():
                client.arm().check()
            print("mission started")
            return EXIT_OK
        if action == "pause":
            client.set_mode("LOITER").check()
            print("mission paused (LOITER)")
            return EXIT_OK
        return _status(client, args.once)
    except MissionRefused as exc:
        print(f"gcs: mission {action}: {exc}", file=sys.stderr)
        return EXIT_REFUSED


def _upload(client: VehicleClient, path: str, plan: Plan) -> int:
    is_wpl = not path.endswith(".plan") and not plan.fence and not plan.rally
    parts = [(mi.MISSION, plan.mission)] + ([] if is_wpl else [(mi.FENCE, plan.fence), (mi.RALLY, plan.rally)])
    t0 = time.monotonic()
    for mtype, items in parts:
        upload(client, items, mtype)
    counts = ", ".join(f"{len(items)} {mi.TYPE_NAMES[t]}" for t, items in parts)
    print(f"uploaded {counts} items in {time.monotonic() - t0:.2f} s")
    return EXIT_OK


def _download(client: VehicleClient, path: str | None) -> int:
    plan = Plan(download(client, mi.MISSION), download(client, mi.FENCE), download(client, mi.RALLY))
    home = client.home()
    if home is not None:
        plan.home = (home.lat_deg, home.lon_deg, home.alt_amsl_m)
    if path:
        try:
            write_plan_file(path, plan)
        except (PlanFileError, OSError) as exc:
            print(f"gcs: mission download: {exc}", file=sys.stderr)
            return EXIT_REFUSED
        print(f"wrote {len(plan.mission)} mission, {len(plan.fence)} fence, {len(plan.rally)} rally items to {path}")
        return EXIT_OK
    for name, items in (("mission", plan.mission), ("fence", plan.fence), ("rally", plan.rally)):
        print(f"{name}: {len(items)} items")
        for it in items:
            print(
                f"  {it.seq:3d} {it.name:<34} frame {it.frame} p {it.param1:g} {it.param2:g} {it.param3:g} "
                f"{it.param4:g}  {it.lat_deg:.7f} {it.lon_deg:.7f} {it.z:g}"
            )
    return EXIT_OK


def _status(client: VehicleClient, once: bool) -> int:
    while True:
        msg = client.recv("MISSION_CURRENT", 3.0)
        if msg is None:
            print("gcs: mission status: no MISSION_CURRENT from the vehicle", file=sys.stderr)
            return EXIT_NO_ANSWER
        state = STATES.get(msg.mission_state, str(msg.mission_state))
        mode = client.mode_name() or "?"
        print(f"item {msg.seq} of {msg.total}, {state}, mode {mode}", flush=True)
        if once:
            return EXIT_OK
        time.sleep(1.0)
