"""Missions from the other clients on the real stack: MAVProxy's ``wp``, ``gcs mission``, a lossy link.

MAVProxy loads a QGC WPL 110 file, lists it back and the mission is flown after ``long
DO_SET_MODE``, until MAVProxy's ``land`` (MAV_CMD_DO_LAND_START) takes it to its landing
sequence; a return with RTL_TYPE 1 flies a mission's landing too; ``gcs mission upload`` sends a
QGroundControl ``.plan`` with mission, fence and rally points, and a return then goes to the
rally point; a broken file is refused naming its line and leaves the vehicle's plan as it was;
through a proxy that drops every fifth datagram in each direction, upload and download still
complete.  Positions are checked against the simulator's ground truth.
"""

from __future__ import annotations

import math
import socket
import subprocess
import sys
import threading

import pytest

from gcs.client import VehicleClient, mavlink
from gcs.mission_files import parse_qgc_plan
from gcs.mission_transfer import download, upload
from mavsim_core import mission_items as mi
from mavsim_core import ports

from e2e_flight_helpers import (  # tests/e2e_flight_helpers.py
    SIM_HOME,
    closest_approach,
    latlon,
    truth_and_stack_fixtures,
)
from e2e_params_clients import MavproxySession  # tests/e2e_params_clients.py

pytestmark = pytest.mark.e2e
truth, stack = truth_and_stack_fixtures()


def gcs(stack) -> list[str]:
    """``python -m gcs`` on the stack's own ground-station port."""
    return [sys.executable, "-m", "gcs", "--url", f"udpin:0.0.0.0:{stack.gcs_port}", "-i", str(stack.instance)]


@pytest.fixture()
def vehicle(stack):
    with VehicleClient(stack.api_url, timeout_s=60, idle=stack.check_alive) as c:
        c.wait_until(lambda: c.prearm_ok() and not c.armed(), 90, "ready to arm")
        yield c


def test_mavproxy_wp_load_list_fly_and_land_skips_to_the_mission_landing(stack, truth, vehicle, tmp_path):
    """A mission with a landing sequence (DO_LAND_START, an approach point, NAV_LAND) after a survey; MAVProxy's
    ``land`` (MAV_CMD_DO_LAND_START to component 0) during the hold at the first survey point: the vehicle leaves
    the survey and lands where the mission's landing says, in AUTO.MISSION, as PX4 does."""
    survey = [(0, 0), (12, 0), (12, 12), (0, 12)]
    landing = (6.0, 6.0)
    lines = ["QGC WPL 110"]
    for k, (n, e) in enumerate(survey):
        lat, lon = latlon(n, e)
        command, hold = (22, 0) if k == 0 else (16, 60 if k == 1 else 0)  # a long hold at item 1: land arrives in it
        lines.append(f"{k}\t0\t3\t{command}\t{hold}\t0\t0\t0\t{lat:.8f}\t{lon:.8f}\t5.0\t1")
    lat, lon = latlon(*landing)
    lines.append(f"{len(survey)}\t0\t2\t189\t0\t0\t0\t0\t0\t0\t0\t1")  # DO_LAND_START, MAV_FRAME_MISSION
    lines.append(f"{len(survey) + 1}\t0\t3\t16\t0\t0\t0\t0\t{lat:.8f}\t{lon:.8f}\t5.0\t1")
    lines.append(f"{len(survey) + 2}\t0\t3\t21\t0\t0\t0\t0\t{lat:.8f}\t{lon:.8f}\t0\t1")
    path = tmp_path / "survey.waypoints"
    path.write_text("\n".join(lines) + "\n")
    start_ms = truth.latest().time_ms
    n_texts = len(vehicle.statustexts)
    mavproxy = MavproxySession(f"udpin:127.0.0.1:{stack.gcs_port}", modules="wp,cmdlong,misc")
    try:
        mavproxy.expect(rf"online system {stack.sysid}\b")
        mavproxy.send(f"wp load {path}")
        mavproxy.expect(r"ACCEPTED")
        mavproxy.send("wp list")
        listed = [mavproxy.expect(r"^(16|21|22|189) \d+ (-?\d+\.\d+) (-?\d+\.\d+)") for _ in range(len(lines) - 1)]
        mavproxy.send("long DO_SET_MODE 1 4 4")  # custom mode: AUTO (4) . MISSION (4)
        mavproxy.send("long COMPONENT_ARM_DISARM 1 0")
        vehicle.wait_armed(True, 30)
        reached_1 = lambda: any(st.text == "Mission: item 1 reached" for st in vehicle.statustexts[n_texts:])  # noqa: E731
        vehicle.wait_until(reached_1, 120, "the hold at the first survey point")
        mavproxy.send("land")
        mavproxy.expect(r"Got COMMAND_ACK: DO_LAND_START: ACCEPTED")
        vehicle.wait_until(lambda: not vehicle.armed(), 180, "the mission's landing and disarm")
    finally:
        mavproxy.close()
    texts = [st.text for st in vehicle.statustexts[n_texts:]]
    assert [int(m.group(1)) for m in listed] == [22, 16, 16, 16, 189, 16, 21]
    assert float(listed[2].group(2)) == pytest.approx(latlon(12, 0)[0], abs=1e-7)
    assert "Mission landing: from item 4, landing at item 6" in texts and "Mission finished: landed" in texts
    assert not any(t.startswith("Mode ") and "MISSION" not in t for t in texts), texts  # in AUTO.MISSION throughout
    assert closest_approach(truth, start_ms, 12, 0) < 2.0
    assert closest_approach(truth, start_ms, 12, 12) > 5.0 and closest_approach(truth, start_ms, 0, 12) > 5.0
    end = truth.now().pos_ned_m  # after the reader caught up: latest() may be from before the landing
    assert math.hypot(end[0] - landing[0], end[1] - landing[1]) < 1.0 and abs(end[2]) < 0.5, (end, texts)


