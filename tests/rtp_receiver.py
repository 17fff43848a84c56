"""Receivers of the camera's RTP video for the tests (tests/test_video_stream.py), with nothing timed.

:class:`SdpReceiver` opens the stream's SDP text with FFmpeg's own RTP input (PyAV's ``sdp`` format, as ``ffplay
stream.sdp`` does), an implementation independent of the sender's, and decodes the frames in a thread.  It is
ready once FFmpeg has bound the SDP's port (read from /proc/net/udp, so the test waits on a fact, not a delay);
the stream ends with the sender's RTCP BYE, which FFmpeg turns into the end of its input, and the frames held
in FFmpeg's H.264 parser come out then.  :func:`receive_datagrams` collects the raw datagrams on a plain socket
up to that BYE, for checks of the RTP packets themselves.  Timeouts only guard against a hang: a test fails on
one, never passes because of one.
"""

from __future__ import annotations

import re
import socket
import threading
import time
from dataclasses import dataclass
from pathlib import Path

import av
import numpy as np

RTCP_BYE = 203
GUARD_S = 10.0  # nothing here takes more than a fraction of it; a hung receiver fails the test after it


def sdp_port(sdp: str) -> int:
    """The port of the SDP's ``m=video`` line."""
    found = re.search(r"^m=video (\d+) RTP/AVP ", sdp, re.MULTILINE)
    assert found, f"no m=video line in the SDP:\n{sdp}"
    return int(found.group(1))


def udp_port_bound(port: int) -> bool:
    """True if a UDP socket of this machine (IPv4 or IPv6) is bound to ``port``."""
    for table in ("/proc/net/udp", "/proc/net/udp6"):
        try:
            rows = Path(table).read_text().splitlines()[1:]
        except OSError:
            continue
        if any(int(row.split()[1].rsplit(":", 1)[1], 16) == port for row in rows):
            return True
    return False


class SdpReceiver:
    """The frames of the RTP stream ``sdp`` describes, decoded by FFmpeg in a background thread.

    The SDP is written to ``directory``; the constructor returns once FFmpeg listens on the SDP's port (and the
    RTCP port above it, which FFmpeg binds too).  :meth:`result` waits for the end of the stream and returns the
    decoded frames as (pts on the 90 kHz RTP clock from the first frame's or None, greyscale uint8 image).
    """

    def __init__(self, sdp: str, directory: Path, guard_s: float = GUARD_S) -> None:
        self.port = sdp_port(sdp)
        assert not udp_port_bound(self.port), f"UDP {self.port} is bound already: the test's port is not its own"
        self.path = directory / "stream.sdp"
        self.path.write_text(sdp)
        self.frames: list[tuple[int | None, np.ndarray]] = []
        self.error: BaseException | None = None
        self._thread = threading.Thread(target=self._run, args=(guard_s,), name="sdp-receiver", daemon=True)
        self._thread.start()
        deadline = time.monotonic() + guard_s
        while not udp_port_bound(self.port):
            assert self._thread.is_alive(), f"the receiver stopped before it listened: {self.error!r}"
            assert time.monotonic() < deadline, f"FFmpeg did not bind UDP {self.port} within {guard_s} s"
            time.sleep(0.005)

    def _run(self, guard_s: float) -> None:
        options = {
            "protocol_whitelist": "file,udp,rtp",
            "listen_timeout": str(round(guard_s)),
            "buffer_size": str(4 << 20),  # SO_RCVBUF (up to net.core.rmem_max): a burst waits for the thread
        }
        try:
            with av.open(str(self.path), format="sdp", options=options, timeout=guard_s) as container:
                for frame in container.decode(video=0):
                    self.frames.append((frame.pts, frame.to_ndarray(format="gray")))
        except Exception as exc:  # reported by result()
            self.error = exc

    def result(self, guard_s: float = GUARD_S) -> list[tuple[int | None, np.ndarray]]:
        """The decoded frames, once the stream has ended (its RTCP BYE received); AssertionError if it has not
        within ``guard_s``, the receiver's own exception if it failed."""
        self._thread.join(guard_s)
        assert not self._thread.is_alive(), f"no end of stream within {guard_s} s ({len(self.frames)} frames so far)"
        if self.error is not None:
            raise self.error
        return self.frames


def receive_datagrams(sock: socket.socket, guard_s: float = GUARD_S) -> list[bytes]:
    """Every datagram ``sock`` (bound before the stream started) has received, up to and with the first RTCP
    packet carrying a BYE; AssertionError if none comes within ``guard_s`` of the last datagram."""
    sock.settimeout(guard_s)
    out: list[bytes] = []
    while True:
        try:
            data = sock.recv(65536)
        except TimeoutError:
            raise AssertionError(f"no RTCP BYE after {len(out)} datagrams within {guard_s} s") from None
        out.append(data)
        if has_bye(data):
            return out


