"""The camera's video out: H.264 over RTP to a ground station (:class:`RtpVideoStream`), or into an MP4 file
(:class:`Mp4Recorder`), encoded with PyAV's libx264.

PX4's simulation sends its camera as RTP H.264 to UDP 5600+N, and QGroundControl's default video source ("UDP
h.264 video stream", port 5600) plays it without an SDP file: so the stream is RTP/AVP payload type 96,
H264/90000, packetised as RFC 6184 (packetization-mode 1: single NAL unit packets, FU-A fragments past
:data:`RTP_MAX_PACKET_BYTES`), its SPS and PPS in band before every key frame, a key frame every second of
frames, so a receiver that joins late has a picture within a second.  libx264 runs set for latency (preset
ultrafast, tune zerolatency, no B-frames, yuv420p, one thread): a frame goes out as one access unit as soon as it
is sent.  :attr:`RtpVideoStream.sdp` is the session description other receivers need (``ffplay``, PyAV).

Time is simulated time: a frame's presentation time is its ``time_us`` (the simulator's clock, microseconds) on
the 90 kHz RTP clock, never the wall clock, so a run 20x faster than real time streams frames 20x faster, each
stamped where it belongs, and an MP4 recorded lasts the simulated time it covers.

Frames are ``uint8`` greyscale (height, width), as :mod:`sitl.camera` renders them, or RGB (height, width, 3).
A frame of another size or type is a caller's error: ValueError.  The stream never raises for the network: UDP
does not wait for a receiver, and a send that fails (no route, a full socket buffer) is counted in
:attr:`RtpVideoStream.send_errors`.  The recorder raises :class:`VideoWriteError` (an OSError) when its file cannot
be written (unwritable path, full disk), once, and ignores the frames after it, so a caller can report it and fly
on.
"""

from __future__ import annotations

import base64
import math
import random
import socket
import struct
from collections.abc import Callable
from fractions import Fraction
from pathlib import Path

import av
import cv2
import numpy as np
from av.codec.context import Flags
from av.container import OutputContainer
from av.video.codeccontext import VideoCodecContext

from vision.annotate import annotate
from vision.camera_model import CameraModel
from vision.detector import MarkerDetection

RTP_PAYLOAD_TYPE = 96  # the first dynamic type: what QGroundControl's and PX4's UDP h.264 pipelines use
RTP_CLOCK_HZ = 90_000  # RFC 6184's clock for H.264
RTP_MAX_PACKET_BYTES = 1400  # RTP header included: GStreamer's rtph264pay default, under any link's MTU with IP+UDP
RTP_HEADER_BYTES = 12
FU_A = 28  # RFC 6184 NAL unit type of a fragmentation unit
RTCP_SR, RTCP_BYE = 200, 203
NTP_FRACTION = 2**32
LIMITED_Y = np.round(16.0 + np.arange(256) * 219.0 / 255.0).astype(np.uint8)  # full-range grey -> video-range luma


class VideoWriteError(OSError):
    """The video file cannot be written (its path, a full disk): the OSError's text, the path named."""


def nal_units(annexb: bytes) -> list[bytes]:
    """The NAL units of an H.264 Annex B byte stream, start codes and trailing zero bytes removed."""
    starts = []
    i = annexb.find(b"\0\0\1")
    while i >= 0:
        starts.append(i + 3)
        i = annexb.find(b"\0\0\1", i + 3)
    ends = [s - 3 for s in starts[1:]] + [len(annexb)]
    return [nal for s, e in zip(starts, ends) if (nal := annexb[s:e].rstrip(b"\0"))]


def rtp_payloads(nal: bytes, max_payload_bytes: int) -> list[bytes]:
    """RFC 6184 payloads carrying one NAL unit: the unit itself if it fits, else FU-A fragments (5.8), in order."""
    if len(nal) <= max_payload_bytes:
        return [nal]
    indicator = bytes(((nal[0] & 0xE0) | FU_A,))  # the unit's F and NRI bits, type FU-A
    kind, body, step = nal[0] & 0x1F, nal[1:], max_payload_bytes - 2
    out = []
    for at in range(0, len(body), step):
        header = (0x80 if at == 0 else 0) | (0x40 if at + step >= len(body) else 0) | kind  # S, E bits
        out.append(indicator + bytes((header,)) + body[at : at + step])
    return out


