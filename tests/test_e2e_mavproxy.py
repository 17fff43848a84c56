"""MAVProxy on the real stack as a user starts it (its default modules, FTP included), and the other
clients of MAVLink FTP and component metadata: MAVSDK's Ftp and ComponentMetadata plugins.

MAVProxy (in a virtual environment of its own, tests/mavproxy_env.py) first asks for the parameters
over FTP (``@PARAM/param.pck``, ArduPilot's file); the flight controller NAKs it with FileNotFound at
once and MAVProxy falls back to the parameter protocol.  A relay between MAVProxy and the vehicle
records the FTP exchange: the request, a NAK answering it (MAVProxy resends after a second without an
answer and gives up after ten; a resend on a busy machine is answered too), then PARAM_REQUEST_LIST; the time from
MAVProxy's start to "Received N parameters" is printed.  The same for the simulator's own component.
Then MAVProxy's ``ftp list`` / ``get`` / ``crc`` / ``rm`` and MAVSDK's list, download, compare and
remove on the same read-only tree, and MAVSDK fetching the parameter metadata through
COMPONENT_METADATA.
"""

from __future__ import annotations

import asyncio
import json
import os
import socket
import threading
import time

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from autopilot.param_catalogue import catalogue  # noqa: E402
from gcs.launcher import Stack  # noqa: E402
from mavsim_core import ports  # noqa: E402
from mavsim_core.mavftp import Err, Op, crc32, decode  # noqa: E402

from e2e_params_clients import MavproxySession  # tests/e2e_params_clients.py

pytestmark = pytest.mark.e2e
WAIT_S = 120.0  # wall-clock safety net of each wait
PARAM_PCK = "@PARAM/param.pck"
NOTES = os.urandom(50_000)  # a file put in the log directory, read back by the clients


@pytest.fixture(scope="module")
def stack(inst):
    """The stack at real time (``--speed 1``), as a person runs it beside MAVProxy: nothing here flies, and at
    ``max`` it would step as fast as it can, taking the CPU from the clients under test (MAVProxy takes seconds
    to start; their FTP and parameter timeouts are wall-clock ones)."""
    from gcs.client import VehicleClient

    with Stack(instance=inst, speed=1) as s:
        (s.log_dir / "notes.bin").write_bytes(NOTES)
        with VehicleClient(s.api_url, timeout_s=WAIT_S, idle=s.check_alive):
            pass  # running: clients connect to a vehicle that is up, as a user's do
        yield s


class RecordingRelay:
    """A UDP relay between a client and a vehicle that decodes and timestamps what passes.

    The client talks to ``port``; the vehicle side either sends to ``vehicle_port`` (the flight
    controller answers whoever talks to it) or, with ``bind_vehicle_side``, listens on it (the
    simulator's component sends there)."""

    def __init__(self, vehicle_port: int, bind_vehicle_side: bool = False) -> None:
        self.client_sock = self._udp(0)
        self.vehicle_sock = self._udp(vehicle_port if bind_vehicle_side else 0)
        self.port = self.client_sock.getsockname()[1]
        self.vehicle = None if bind_vehicle_side else ("127.0.0.1", vehicle_port)
        self.client: tuple[str, int] | None = None
        self.seen: list[tuple[float, str, mavlink.MAVLink_message]] = []  # (monotonic s, "up"/"down", message)
        self._parsers = {"up": mavlink.MAVLink(None), "down": mavlink.MAVLink(None)}
        self.running = True
        self.threads = [threading.Thread(target=self._run, args=(way,), daemon=True) for way in ("up", "down")]
        for t in self.threads:
            t.start()

    @staticmethod
    def _udp(port: int) -> socket.socket:
        s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        s.bind(("127.0.0.1", port))
        s.settimeout(0.05)
        return s

    def _run(self, way: str) -> None:
        src, dst = (self.client_sock, self.vehicle_sock) if way == "up" else (self.vehicle_sock, self.client_sock)
        while self.running:
            try:
                data, addr = src.recvfrom(65535)
            except OSError:
                continue
            if way == "up":
                self.client = addr
            elif self.vehicle is None:
                self.vehicle = addr
            now = time.monotonic()
            for m in self._parsers[way].parse_buffer(data) or []:
                self.seen.append((now, way, m))
            to = self.vehicle if way == "up" else self.client
            if to is not None:
                dst.sendto(data, to)

    def ftp(self) -> list[tuple[float, str, object]]:
        return [(t, w, decode(m.payload)) for t, w, m in self.seen if m.get_type() == "FILE_TRANSFER_PROTOCOL"]

    def first(self, mtype: str, way: str = "up") -> float | None:
        return next((t for t, w, m in self.seen if w == way and m.get_type() == mtype), None)

    def close(self) -> None:
        self.running = False
        for t in self.threads:
            t.join(timeout=2)
        self.client_sock.close()
        self.vehicle_sock.close()


