"""The simulator's TCP port verifies its peer, and both of the simulator's ports bind the loopback address
(issue 18, findings 6 and 7), over real sockets on this machine.

* :func:`sitl.peer_accept.accept_peer` drops a peer that stays silent or sends garbage for its handshake
  timeout and serves the next one in the queue, which sends a HEARTBEAT.
* :meth:`autopilot.mavlink.sim_link.SimLink.connect` sends a HEARTBEAT on connecting and, with a handshake
  timeout, counts as connected only once the other end has sent a valid MAVLink message: a port held by
  something that accepts and stays silent makes it connect again.
* :class:`sitl.lockstep.LockstepServer` listens on 127.0.0.1 and its ``SIM_*``/truth socket is bound to
  127.0.0.1 unless told otherwise; the port is not reachable on this machine's other addresses.
"""

from __future__ import annotations

import socket
import threading
import time
from types import SimpleNamespace

from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink.sim_link import SimLink
from sitl.peer_accept import accept_peer, listen
from sitl.sim_settings import CameraSettings, MotorSettings, SensorSettings, UgvSettings, WindSettings


def heartbeat_bytes(sysid: int = 1) -> bytes:
    mav = mavlink.MAVLink(None, sysid, 1)
    return mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_QUADROTOR, 12, 0, 0, 0, 3).pack(mav)


def test_accept_peer_drops_silent_and_garbage_peers_and_serves_the_next():
    listener = listen("127.0.0.1", 0)
    port = listener.getsockname()[1]
    silent = socket.create_connection(("127.0.0.1", port))
    garbage = socket.create_connection(("127.0.0.1", port))
    garbage.sendall(b"GET / HTTP/1.0\r\n\r\n" * 4)
    good = socket.create_connection(("127.0.0.1", port))
    good.sendall(heartbeat_bytes())
    logged: list[str] = []
    served: list[int] = []
    try:
        start = time.monotonic()
        conn, addr = accept_peer(listener, lambda: served.append(1), log=logged.append, timeout_s=0.3)
        assert addr == good.getsockname()
        conn.close()
        assert len(logged) == 2 and all(text.startswith("dropped 127.0.0.1:") for text in logged), logged
        assert time.monotonic() - start >= 0.3  # the silent one had its full timeout (garbage too)
        assert len(served) >= 3  # the parameter service was served while waiting
        silent.settimeout(1.0)
        assert silent.recv(10) == b""  # the simulator closed the squatter's connection
    finally:
        for s in (silent, garbage, good, listener):
            s.close()


def test_sim_link_connects_again_until_the_other_end_answers():
    listener = listen("127.0.0.1", 0)
    port = listener.getsockname()[1]
    seen: list[bytes] = []

    def server() -> None:
        first, _ = listener.accept()  # accepts, reads, never answers: a squatter's behaviour
        seen.append(first.recv(4096))
        second, _ = listener.accept()
        seen.append(second.recv(4096))
        second.sendall(heartbeat_bytes(sysid=2))
        time.sleep(0.5)
        first.close()
        second.close()

    thread = threading.Thread(target=server, daemon=True)
    thread.start()
    link = SimLink("127.0.0.1", port, sysid=7)
    waits: list[int] = []
    try:
        link.connect(on_wait=lambda: waits.append(1), handshake_timeout_s=0.3)
        assert len(seen) == 2 and waits  # connected twice; the ground link was served meanwhile
        parser = mavlink.MAVLink(None)
        for data in seen:  # each connection began with our HEARTBEAT
            msgs = parser.parse_buffer(data)
            assert msgs and msgs[0].get_type() == "HEARTBEAT" and msgs[0].get_srcSystem() == 7
        got = link.receive(timeout_s=1.0)
        assert got and got[0].get_type() == "HEARTBEAT" and got[0].get_srcSystem() == 2  # kept for receive()
    finally:
        link.close()
        thread.join(2.0)
        listener.close()


def _lockstep_server(**kwargs):
    from sitl.lockstep import LockstepServer

    fake_sim = SimpleNamespace(
        wind_settings=WindSettings(),
        sensors=SimpleNamespace(settings=SensorSettings()),
        motor_settings=MotorSettings(),
        ugv_settings=UgvSettings(),
        camera_settings=CameraSettings(),
        rotors=SimpleNamespace(n=4),
    )
    return LockstepServer(fake_sim, 0, ("127.0.0.1", 9), None, **kwargs)


def other_addresses() -> set[str]:
    """This machine's IPv4 addresses outside 127/8 (the source address toward a few networks; no packet sent)."""
    found = set()
    for probe in ("192.0.2.1", "10.255.255.254", "172.31.255.254", "192.168.255.254", "8.8.8.8"):
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            try:
                s.connect((probe, 9))
                found.add(s.getsockname()[0])
            except OSError:
                pass
    return {a for a in found if not a.startswith("127.") and a != "0.0.0.0"}


def test_simulator_ports_bind_loopback_by_default():
    server = _lockstep_server()
    try:
        tcp_host, tcp_port = server.listener.getsockname()
        assert tcp_host == "127.0.0.1" and server.param_server.local_address[0] == "127.0.0.1"
        for address in other_addresses():
            with socket.socket() as s:
                s.settimeout(1.0)
                assert s.connect_ex((address, tcp_port)) != 0, f"TCP {tcp_port} reachable on {address}"
    finally:
        server.close()


def test_simulator_ports_widen_on_request():
    server = _lockstep_server(bind_host="0.0.0.0", truth_bind=("0.0.0.0", 0))
    try:
        assert server.listener.getsockname()[0] == "0.0.0.0"
        assert server.param_server.local_address[0] == "0.0.0.0"
    finally:
        server.close()


def test_sitl_has_a_bind_option_defaulting_to_loopback():
    from sitl.__main__ import build_parser

    assert build_parser().parse_args([]).bind == "127.0.0.1"
    assert build_parser().parse_args(["--bind", "0.0.0.0"]).bind == "0.0.0.0"


def test_the_flight_controller_connects_to_loopback_by_default():
    from autopilot.__main__ import build_parser

    assert build_parser().parse_args([]).sim_host == "127.0.0.1"