def annotated_rgb(frame: np.ndarray, detection: MarkerDetection | None, camera: CameraModel) -> np.ndarray:
    """An RGB copy of ``frame`` (grey or RGB uint8) with the detection drawn by :func:`vision.annotate.annotate`
    (the pad's markers outlined, its axes, id and distance), ready for :meth:`RtpVideoStream.send`."""
    bgr = frame if frame.ndim == 2 else cv2.cvtColor(frame, cv2.COLOR_RGB2BGR)
    return cv2.cvtColor(annotate(bgr, detection, camera), cv2.COLOR_BGR2RGB)


def _check_settings(width_px: int, height_px: int, rate_hz: float, bit_rate_kbit_s: float) -> None:
    for name, v in (("width_px", width_px), ("height_px", height_px)):
        if int(v) != v or v < 16 or v % 2:
            raise ValueError(f"video {name} {v}: an even number of pixels, 16 or more (yuv420p halves it)")
    if not (math.isfinite(rate_hz) and 0.0 < rate_hz <= 1000.0):
        raise ValueError(f"video rate_hz {rate_hz}: a frame rate above 0, at most 1000 Hz")
    if not (math.isfinite(bit_rate_kbit_s) and bit_rate_kbit_s >= 10.0):
        raise ValueError(f"video bit_rate_kbit_s {bit_rate_kbit_s}: 10 kbit/s or more")


def _encoder_setup(cc: VideoCodecContext, width: int, height: int, rate_hz: float, kbit_s: float, live: bool) -> None:
    """libx264 for the camera: yuv420p, 90 kHz timestamps, no B-frames, a key frame each second of frames, one
    thread; ``live``: tuned for latency, SPS and PPS repeated in band before every key frame."""
    cc.width, cc.height, cc.pix_fmt = width, height, "yuv420p"
    cc.time_base = Fraction(1, RTP_CLOCK_HZ)
    cc.framerate = Fraction(rate_hz).limit_denominator(1001)
    cc.bit_rate = round(kbit_s * 1000.0)
    cc.gop_size = max(1, round(rate_hz))
    cc.max_b_frames = 0
    cc.thread_count = 1  # its cost on the caller's core, none taken from the other processes; one slice a frame
    cc.flags |= Flags.global_header  # SPS and PPS as extradata too: the SDP's sprop-parameter-sets, MP4's avcC
    options = {"preset": "ultrafast", "maxrate": str(cc.bit_rate), "bufsize": str(cc.bit_rate)}
    if live:
        options |= {"tune": "zerolatency", "x264-params": "repeat-headers=1"}
    cc.options = options