def _ready_without_ftp_timeout(relay: RecordingRelay, expected_params: int, what: str, nak: Err) -> None:
    """MAVProxy with its default modules through ``relay``: ready with every parameter, the FTP request
    for param.pck answered by one ``nak`` and never sent again."""
    mavproxy = MavproxySession(f"udpout:127.0.0.1:{relay.port}", modules=None)
    try:
        count = int(mavproxy.expect(r"Received (\d+) parameters", WAIT_S).group(1))
        ready_s = time.monotonic() - mavproxy.started
    finally:
        mavproxy.close()
        relay.close()
    ftp = relay.ftp()
    requests = [(t, p) for t, w, p in ftp if w == "up"]
    replies = [(t, p) for t, w, p in ftp if w == "down"]
    assert len(requests) >= 1 and requests[0][1].opcode == Op.OPEN_FILE_RO
    t_req, req = requests[0]
    assert req.path().startswith(PARAM_PCK)
    # A busy machine may let MAVProxy resend before the answer reaches it; every request is answered at once
    # (before anything else MAVProxy sends), none is left to its timeout.
    answered = [any(r.req_opcode == p.opcode and r.seq == p.seq + 1 for _, r in replies) for _, p in requests]
    assert all(answered), f"FTP requests left unanswered: {answered}"
    t_nak, reply = next((t, p) for t, p in replies if p.req_opcode == Op.OPEN_FILE_RO)
    assert (reply.opcode, reply.data[0], reply.seq, reply.session) == (Op.NAK, nak, req.seq + 1, req.session)
    t_list = relay.first("PARAM_REQUEST_LIST")
    assert t_list is not None and t_list > t_nak  # the fallback followed the NAK
    assert count == expected_params
    print(
        f"MAVProxy on {what}: ready ({count} parameters) {ready_s:.2f} s after its start; FTP NAK "
        f"{1e3 * (t_nak - t_req):.1f} ms after the request, PARAM_REQUEST_LIST {t_list - t_nak:.2f} s after the NAK"
    )


def test_mavproxy_is_ready_without_waiting_for_ftp(stack):
    count = _param_count(f"udpout:127.0.0.1:{ports.gcs_local_port(stack.instance)}")
    relay = RecordingRelay(ports.gcs_local_port(stack.instance))  # the flight controller's ground-station socket
    _ready_without_ftp_timeout(relay, count, "the flight controller", Err.FILE_NOT_FOUND)


def test_mavproxy_on_the_simulator_component_is_ready_without_waiting_for_ftp(stack):
    count = _param_count(f"udpin:127.0.0.1:{ports.sim_component_port(stack.instance)}")
    relay = RecordingRelay(ports.sim_component_port(stack.instance), bind_vehicle_side=True)
    _ready_without_ftp_timeout(relay, count, "the simulator's component", Err.UNKNOWN_COMMAND)


def _param_count(url: str) -> int:
    """How many parameters the component at ``url`` reports (PARAM_VALUE.param_count): the vehicle's own
    list, not the catalogue of this process (the code may change while the suite runs)."""
    from pymavlink import mavutil

    c = mavutil.mavlink_connection(url, dialect="common")
    try:
        c.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)  # udpout: become a peer
        hb = c.wait_heartbeat(timeout=WAIT_S)
        assert hb is not None, f"no HEARTBEAT on {url}"
        c.mav.param_request_read_send(hb.get_srcSystem(), hb.get_srcComponent(), b"", 0)
        m = c.recv_match(type="PARAM_VALUE", blocking=True, timeout=WAIT_S)
        assert m is not None, f"no PARAM_VALUE on {url}"
        return m.param_count
    finally:
        c.close()


def test_mavproxy_ftp_list_get_crc_and_a_refused_remove(stack, tmp_path):
    mavproxy = MavproxySession(f"udpout:127.0.0.1:{ports.gcs_local_port(stack.instance)}", modules="ftp")
    try:
        mavproxy.expect(rf"online system {stack.sysid}\b")
        mavproxy.send("ftp list /")
        names = {mavproxy.expect(r"^(?:\S+> )*\s*D (\S+)").group(1) for _ in range(2)}
        assert names == {"log", "component_metadata"}
        mavproxy.send("ftp list /log")
        mavproxy.expect(rf"notes\.bin\t{len(NOTES)}")
        local = tmp_path / "notes.bin"
        mavproxy.send(f"ftp get /log/notes.bin {local}")
        assert int(mavproxy.expect(r"Wrote (\d+) bytes to").group(1)) == len(NOTES)
        mavproxy.send("ftp crc /log/notes.bin")
        assert int(mavproxy.expect(r"crc: \S+ 0x([0-9a-f]{8})").group(1), 16) == crc32(NOTES)
        mavproxy.send("ftp rm /log/notes.bin")
        mavproxy.expect(r"Remove failed")
    finally:
        mavproxy.close()
    assert local.read_bytes() == NOTES
    assert (stack.log_dir / "notes.bin").read_bytes() == NOTES  # refused: still there