def has_bye(data: bytes) -> bool:
    """True if ``data`` is an RTCP compound packet (RFC 3550 6.1) with a BYE in it."""
    at = 0
    while at + 4 <= len(data) and data[at] >> 6 == 2 and 200 <= data[at + 1] <= 204:
        if data[at + 1] == RTCP_BYE:
            return True
        at += 4 * (int.from_bytes(data[at + 2 : at + 4], "big") + 1)
    return False


def h264_access_units(datagrams: list[bytes]) -> list[bytes]:
    """The H.264 access units (Annex B byte streams) that RTP datagrams carry (RFC 6184: single NAL units and
    FU-A fragments; a unit ends at a packet with the marker bit).  Datagrams that are not RTP (RTCP, payload types
    other than 96) are skipped; a fragmented unit missing a piece is dropped whole."""
    units: list[bytes] = []
    current: list[bytes] = []
    fragment: bytearray | None = None
    for d in datagrams:
        if len(d) < 13 or d[0] >> 6 != 2 or d[1] & 0x7F != 96:
            continue
        payload, marker = d[12 + 4 * (d[0] & 0x0F) :], bool(d[1] & 0x80)
        kind = payload[0] & 0x1F
        if kind == 28:  # FU-A: indicator, header, a piece of one NAL unit
            start, end = bool(payload[1] & 0x80), bool(payload[1] & 0x40)
            if start:
                fragment = bytearray([(payload[0] & 0xE0) | (payload[1] & 0x1F)])
            if fragment is not None:
                fragment += payload[2:]
                if end:
                    current.append(b"\x00\x00\x00\x01" + bytes(fragment))
                    fragment = None
        elif 1 <= kind <= 23:
            current.append(b"\x00\x00\x00\x01" + payload)
        if marker and current:
            units.append(b"".join(current))
            current = []
    return units


@dataclass(frozen=True)
class StreamCount:
    """What a receiver of a ``rate_hz`` stream that joined it late got, from the stream's first key frame (an IDR
    slice, NAL type 5) among the datagrams on: ``slots`` frame periods from that frame to the last one that ended
    (its datagram with the marker bit: a receiver may stop in the middle of a frame), by their RTP timestamps
    (90 kHz); ``received`` frames whose datagrams all came (no sequence number missing up to their last);
    ``decodable`` those of them with nothing missing since the key frame they follow (a frame after a loss needs
    the next key frame); ``lost`` datagrams missing by their sequence numbers.  All zero if no key frame came."""

    slots: int = 0
    received: int = 0
    decodable: int = 0
    lost: int = 0


def count_stream(datagrams: list[bytes], rate_hz: float) -> StreamCount:
    """:class:`StreamCount` of ``datagrams`` (in their order of arrival; not RTP payload type 96 ones skipped)."""
    first = last = prev_seq = None
    received = decodable = lost = 0
    intact = key = False  # this frame so far; a key frame in it
    chain = False  # nothing lost since the last key frame
    for d in datagrams:
        if len(d) < 14 or d[0] >> 6 != 2 or d[1] & 0x7F != 96:
            continue
        seq, ts = int.from_bytes(d[2:4], "big"), int.from_bytes(d[4:8], "big")
        payload = d[12 + 4 * (d[0] & 0x0F) :]
        nal = payload[1] & 0x1F if payload[0] & 0x1F == 28 else payload[0] & 0x1F  # FU-A: the fragment's type
        if first is None:
            if nal != 5:
                prev_seq = seq
                continue
            first, intact = ts, prev_seq is not None and seq == (prev_seq + 1) % 2**16  # (its SPS and PPS came)
        elif seq != (prev_seq + 1) % 2**16:
            lost += (seq - prev_seq - 1) % 2**16
            intact = chain = False
        prev_seq = seq
        key = key or nal == 5
        if d[1] & 0x80:  # the frame's last datagram
            last = ts
            if intact:
                received += 1
                chain = chain or key
                decodable += chain
            intact, key = True, False
    if first is None or last is None:
        return StreamCount()
    slots = round(((last - first) % 2**32) / (90_000 / rate_hz)) + 1
    return StreamCount(slots, received, decodable, lost)


def decode_h264(units: list[bytes], pixels: str = "gray") -> list[np.ndarray]:
    """The frames (``pixels``: PyAV's format, "gray" or "rgb24") PyAV's H.264 decoder makes of access units (those
    before the first key frame give nothing: a receiver that joins a stream late waits for its next key frame)."""
    codec = av.CodecContext.create("h264", "r")
    frames: list[np.ndarray] = []
    for unit in units:
        try:
            for packet in codec.parse(unit):
                frames += [f.to_ndarray(format=pixels) for f in codec.decode(packet)]
        except av.error.InvalidDataError:
            continue  # (a unit that refers to a key frame not received)
    try:  # the end: the unit the parser still holds (it waits for the next one's start), then the decoder's
        for packet in codec.parse(None):
            frames += [f.to_ndarray(format=pixels) for f in codec.decode(packet)]
        frames += [f.to_ndarray(format=pixels) for f in codec.decode(None)]
    except av.error.FFmpegError:
        pass
    return frames
