"""One UDP socket of a MAVLink component, as PX4's UDP links behave.

Shared by the flight controller's ground-station link (:mod:`autopilot.mavlink.link`) and the
simulator's ``SIM_*`` parameter service (:mod:`sitl.param_server`):

* bound, non-blocking; a port already in use is an ``OSError`` that names it;
* everything sent goes to a default destination and to the MAX_PEERS most recent
  senders, so replies reach clients on any port; a failed send is counted
  (``tx_errors``), never raised: telemetry is best effort;
* a datagram holds whole MAVLink packets, so bytes left over at its end are damage:
  they are reported and dropped instead of being glued to the next datagram; our own
  packets looped back are ignored.
"""

from __future__ import annotations

import socket

from pymavlink.dialects.v20 import common as mavlink

Address = tuple[str, int]
MAX_PEERS = 4  # remembered reply addresses, besides the default destination
RX_BUFFER_BYTES = 65536


class UdpEndpoint:
    def __init__(self, name: str, bind: Address, default_dest: Address, sysid: int, compid: int) -> None:
        self.name = name
        self.sysid, self.compid = sysid, compid
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        try:
            self.sock.bind(bind)
        except OSError as e:
            self.sock.close()
            raise OSError(e.errno, f"{name}: cannot bind UDP {bind[0]}:{bind[1]}: {e.strerror}") from e
        self.sock.setblocking(False)
        self.default_dest = default_dest
        self.peers: list[Address] = []  # most recent last
        self.destinations: list[Address] = [default_dest]
        self._parser = self._new_parser()
        self._rx_buf = bytearray(RX_BUFFER_BYTES)
        self.tx_errors = 0

    def _new_parser(self) -> mavlink.MAVLink:
        p = mavlink.MAVLink(None, self.sysid, self.compid)
        p.robust_parsing = True  # bad bytes come back as BAD_DATA instead of raising
        return p

    @property
    def local_address(self) -> Address:
        """(host, port) the socket is bound to."""
        return self.sock.getsockname()

    # -- sending
    def send_datagram(self, data: bytes) -> None:
        """One datagram to every destination (best effort: failures are counted in ``tx_errors``)."""
        sendto = self.sock.sendto
        for addr in self.destinations:
            try:
                sendto(data, addr)
            except OSError:  # nobody listening, buffer full, network down
                self.tx_errors += 1

    def note_peer(self, addr: Address) -> None:
        """Remember a sender as a destination (keeping the MAX_PEERS most recent)."""
        if self.peers and self.peers[-1] == addr:
            return
        if addr in self.peers:
            self.peers.remove(addr)
        self.peers.append(addr)
        del self.peers[:-MAX_PEERS]
        self.destinations = [self.default_dest] + [a for a in self.peers if a != self.default_dest]

    # -- receiving
    def recv(self) -> tuple[bytes, Address] | None:
        """One datagram, or None when nothing is waiting."""
        while True:
            try:
                n, addr = self.sock.recvfrom_into(self._rx_buf)
            except (BlockingIOError, InterruptedError):
                return None
            except ConnectionError:  # ICMP error reported by some OSes for an earlier send: try the next
                continue
            except OSError:
                return None
            return bytes(memoryview(self._rx_buf)[:n]), addr

    def incoming(self, data: bytes, addr: Address) -> tuple[list[mavlink.MAVLink_message], int]:
        """The good messages of one datagram from other components, and how many pieces were damaged.

        A sender of any good message becomes a destination (:meth:`note_peer`)."""
        p = self._parser
        try:
            msgs = p.parse_buffer(data) or []
        except Exception:  # robust parsing should not raise; a datagram must never stop the process
            self._parser = self._new_parser()
            return [], 1
        if p.buf_len() > 0:  # the end of the datagram is a packet cut short
            msgs.append(mavlink.MAVLink_bad_data(p.buf[p.buf_index :], "truncated packet"))
            self._parser = self._new_parser()
        good, bad = [], 0
        for msg in msgs:
            if msg.get_type() == "BAD_DATA":
                bad += 1
            elif msg.get_srcSystem() != self.sysid or msg.get_srcComponent() != self.compid:
                good.append(msg)  # (our own packets looped back are dropped)
        if good:
            self.note_peer(addr)
        return good, bad

    def close(self) -> None:
        self.sock.close()