async def _mavsdk_files(stack, into) -> dict:
    from mavsdk.asyncio.plugins.component_metadata import ComponentMetadataAsync
    from mavsdk.asyncio.plugins.ftp import FtpAsync
    from mavsdk.asyncio.plugins.param import ParamAsync
    from mavsdk.plugins.component_metadata import MetadataType
    from mavsdk.plugins.ftp import FtpError
    from mavsdk_session import ground_station

    out: dict = {}
    async with ground_station() as sdk:  # tests/mavsdk_session.py: plugins released first
        await sdk.add_any_connection(f"udpin://0.0.0.0:{stack.api_port}")
        system = await sdk.first_autopilot(timeout_s=WAIT_S)
        assert system is not None, "MAVSDK found no autopilot"
        ftp = FtpAsync(system)
        out["root"] = {(e.name, e.entry_type.name) for e in (await ftp.list_directory("/")).entries}
        out["log"] = {e.name: e.size_bytes for e in (await ftp.list_directory("/log")).entries}
        async for _ in ftp.download("/log/notes.bin", str(into), True):
            pass
        out["identical"] = await ftp.are_files_identical(str(into / "notes.bin"), "/log/notes.bin")
        for name, call in (("remove", ftp.remove_file("/log/notes.bin")), ("missing", _get(ftp, "/nope.bin", into))):
            try:
                await call
                out[name] = "accepted"
            except FtpError as e:
                out[name] = e.result.name
        every = await ParamAsync(system).get_all_params()
        out["names"] = {p.name for p in every.int_params + every.float_params}
        meta = ComponentMetadataAsync(system)
        await meta.request_autopilot_component()
        out["parameters"] = await _parameter_metadata(meta, MetadataType)
    return out


async def _parameter_metadata(meta, types) -> dict | str:
    """The parameter metadata MAVSDK fetched (COMPONENT_METADATA, then the files over FTP), or why not.

    MAVSDK reports each metadata type it got, then ALL_COMPLETED; a file it could not download (its FTP
    timeouts are wall-clock ones) is simply missing before ALL_COMPLETED.  If its COMPONENT_METADATA request
    gets no answer at all (the vehicle silent for all its retries: a stall of some 6-12 s of wall time, found
    by SIGSTOPping the flight controller), MAVSDK 4.1 reports nothing ever ("Unexpected component ID 0"): the
    wait below is bounded so that the failure names that, not a bare TimeoutError."""
    found: dict | str = "no PARAMETER metadata before ALL_COMPLETED"

    async def collect() -> None:
        nonlocal found
        async for update in meta.subscribe_metadata_available():
            if update.type == types.PARAMETER:
                found = json.loads(update.json_metadata)
            elif update.type == types.ALL_COMPLETED:
                return

    try:
        await asyncio.wait_for(collect(), WAIT_S / 2)
    except asyncio.TimeoutError:
        found = f"MAVSDK never completed the autopilot's component metadata in {WAIT_S / 2:g} s (wall)"
    return found


async def _get(ftp, path, into) -> None:
    async for _ in ftp.download(path, str(into), False):
        pass


def test_mavsdk_ftp_and_component_metadata(stack, tmp_path, monkeypatch):
    pytest.importorskip("mavsdk", reason="MAVSDK is in the test extras: pip install '.[test]'")
    # MAVSDK caches metadata files under $HOME/.cache/mavsdk by their CRC: a home of its own, so that the
    # files are fetched over FTP here, not read from what an earlier run left.
    monkeypatch.setenv("HOME", str(tmp_path / "home"))
    (tmp_path / "home").mkdir()
    got = asyncio.run(asyncio.wait_for(_mavsdk_files(stack, tmp_path), WAIT_S))
    assert isinstance(got["parameters"], dict), got["parameters"]
    assert any((tmp_path / "home" / ".cache" / "mavsdk").rglob("*.cache")), "no metadata file fetched"
    assert got["root"] == {("log", "DIRECTORY"), ("component_metadata", "DIRECTORY")}
    assert got["log"]["notes.bin"] == len(NOTES) and "autopilot.log" in got["log"]
    assert (tmp_path / "notes.bin").read_bytes() == NOTES  # MAVSDK's burst download
    assert got["identical"] is True  # CalcFileCRC32 agrees with MAVSDK's own CRC32 of the file
    assert (got["remove"], got["missing"]) == ("FILE_PROTECTED", "FILE_DOES_NOT_EXIST")
    params = {p["name"]: p for p in got["parameters"]["parameters"]}
    assert set(params) == got["names"]  # every parameter the vehicle has, described
    d = catalogue()["MPC_XY_P"]
    assert (params["MPC_XY_P"]["min"], params["MPC_XY_P"]["max"], params["MPC_XY_P"]["units"]) == (d.min, d.max, d.unit)
    assert params["MPC_XY_P"]["shortDesc"] and d.description.startswith(params["MPC_XY_P"]["shortDesc"])
    assert (stack.log_dir / "notes.bin").read_bytes() == NOTES