def _item(seq: int, command: int, north: float, east: float, alt: float, p1: float = 0.0) -> mi.MissionItem:
    lat, lon = latlon(north, east)
    return mi.MissionItem(seq, 3, command, p1, 0, 0, float("nan"), round(lat * 1e7), round(lon * 1e7), alt)


def test_return_with_rtl_type_1_flies_the_mission_landing(stack, truth, vehicle):
    """RTL_TYPE 1 (PX4: return through the mission's landing when there is one): a return during the mission's
    hold climbs to RTL_RETURN_ALT, flies the landing sequence and lands where the mission says, not at home."""
    landing = (6.0, 6.0)
    items = [_item(0, mi.NAV_TAKEOFF, 0, 0, 4.0), _item(1, mi.NAV_WAYPOINT, 2, 0, 4.0, p1=60.0),  # a long hold
             _item(2, mi.NAV_WAYPOINT, -10, 0, 4.0), mi.MissionItem(3, 2, mi.DO_LAND_START),
             _item(4, mi.NAV_WAYPOINT, *landing, 4.0), _item(5, mi.NAV_LAND, *landing, 0.0)]  # fmt: skip
    return_alt = vehicle.param_get("RTL_RETURN_ALT", timeout_s=10)
    n_texts = len(vehicle.statustexts)
    try:
        vehicle.param_set("RTL_TYPE", 1, timeout_s=10)
        vehicle.param_set("RTL_RETURN_ALT", 5.0, timeout_s=10)
        upload(vehicle, items, mi.MISSION)
        vehicle.set_mode("MISSION").check()
        vehicle.arm().check()
        reached_1 = lambda: any(st.text == "Mission: item 1 reached" for st in vehicle.statustexts[n_texts:])  # noqa: E731
        vehicle.wait_until(reached_1, 120, "the hold at item 1")
        start_ms = truth.caught_up()
        vehicle.return_to_launch().check()
        vehicle.wait_until(lambda: not vehicle.armed(), 120, "landed after the return")
    finally:
        vehicle.param_set("RTL_TYPE", 0, timeout_s=10)
        vehicle.param_set("RTL_RETURN_ALT", return_alt, timeout_s=10)
    texts = [st.text for st in vehicle.statustexts[n_texts:]]
    assert "Return: through the mission landing (items 3-5)" in texts, texts
    assert closest_approach(truth, start_ms, -10, 0) > 8.0  # straight to the landing, not along the mission
    top = min(s.pos_ned_m[2] for s in truth.since(start_ms))
    assert -5.6 < top < -4.5, top  # climbed to RTL_RETURN_ALT (5 m) before the landing sequence
    end = truth.now().pos_ned_m
    assert math.hypot(end[0] - landing[0], end[1] - landing[1]) < 1.0 and abs(end[2]) < 0.5, (end, texts)


def _plan_text(rally_ne: tuple[float, float]) -> str:
    wps = [(0, 0, 22), (10, 20, 16), (25, 20, 16)]
    items = []
    for k, (n, e, cmd) in enumerate(wps):
        lat, lon = latlon(n, e)
        items.append(
            f'{{"type": "SimpleItem", "command": {cmd}, "frame": 3, "params": [0, 0, 0, null, {lat}, {lon}, 6],'
            f' "autoContinue": true, "doJumpId": {k + 1}, "AMSLAltAboveTerrain": null, "Altitude": 6,'
            f' "AltitudeMode": 1}}'
        )
    rlat, rlon = latlon(*rally_ne)
    return (
        '{"fileType": "Plan", "version": 1, "groundStation": "QGroundControl", "mission": {"version": 2,'
        ' "firmwareType": 12, "vehicleType": 2, "cruiseSpeed": 15, "hoverSpeed": 5,'
        f' "plannedHomePosition": [{SIM_HOME[0]}, {SIM_HOME[1]}, 488.0], "items": [{", ".join(items)}]}},'
        ' "geoFence": {"version": 2, "polygons": [], "circles": [{"inclusion": true, "version": 1,'
        f' "circle": {{"center": [{SIM_HOME[0]}, {SIM_HOME[1]}], "radius": 200}}}}]}},'
        f' "rallyPoints": {{"version": 2, "points": [[{rlat}, {rlon}, 10]]}}}}'
    )


