"""One UDP endpoint of the ground-station link: socket and peers, encoder, send batching, streams.

The socket, the peers (whoever talks to the endpoint becomes a destination) and the
parsing of received datagrams are :class:`mavsim_core.mavlink_udp.UdpEndpoint`'s.  This
class adds what the link keeps per endpoint: a MAVLink encoder, the packets of one link
iteration held and sent several per datagram (up to MAX_DATAGRAM_BYTES, as PX4's UDP
links buffer theirs), the telemetry streams with their intervals (µs of simulated time),
the position in a parameter list being served, and the traffic tap.  Its socket's receive buffer is
enlarged (RX_SOCKET_BUFFER_BYTES) so a burst of a few hundred small datagrams (sticks at 150 Hz while
the loop was busy) waits for the link instead of being dropped by the kernel; the link reads them all
(:meth:`LinkEndpoint.read_waiting`) and sorts them by their headers (:mod:`autopilot.mavlink.rx_triage`).
HEARTBEAT's interval is not a client's to change (PX4 refuses SET_MESSAGE_INTERVAL for it too): every
ground station on an endpoint relies on it to see the vehicle.
"""

from __future__ import annotations

import math
import socket
from dataclasses import dataclass
from typing import Callable

from pymavlink.dialects.v20 import common as mavlink

from mavsim_core.mavlink_signing import SigningParser, SigningState
from mavsim_core.mavlink_udp import UdpEndpoint
from mavsim_core.sim_api_codec import MessageLayout, numeric_layout

MAX_DATAGRAM_BYTES = 1400  # packets of one update() share datagrams up to this size (under an Ethernet MTU)
RX_SOCKET_BUFFER_BYTES = 1 << 20  # asked for (Linux: doubled, capped at 2 x net.core.rmem_max)
# A stream goes out at most once per link update (50 Hz of simulated time): a shorter interval is accepted and
# capped, as PX4 accepts any interval and sends a stream at most once per iteration of its MAVLink loop.
MIN_STREAM_INTERVAL_US = 20_000


@dataclass(slots=True)
class Stream:
    """One telemetry stream of an endpoint (simulated µs)."""

    interval_us: int  # <= 0: disabled
    next_due_us: int


