"""The simulator's TCP port: listening on it and accepting the flight controller with a handshake.

A TCP connection alone proves nothing: any local program that connects first (a port scanner, a stuck
old process, a hostile user) would be what the simulator serves, and the lockstep would stall on a peer
that never answers while the real flight controller waits in the listen queue.  So the simulator accepts
a peer, then waits up to :data:`HANDSHAKE_TIMEOUT_S` (wall clock) for one valid MAVLink message from it
(the flight controller sends a HEARTBEAT as soon as it has connected: :mod:`autopilot.mavlink.sim_link`);
a peer that sends none, only garbage, or closes, is dropped and the next one in the queue is accepted.
While it waits, ``serve()`` runs at least every :data:`SERVE_PERIOD_S` (the ``SIM_*`` parameter service).

The port binds the loopback address unless told otherwise (``sitl --bind``): the lockstep link carries
the vehicle's sensors and motors and has no authentication.
"""

from __future__ import annotations

import select
import socket
import time
from typing import Callable, Sequence

from pymavlink.dialects.v20 import common as mavlink

HANDSHAKE_TIMEOUT_S = 2.0  # wall seconds a new peer has to send its first valid MAVLink message
SERVE_PERIOD_S = 0.1  # while waiting, serve the parameter service at least this often
LISTEN_BACKLOG = 8  # peers queued behind the one being checked (a squatter does not lock the rest out)


def listen(host: str, port: int) -> socket.socket:
    """A TCP socket listening on ``host:port`` (port 0: any free port); OSError with the port if it cannot."""
    listener = socket.socket(socket.AF_INET, socket.SOCK_STREAM)
    try:
        listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
        listener.bind((host, port))
        listener.listen(LISTEN_BACKLOG)
    except OSError as e:
        listener.close()
        raise OSError(e.errno, f"cannot listen on TCP {host}:{port}: {e.strerror}") from e
    return listener


def handshake(
    conn: socket.socket, serve: Callable[[], None], watched: Sequence[socket.socket], timeout_s: float
) -> bool:
    """True once ``conn`` has sent a valid MAVLink message within ``timeout_s``; False if it sent none,
    closed, or failed.  ``watched``: other sockets whose readiness calls ``serve()`` early."""
    parser = mavlink.MAVLink(None)
    parser.robust_parsing = True
    deadline = time.monotonic() + timeout_s
    while (remaining := deadline - time.monotonic()) > 0:
        serve()
        ready, _, _ = select.select([conn, *watched], [], [], min(remaining, SERVE_PERIOD_S))
        if conn not in ready:
            continue
        try:
            data = conn.recv(4096)
        except OSError:
            return False
        if not data:
            return False
        try:
            msgs = parser.parse_buffer(data) or []
        except mavlink.MAVError:
            msgs = []
        if any(m.get_type() != "BAD_DATA" for m in msgs):
            return True
    return False


def accept_peer(
    listener: socket.socket,
    serve: Callable[[], None],
    watched: Sequence[socket.socket] = (),
    log: Callable[[str], None] = lambda text: None,
    timeout_s: float = HANDSHAKE_TIMEOUT_S,
) -> tuple[socket.socket, tuple[str, int]]:
    """The next peer that passes :func:`handshake`, and its address; peers that fail are closed and logged.

    Blocks until one comes, calling ``serve()`` at least every SERVE_PERIOD_S and when a ``watched``
    socket is readable.
    """
    while True:
        serve()
        ready, _, _ = select.select([listener, *watched], [], [], SERVE_PERIOD_S)
        if listener not in ready:
            continue
        conn, addr = listener.accept()
        if handshake(conn, serve, watched, timeout_s):
            return conn, addr
        log(f"dropped {addr[0]}:{addr[1]}: no MAVLink message within {timeout_s:g} s of connecting")
        conn.close()