def test_gcs_mission_plan_with_fence_and_rally_then_return_goes_to_the_rally_point(stack, truth, vehicle, tmp_path):
    rally = (30.0, 30.0)
    plan = tmp_path / "survey.plan"
    plan.write_text(_plan_text(rally))
    out = subprocess.run([*gcs(stack), "mission", "upload", str(plan)], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    assert "3 mission, 1 fence, 1 rally" in out.stdout
    # a broken file: refused before anything is sent, the line named, the vehicle's plan unchanged
    broken = tmp_path / "broken.waypoints"
    broken.write_text("QGC WPL 110\n0\t0\t3\t16\t0\t0\t0\t0\t47.4\tabc\t5\t1\n")
    bad = subprocess.run([*gcs(stack), "mission", "upload", str(broken)], capture_output=True, text=True, timeout=60)
    assert bad.returncode == 1 and ":2:" in bad.stderr and "longitude" in bad.stderr, bad.stderr
    assert len(download(vehicle, mi.MISSION)) == 3 and len(download(vehicle, mi.RALLY)) == 1
    out = subprocess.run([*gcs(stack), "mission", "start"], capture_output=True, text=True, timeout=60)
    assert out.returncode == 0, out.stderr
    complete = mavlink.MISSION_STATE_COMPLETE
    vehicle.wait_until(lambda: getattr(vehicle.latest("MISSION_CURRENT"), "mission_state", 0) == complete, 120, "end")
    start_ms = truth.caught_up()  # the return's track from now (latest() may be behind on a loaded machine)
    vehicle.return_to_launch().check()
    vehicle.wait_until(lambda: not vehicle.armed(), 120, "landed after the return")
    end = truth.now().pos_ned_m
    texts = [st.text for st in vehicle.statustexts[-15:]]
    assert math.hypot(end[0] - rally[0], end[1] - rally[1]) < 1.5, (end, texts)  # the rally point, not home
    assert closest_approach(truth, start_ms, 0, 0) > 10.0
    upload(vehicle, [], mi.FENCE)
    upload(vehicle, [], mi.RALLY)


CONNECT_DATAGRAMS = 20  # the first datagrams each way pass: the client finds the vehicle before the losses


class LossyProxy:
    """A UDP relay that drops every fifth datagram in each direction (client <-> vehicle)."""

    def __init__(self, vehicle_port: int) -> None:
        self.vehicle = ("127.0.0.1", vehicle_port)
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.bind(("127.0.0.1", 0))
        self.sock.settimeout(0.05)
        self.port = self.sock.getsockname()[1]
        self.client: tuple[str, int] | None = None
        self.counts = {"up": 0, "down": 0}
        self.dropped = {"up": 0, "down": 0}
        self.running = True
        self.thread = threading.Thread(target=self._run, daemon=True)
        self.thread.start()

    def _run(self) -> None:
        while self.running:
            try:
                data, addr = self.sock.recvfrom(65535)
            except OSError:
                continue
            way = "down" if addr == self.vehicle else "up"
            if way == "up":
                self.client = addr
            self.counts[way] += 1
            if self.counts[way] > CONNECT_DATAGRAMS and self.counts[way] % 5 == 0:
                self.dropped[way] += 1
                continue
            dest = self.client if way == "down" else self.vehicle
            if dest is not None:
                self.sock.sendto(data, dest)

    def close(self) -> None:
        self.running = False
        self.thread.join(timeout=2)
        self.sock.close()


def test_upload_and_download_through_a_link_that_drops_every_fifth_datagram(stack, vehicle):
    proxy = LossyProxy(ports.gcs_local_port(stack.instance))  # the vehicle's ground-station socket
    items = parse_qgc_plan(_plan_text((5.0, 5.0))).mission
    items = [items[0]] + [
        mi.MissionItem(k, 3, 16, 0, 0, 0, float("nan"), *[round(v * 1e7) for v in latlon(k, -k)], 6.0)
        for k in range(1, 30)
    ]
    try:
        with VehicleClient(f"udpout:127.0.0.1:{proxy.port}", timeout_s=60) as lossy:
            upload(lossy, items, mi.MISSION)
            back = download(lossy, mi.MISSION)
    finally:
        proxy.close()
    assert proxy.dropped["up"] > 5 and proxy.dropped["down"] > 5, proxy.dropped
    assert [(b.command, b.x, b.y, b.z) for b in back] == [(i.command, i.x, i.y, i.z) for i in items]
    assert len(download(vehicle, mi.MISSION)) == len(items)  # what a direct client sees too
