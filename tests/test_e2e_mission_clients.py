"""Missions from the other clients on the real stack: MAVProxy's ``wp``, ``gcs mission``, a lossy link.

MAVProxy loads a QGC WPL 110 file, lists it back and the mission is flown after ``long
DO_SET_MODE``; ``gcs mission upload`` sends a QGroundControl ``.plan`` with mission, fence and
rally points, and a return then goes to the rally point; a broken file is refused naming its
line and leaves the vehicle's plan as it was; through a proxy that drops every fifth datagram in
each direction, upload and download still complete.  Positions are checked against the
simulator's ground truth.
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


def test_mavproxy_wp_load_list_and_fly(stack, truth, vehicle, tmp_path):
    points = [(0, 0), (12, 0), (12, 12), (0, 12)]
    lines = ["QGC WPL 110"]
    for k, (n, e) in enumerate(points):
        lat, lon = latlon(n, e)
        command, alt = (22, 5.0) if k == 0 else (16, 5.0)
        lines.append(f"{k}\t0\t3\t{command}\t0\t0\t0\t0\t{lat:.8f}\t{lon:.8f}\t{alt}\t1")
    lat, lon = latlon(*points[-1])
    lines.append(f"{len(points)}\t0\t3\t21\t0\t0\t0\t0\t{lat:.8f}\t{lon:.8f}\t0\t1")
    path = tmp_path / "square.waypoints"
    path.write_text("\n".join(lines) + "\n")
    start_ms = truth.latest().time_ms
    mavproxy = MavproxySession(f"udpin:127.0.0.1:{stack.gcs_port}", modules="wp,cmdlong")
    try:
        mavproxy.expect(rf"online system {stack.sysid}\b")
        mavproxy.send(f"wp load {path}")
        mavproxy.expect(r"ACCEPTED")
        mavproxy.send("wp list")
        listed = [mavproxy.expect(r"^(16|21|22) 3 (\d+\.\d+) (\d+\.\d+)") for _ in range(len(points) + 1)]
        mavproxy.send("long DO_SET_MODE 1 4 4")  # custom mode: AUTO (4) . MISSION (4)
        mavproxy.send("long COMPONENT_ARM_DISARM 1 0")
        vehicle.wait_armed(True, 30)
        vehicle.wait_until(lambda: not vehicle.armed(), 180, "the mission's landing and disarm")
    finally:
        mavproxy.close()
    assert [int(m.group(1)) for m in listed] == [22, 16, 16, 16, 21]
    assert float(listed[2].group(2)) == pytest.approx(latlon(12, 0)[0], abs=1e-7)
    for n, e in points:
        assert closest_approach(truth, start_ms, n, e) < 2.0, (n, e)
    end = truth.now().pos_ned_m  # after the reader caught up: latest() may be from before the landing
    assert math.hypot(end[0] - 0, end[1] - 12) < 1.5 and abs(end[2]) < 0.5


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