class LinkEndpoint(UdpEndpoint):
    """One UDP socket (:class:`UdpEndpoint`) with its encoder, send batching and streams."""

    def __init__(
        self,
        name: str,
        bind: tuple[str, int],
        default_dest: tuple[str, int],
        sysid: int,
        compid: int,
        default_intervals_us: dict[int, int],
    ) -> None:
        # MAVLink 2 signing (autopilot/mavlink/signing.py), shared by the encoder and the parser; no key: off
        self.signing = SigningState()
        super().__init__(f"gcs_link {name}", bind, default_dest, sysid, compid)
        try:
            self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, RX_SOCKET_BUFFER_BYTES)
        except OSError:  # not allowed here: the system's default buffer
            pass
        self.name = name
        self.mav = mavlink.MAVLink(self, sysid, compid)  # encoder: writes through self.write
        self.mav.signing = self.signing  # everything sent is signed once a key is set
        self.default_intervals_us = default_intervals_us
        self.streams = {mid: Stream(iv, 0) for mid, iv in default_intervals_us.items()}
        self.next_due_us = 0  # earliest next_due_us of the enabled streams
        self.param_cursor: int | None = None  # next index of a PARAM_REQUEST_LIST being served
        self.tap: Callable[[bytes], None] | None = None  # sees every packet sent (GcsLink.set_traffic_tap)
        self._batch: list[bytes] | None = None  # packets held for one datagram (begin_batch .. flush)
        self.ground_stations: set[tuple[tuple[str, int] | None, int, int]] = set()  # (address, sysid, compid) heard

    # -- signing
    def _new_parser(self) -> mavlink.MAVLink:
        """A parser that checks signatures with this endpoint's signing state (refusals counted there)."""
        p = SigningParser(None, self.sysid, self.compid)
        p.robust_parsing = True
        p.signing = self.signing
        return p

    def incoming(self, data: bytes, addr: tuple[str, int]) -> tuple[list[mavlink.MAVLink_message], int]:
        """The good (and, with a key, correctly signed) messages; refused packets are not counted as damage."""
        refused = self.signing.refused
        msgs, damaged = super().incoming(data, addr)
        return msgs, damaged - (self.signing.refused - refused)

    # -- sending
    def write(self, data: bytes) -> None:
        """File-like sink for the encoder: the packet joins the open batch, or goes out as a datagram."""
        if self.tap is not None:
            self.tap(data)
        if self._batch is not None:
            self._batch.append(data)
        else:
            self.send_datagram(data)

    def begin_batch(self) -> None:
        """Hold the packets sent from now until :meth:`flush` (one link iteration)."""
        self._batch = []

    def flush(self) -> None:
        """The held packets, several per datagram (up to MAX_DATAGRAM_BYTES), as PX4's UDP link sends them."""
        batch, self._batch = self._batch, None
        if not batch:
            return
        data = b"".join(batch)
        if len(data) <= MAX_DATAGRAM_BYTES:  # (the usual case) all in one datagram
            self.send_datagram(data)
            return
        out: list[bytes] = []
        size = 0
        for packet in batch:
            if out and size + len(packet) > MAX_DATAGRAM_BYTES:
                self.send_datagram(b"".join(out))
                out, size = [], 0
            out.append(packet)
            size += len(packet)
        self.send_datagram(b"".join(out))

    def send(self, msg: mavlink.MAVLink_message) -> bytes | None:
        """``mav.send(msg)``; a message of numbers only, unsigned, is packed by its precomputed layout (the
        same bytes: :func:`mavsim_core.sim_api_codec.numeric_layout`), a third of pymavlink's work, and that
        packet is returned (None when pymavlink packed it)."""
        mav, layout = self.mav, numeric_layout(type(msg))
        if layout is None or mav.signing.sign_outgoing or "pack" in msg.__dict__:
            mav.send(msg)
            return None
        data = layout.encode(mav, layout.values_of(msg))
        mav.total_bytes_sent += len(data)
        self.write(data)
        return data

    def send_as(self, msg: mavlink.MAVLink_message, compid: int) -> None:
        """Send ``msg`` as component ``compid`` of this system (a device the flight controller speaks for, as
        PX4 forwards a MAVLink gimbal's messages), the endpoint's own component restored after."""
        own, self.mav.srcComponent = self.mav.srcComponent, compid
        try:
            self.mav.send(msg)
        finally:
            self.mav.srcComponent = own

    def send_payload(self, layout: MessageLayout, payload: bytes) -> None:
        """Send the message whose MAVLink 2 payload (trailing zeros trimmed) ``layout`` packed already, e.g. for
        another endpoint: the bytes :meth:`send` writes for that message, framed with this endpoint's sequence
        number (unsigned only: the caller checks ``signing.sign_outgoing``)."""
        data = layout.frame(self.mav, payload)
        self.mav.total_bytes_sent += len(data)
        self.write(data)

    # -- streams
    def refresh_next_due(self) -> None:
        due = [s.next_due_us for s in self.streams.values() if s.interval_us > 0]
        self.next_due_us = min(due) if due else 2**63

    def set_interval(self, msg_id: int, interval_us: int, now_us: int) -> int:
        """MAV_CMD_SET_MESSAGE_INTERVAL on this endpoint: -1 disable, 0 default, > 0 µs; a MAV_RESULT
        (DENIED for HEARTBEAT, which keeps its 1 Hz whoever asks)."""
        stream = self.streams.get(msg_id)
        if stream is None:
            return mavlink.MAV_RESULT_UNSUPPORTED
        if msg_id == mavlink.MAVLINK_MSG_ID_HEARTBEAT:  # (PX4 answers FAILED; DENIED: understood, not allowed)
            return mavlink.MAV_RESULT_DENIED
        if interval_us == 0:
            interval_us = self.default_intervals_us[msg_id]
        elif interval_us < -1:
            return mavlink.MAV_RESULT_DENIED
        stream.interval_us = max(interval_us, MIN_STREAM_INTERVAL_US) if interval_us > 0 else interval_us
        stream.next_due_us = now_us  # first one at the next update
        self.refresh_next_due()
        return mavlink.MAV_RESULT_ACCEPTED

    def report_interval(self, msg_id: float) -> int:
        """MAV_CMD_GET_MESSAGE_INTERVAL (or REQUEST_MESSAGE 244): send MESSAGE_INTERVAL for ``msg_id`` on this
        endpoint, its interval in µs, -1 when off, 0 when the link cannot stream it (MAV_RESULT_UNSUPPORTED)."""
        if not (math.isfinite(msg_id) and 0 <= msg_id <= 0xFFFF):  # MESSAGE_INTERVAL.message_id: uint16
            return mavlink.MAV_RESULT_DENIED
        stream = self.streams.get(int(msg_id))
        interval_us = 0 if stream is None else stream.interval_us if stream.interval_us > 0 else -1
        self.send(mavlink.MAVLink_message_interval_message(int(msg_id), interval_us))
        return mavlink.MAV_RESULT_UNSUPPORTED if stream is None else mavlink.MAV_RESULT_ACCEPTED

    def read_waiting(self, most: int) -> list[tuple[bytes, tuple[str, int]]]:
        """Up to ``most`` queued datagrams with their senders, unparsed (empty when nothing waits)."""
        out: list[tuple[bytes, tuple[str, int]]] = []
        while len(out) < most and (got := self.recv()) is not None:
            out.append(got)
        return out
