"""The ground-station side's UDP receive buffers (mavsim_core/udp_buffers.py)."""

from __future__ import annotations

import socket

from mavsim_core.udp_buffers import RECEIVE_BUFFER_BYTES, enlarge_receive_buffer


def test_the_receive_buffer_grows_as_far_as_the_kernel_allows_and_a_closed_socket_is_no_error():
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        default = s.getsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF)
        with open("/proc/sys/net/core/rmem_max") as f:
            allowed = int(f.read())
        granted = enlarge_receive_buffer(s)
        assert granted >= default
        assert allowed < RECEIVE_BUFFER_BYTES or granted >= RECEIVE_BUFFER_BYTES  # all asked for, where allowed
    closed = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    closed.close()
    assert enlarge_receive_buffer(closed) == 0
    assert enlarge_receive_buffer(None) == 0  # pymavlink's non-UDP links have no such socket