def _yuv_frame(frame: np.ndarray, width: int, height: int) -> av.VideoFrame:
    """``frame`` checked (ValueError naming what is wrong) and converted to a yuv420p VideoFrame."""
    if not isinstance(frame, np.ndarray) or frame.dtype != np.uint8:
        kind = frame.dtype if isinstance(frame, np.ndarray) else type(frame).__name__
        raise ValueError(f"video frame of {kind}: uint8 greyscale (H x W) or RGB (H x W x 3) expected")
    if frame.shape not in ((height, width), (height, width, 3)):
        raise ValueError(f"video frame {frame.shape}: ({height}, {width}) grey or ({height}, {width}, 3) RGB expected")
    if frame.ndim == 3:  # BT.601 video range, as swscale converts it (luma within one level), ten times faster
        return av.VideoFrame.from_ndarray(np.asarray(cv2.cvtColor(frame, cv2.COLOR_RGB2YUV_I420), np.uint8), "yuv420p")
    planes = np.empty((height * 3 // 2, width), np.uint8)
    np.take(LIMITED_Y, frame, out=planes[:height])  # the same luma; chroma neutral
    planes[height:] = 128
    return av.VideoFrame.from_ndarray(planes, format="yuv420p")


def _ticks(time_us: int, last: int | None) -> int:
    """``time_us`` (simulated µs) on the 90 kHz clock; ValueError unless after ``last``."""
    ticks = (int(time_us) * 9 + 50) // 100
    if last is not None and ticks <= last:
        raise ValueError(f"video frame at {time_us} us is not after the last one: 1/90000 s apart at least, in order")
    return ticks


class RtpVideoStream:
    """The camera's frames as RTP H.264 to ``host``:``port`` (UDP), as PX4's simulation sends them to QGroundControl.

    ``width_px`` x ``height_px``: the frames' size; ``rate_hz``: their nominal rate (the key frame interval is one
    second of it); ``bit_rate_kbit_s``: the encoder's target (and VBV ceiling).  :meth:`send` encodes a frame and
    sends it at once (``max_packet_bytes``: the largest datagram, RTP header included); :meth:`close` ends the stream
    with an RTCP BYE on the same port if ``rtcp_bye`` (RFC 5761 multiplexing, announced by the SDP's ``a=rtcp-mux``:
    FFmpeg ends its input there; GStreamer's plain udpsrc pipeline, QGroundControl's, drops it with one warning) and
    closes the socket.  Counters: ``frames_sent`` (frames encoded and handed to the socket), ``packets_sent`` and
    ``bytes_sent`` (RTP datagrams sent, headers included), ``send_errors`` (datagrams the socket refused, the last
    one's text in ``last_send_error``).
    """

    def __init__(
        self,
        host: str,
        port: int,
        width_px: int,
        height_px: int,
        rate_hz: float = 20.0,
        bit_rate_kbit_s: float = 1000.0,
        max_packet_bytes: int = RTP_MAX_PACKET_BYTES,
        rtcp_bye: bool = True,
    ) -> None:
        _check_settings(width_px, height_px, rate_hz, bit_rate_kbit_s)
        if not 0 < port < 65536:
            raise ValueError(f"video port {port}: 1-65535")
        if not 64 <= max_packet_bytes <= 65000:
            raise ValueError(f"video max_packet_bytes {max_packet_bytes}: 64-65000")
        try:
            family, _, _, _, dest = socket.getaddrinfo(host, port, type=socket.SOCK_DGRAM)[0]
        except OSError as exc:
            raise ValueError(f"video host {host!r}: {exc}") from None
        self.width_px, self.height_px, self.rate_hz = int(width_px), int(height_px), float(rate_hz)
        self.dest: tuple[str, int] = (str(dest[0]), int(dest[1]))
        self.max_packet_bytes, self.rtcp_bye = max_packet_bytes, rtcp_bye
        self._encoder = VideoCodecContext.create("libx264", "w")
        _encoder_setup(self._encoder, self.width_px, self.height_px, rate_hz, bit_rate_kbit_s, live=True)
        self._encoder.open()
        self._parameter_sets = nal_units(self._encoder.extradata or b"")
        draw = random.SystemRandom().getrandbits  # RFC 3550: random SSRC, first sequence number and timestamp
        self.ssrc, self._seq, self._ts0 = draw(32), draw(16), draw(32)
        self._family = family
        self._sock = socket.socket(family, socket.SOCK_DGRAM)
        self._sock.setblocking(False)  # a full buffer drops the datagram (counted) rather than wait
        self._last_ticks: int | None = None
        self._closed = False
        self.frames_sent = self.packets_sent = self.bytes_sent = self.send_errors = 0
        self.last_send_error = ""

    @property
    def sdp(self) -> str:
        """The session description of the stream (RFC 4566), for receivers that want one: ffplay, PyAV's ``sdp``
        format (its ``protocol_whitelist`` must allow file,udp,rtp).  QGroundControl and GStreamer pipelines need
        none: the parameter sets come in band."""
        ip4 = self._family == socket.AF_INET
        addr = f"IN {'IP4' if ip4 else 'IP6'} {self.dest[0]}"
        fmtp = "packetization-mode=1"
        sps = [n for n in self._parameter_sets if n[0] & 0x1F == 7]
        if sps:
            fmtp += f";profile-level-id={sps[0][1:4].hex()}"
        if self._parameter_sets:
            fmtp += ";sprop-parameter-sets=" + ",".join(base64.b64encode(n).decode() for n in self._parameter_sets)
        lines = (
            "v=0",
            f"o=- {self.ssrc} 1 {addr}",
            "s=mavsim camera",
            f"c={addr}",
            "t=0 0",
            f"m=video {self.dest[1]} RTP/AVP {RTP_PAYLOAD_TYPE}",
            f"a=rtpmap:{RTP_PAYLOAD_TYPE} H264/{RTP_CLOCK_HZ}",
            f"a=fmtp:{RTP_PAYLOAD_TYPE} {fmtp}",
            f"a=framerate:{self.rate_hz:g}",
            "a=rtcp-mux",
        )
        return "\r\n".join(lines) + "\r\n"

    def send(self, frame: np.ndarray, time_us: int) -> None:
        """Encode ``frame`` (uint8 grey H x W or RGB H x W x 3), stamped ``time_us`` (simulated µs, increasing),
        and send it.  ValueError for a frame of another size or type, or a time not after the last frame's."""
        if self._closed:
            raise ValueError("video stream closed")
        video = _yuv_frame(frame, self.width_px, self.height_px)
        video.pts = self._last_ticks = _ticks(time_us, self._last_ticks)
        for packet in self._encoder.encode(video):
            self._send_access_unit(bytes(packet), packet.pts or 0)

    def close(self) -> None:
        """Flush the encoder, send what it held, end the stream with an RTCP BYE and close the socket (idempotent)."""
        if self._closed:
            return
        self._closed = True
        try:
            for packet in self._encoder.encode(None):
                self._send_access_unit(bytes(packet), packet.pts or 0)
            if self.rtcp_bye and self._last_ticks is not None:
                self._send_datagram(self._sender_report() + self._bye())
        finally:
            self._sock.close()

    def __enter__(self) -> RtpVideoStream:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _send_access_unit(self, annexb: bytes, ticks: int) -> None:
        """One encoded frame as RTP packets, all with its timestamp, the marker bit on its last one."""
        payloads = [p for nal in nal_units(annexb) for p in rtp_payloads(nal, self.max_packet_bytes - RTP_HEADER_BYTES)]
        stamp = (self._ts0 + ticks) & 0xFFFFFFFF
        for k, payload in enumerate(payloads):
            marker = 0x80 if k == len(payloads) - 1 else 0
            header = struct.pack("!BBHII", 0x80, marker | RTP_PAYLOAD_TYPE, self._seq, stamp, self.ssrc)
            self._seq = (self._seq + 1) & 0xFFFF
            if self._send_datagram(header + payload):
                self.packets_sent += 1
                self.bytes_sent += RTP_HEADER_BYTES + len(payload)
        self.frames_sent += 1

    def _send_datagram(self, data: bytes) -> bool:
        try:
            self._sock.sendto(data, self.dest)
        except OSError as exc:  # no route, a refused broadcast, a full buffer: the simulator flies on
            self.send_errors += 1
            self.last_send_error = str(exc)
            return False
        return True

    def _sender_report(self) -> bytes:
        """RTCP SR (RFC 3550 6.4.1) of the last frame: its simulated time as the NTP time, packets and payload
        octets sent."""
        seconds = (self._last_ticks or 0) / RTP_CLOCK_HZ
        ntp = (int(seconds) & 0xFFFFFFFF, int((seconds % 1.0) * NTP_FRACTION) & 0xFFFFFFFF)
        stamp = (self._ts0 + (self._last_ticks or 0)) & 0xFFFFFFFF
        octets = (self.bytes_sent - RTP_HEADER_BYTES * self.packets_sent) & 0xFFFFFFFF
        return struct.pack("!BBHIIIIII", 0x80, RTCP_SR, 6, self.ssrc, *ntp, stamp, self.packets_sent, octets)

    def _bye(self) -> bytes:
        return struct.pack("!BBHI", 0x81, RTCP_BYE, 1, self.ssrc)


class Mp4Recorder:
    """The camera's frames into an MP4 file (H.264 yuv420p), stamped with simulated time.

    ``path``: the file (replaced if it exists); ``width_px`` x ``height_px``, ``rate_hz``, ``bit_rate_kbit_s`` as
    :class:`RtpVideoStream`'s.  The first frame is at 0 s in the file, each next one at its ``time_us`` after the
    first's, the last one lasts one frame period (1/``rate_hz``): the file lasts the simulated time recorded.
    :class:`VideoWriteError` from the constructor, :meth:`add` or :meth:`close` when the file cannot be written;
    after one, :meth:`add` does nothing and :meth:`close` only releases (``error`` keeps it).
    """

    def __init__(
        self, path: str | Path, width_px: int, height_px: int, rate_hz: float = 20.0, bit_rate_kbit_s: float = 2000.0
    ) -> None:
        _check_settings(width_px, height_px, rate_hz, bit_rate_kbit_s)
        self.path = Path(path)
        self.width_px, self.height_px, self.rate_hz = int(width_px), int(height_px), float(rate_hz)
        self._period_ticks = round(RTP_CLOCK_HZ / rate_hz)
        self.frames = 0
        self.error: VideoWriteError | None = None
        self._first_ticks: int | None = None
        self._last_ticks: int | None = None
        self._closed = self._open = False
        self._container: OutputContainer

        def open_file() -> None:
            self._container = av.open(str(self.path), "w", format="mp4")
            self._open = True
            self._stream = self._container.add_stream("libx264", rate=Fraction(rate_hz).limit_denominator(1001))
            _encoder_setup(self._stream.codec_context, self.width_px, self.height_px, rate_hz, bit_rate_kbit_s, False)
            self._stream.time_base = Fraction(1, RTP_CLOCK_HZ)
            self._container.start_encoding()  # opens the file and writes the header: a bad path fails here

        self._guarded(open_file)

    def add(self, frame: np.ndarray, time_us: int) -> None:
        """Encode ``frame`` (uint8 grey H x W or RGB H x W x 3) at ``time_us`` (simulated µs, increasing) into the
        file.  ValueError for a frame of another size or type or a time not after the last frame's;
        VideoWriteError if the file cannot be written (then, and once closed, it does nothing)."""
        if self.error is not None or self._closed:
            return
        video = _yuv_frame(frame, self.width_px, self.height_px)
        ticks = _ticks(time_us, self._last_ticks)
        first = ticks if self._first_ticks is None else self._first_ticks
        video.pts = ticks - first
        self._write(video)
        self._first_ticks, self._last_ticks = first, ticks
        self.frames += 1

    def close(self) -> tuple[int, float]:
        """Flush the encoder, finish the file, release it: (frames added, duration s), the frames before a failure
        if there was one.  VideoWriteError if the end of the file cannot be written; after an earlier one, it only
        releases (idempotent)."""
        if not self._closed:
            self._closed = True
            if self.error is None:
                self._write(None)
                self._guarded(self._container.close)  # the trailer (the MP4's index) written here
            self._release()
        return self.frames, self.duration_s

    @property
    def duration_s(self) -> float:
        """The simulated time the frames added so far cover: the last one's time after the first's, plus a period."""
        if self._first_ticks is None or self._last_ticks is None:
            return 0.0
        return (self._last_ticks - self._first_ticks + self._period_ticks) / RTP_CLOCK_HZ

    def __enter__(self) -> Mp4Recorder:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def _write(self, video: av.VideoFrame | None) -> None:
        """Encode ``video`` (None: flush the encoder) and mux what comes out."""

        def write() -> None:
            for packet in self._stream.encode(video):
                packet.duration = self._period_ticks  # the last frame's length in the file; the others' follow
                self._container.mux(packet)

        self._guarded(write)

    def _guarded(self, action: Callable[[], object]) -> None:
        """``action()``; an OSError from it (PyAV's errors of the file are OSErrors) becomes the recorder's
        VideoWriteError, raised once, the file released."""
        try:
            action()
        except OSError as exc:
            error = self.error = VideoWriteError(f"video file {self.path}: {exc.strerror or exc}")
            error.errno = exc.errno
            self._release()
            raise error from None

    def _release(self) -> None:
        if self._open:
            self._open = False
            try:
                self._container.close()
            except OSError:
                pass  # the file is already lost; the first error is the one reported
