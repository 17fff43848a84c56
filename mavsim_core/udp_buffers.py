"""Large receive buffers for the ground-station side's UDP sockets.

At 30x real time a flight controller sends its 50 Hz telemetry streams 1,500 times a wall second, and a
client that is busy for a moment (a test, a script between two reads, a loaded machine) finds Linux's
default 208 KiB receive buffer full: the datagrams that do not fit are dropped silently, among them
the STATUSTEXT a user waits for.  Asking for 4 MiB (what ``net.core.rmem_max`` allows here; the kernel
caps the request silently where it allows less) holds about 40,000 telemetry messages.
"""

from __future__ import annotations

import socket

RECEIVE_BUFFER_BYTES = 4 * 1024 * 1024


def enlarge_receive_buffer(sock: object, size: int = RECEIVE_BUFFER_BYTES) -> int:
    """Ask for a ``size``-byte receive buffer on ``sock``; the size the kernel granted (0 if it refused, or
    ``sock`` is not a UDP socket: a TCP or serial link of pymavlink's is left as it is)."""
    if not isinstance(sock, socket.socket) or sock.type != socket.SOCK_DGRAM:
        return 0
    try:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, size)
        return int(sock.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF))
    except OSError:
        return 0
