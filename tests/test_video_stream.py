"""The camera's video out (sitl/video_stream.py): RTP H.264 that FFmpeg decodes with the marker still found in it,
RTP packets as RFC 6184 and QGroundControl want them, an MP4 file that lasts the simulated time, and the errors.

Frames are drawn here (the pad's ArUco marker on a textured ground, moving a few pixels a frame) at the quad_x
camera's size and rate; nothing is rendered or flown.  Frames are sent as fast as the loop goes, far faster than
their 20 Hz of simulated time, so timestamps that follow the simulated time cannot come from the wall clock.
Ports: 5600+N (PX4's video port scheme) for a leased instance N whose N+1 is leased too, as FFmpeg's RTP input
binds the RTCP port 5601+N as well (tests/rtp_receiver.py).
"""

from __future__ import annotations

import base64
import errno
import json
import math
import re
import socket
import struct
import subprocess
import sys
from pathlib import Path

import av
import numpy as np
import pytest

from sitl.video_stream import Mp4Recorder, RtpVideoStream, VideoWriteError, annotated_rgb
from vision.camera_model import pinhole
from vision.detector import MarkerDetector
from vision.marker import MARKER_ID, marker_image

from rtp_receiver import (
    SdpReceiver,
    StreamCount,
    count_stream,
    decode_h264,
    h264_access_units,
    has_bye,
    receive_datagrams,
)

ROOT = Path(__file__).resolve().parents[1]
W, H, RATE_HZ = 480, 360, 20.0  # params/vehicles/quad_x.toml [camera]
PERIOD_US = 50_000
TICKS = 4500  # one frame period on the 90 kHz RTP clock
VIDEO_PORT_BASE = 5600  # PX4's simulation: instance N's video to UDP 5600+N
BITS_PX = 12  # marker bit side in the drawn frames: 84 px black square, 12 px white quiet zone
GROUND = (96 + 48 * np.sin(np.add.outer(np.arange(H) / 9.0, np.arange(W) / 13.0))).astype(np.uint8)
CAMERA = pinhole(W, H, math.radians(90.0))


def scene(k: int) -> tuple[np.ndarray, tuple[int, int]]:
    """Frame ``k`` (grey uint8 H x W) and the top-left corner (x, y px) of the marker's black square in it."""
    frame = GROUND.copy()
    marker = marker_image(BITS_PX)
    x, y = 40 + 5 * k, 60 + 3 * k
    frame[y : y + marker.shape[0], x : x + marker.shape[1]] = marker
    return frame, (x + BITS_PX, y + BITS_PX)


def assert_marker_at(frame: np.ndarray, corner: tuple[int, int]) -> None:
    found = MarkerDetector(CAMERA).detect(frame)
    assert found is not None and found.marker_id == MARKER_ID
    top_left = found.corners_px[0] + 0.5  # OpenCV: pixel centres at integers, so the square's edge is at -0.5
    assert np.abs(top_left - corner).max() < 1.5, (top_left, corner)


@pytest.fixture(scope="module")
def video_port(free_instance) -> int:
    """5600+N for a leased instance N whose N+1 is leased too (FFmpeg's RTCP port 5601+N is N+1's video port)."""
    held: set[int] = set()
    while True:  # the lowest free numbers: most often the first two
        held.add(free_instance())
        pairs = sorted(m for m in held if m + 1 in held)
        if pairs:
            return VIDEO_PORT_BASE + pairs[0]


def test_marker_frames_streamed_over_rtp_decode_with_ffmpeg_stamped_with_simulated_time(video_port, tmp_path):
    n, start_us = 30, 12_500_000
    stream = RtpVideoStream("127.0.0.1", video_port, W, H, RATE_HZ, bit_rate_kbit_s=1000.0)
    receiver = SdpReceiver(stream.sdp, tmp_path)  # FFmpeg listens before the first frame goes
    corners = []
    for k in range(n):
        grey, corner = scene(k)
        stream.send(grey if k % 2 else np.dstack([grey] * 3), start_us + k * PERIOD_US)  # grey and RGB alike
        corners.append(corner)
    stream.close()
    frames = receiver.result()
    assert (stream.frames_sent, stream.send_errors) == (n, 0)
    assert len(frames) == n
    # FFmpeg's RTP input stamps frames from the first RTP timestamp (it leaves the first frame's pts unset).
    assert [pts for pts, _ in frames[1:]] == [k * TICKS for k in range(1, n)]
    for (_, image), corner in zip(frames, corners):
        assert_marker_at(image, corner)


def rtp_frames(datagrams: list[bytes], ssrc: int, max_bytes: int) -> list[tuple[int, list[bytes]]]:
    """(RTP timestamp, NAL units) of each frame the datagrams carry (a frame ends at a marker bit), FU-A fragments
    joined, the header of every packet checked: version 2, type 96, the stream's SSRC, sequence numbers in a row."""
    frames, units, fragment, stamps = [], [], None, []
    seq0 = struct.unpack("!H", datagrams[0][2:4])[0]
    for k, data in enumerate(datagrams):
        first, second, seq, stamp, source = struct.unpack("!BBHII", data[:12])
        assert (first, second & 0x7F, source, seq) == (0x80, 96, ssrc, (seq0 + k) & 0xFFFF)
        assert len(data) <= max_bytes
        payload = data[12:]
        if payload[0] & 0x1F == 28:  # FU-A: indicator, header (S, E, type), a piece of the unit
            start, end, kind = payload[1] & 0x80, payload[1] & 0x40, payload[1] & 0x1F
            assert (fragment is None) == bool(start), "a fragment out of order"
            fragment = (fragment or bytes(((payload[0] & 0xE0) | kind,))) + payload[2:]
            if end:
                units.append(fragment)
                fragment = None
        else:
            assert fragment is None
            units.append(payload)
        stamps.append(stamp)
        if second & 0x80:  # the marker: the frame's last packet
            assert len(set(stamps)) == 1, "one timestamp a frame"
            frames.append((stamp, units))
            units, stamps = [], []
    assert not units and fragment is None, "a frame without its marker bit"
    return frames


def streamed(port: int, n: int, max_bytes: int) -> tuple[RtpVideoStream, list[bytes]]:
    """The closed stream and every datagram it sent (the last one its RTCP BYE) for ``n`` frames of :func:`scene`,
    one period apart, in packets of at most ``max_bytes``."""
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4 << 20)  # a key frame's burst, with room to spare
        sock.bind(("127.0.0.1", port))  # bound before the stream starts: every datagram is queued
        stream = RtpVideoStream("127.0.0.1", port, W, H, RATE_HZ, 1000.0, max_packet_bytes=max_bytes)
        datagrams = []
        for k in range(n):
            stream.send(scene(k)[0], 3_000_000 + k * PERIOD_US)
            sock.setblocking(False)  # take what is queued before the next frame, so no burst overflows the buffer
            while True:
                try:
                    datagrams.append(sock.recv(65536))
                except BlockingIOError:
                    break
        stream.close()
        sock.setblocking(True)
        datagrams += receive_datagrams(sock)
    return stream, datagrams


def test_rtp_packets_carry_simulated_time_and_the_parameter_sets_before_every_key_frame(video_port):
    n, max_bytes = 45, 600  # 2.25 s of frames: key frames 0, 20 and 40; small packets, so key frames fragment
    stream, datagrams = streamed(video_port, n, max_bytes)
    sdp = stream.sdp
    assert has_bye(datagrams[-1]) and struct.unpack("!I", datagrams[-1][4:8])[0] == stream.ssrc  # SR + BYE
    frames = rtp_frames(datagrams[:-1], stream.ssrc, max_bytes)
    assert len(frames) == n
    stamps = [stamp for stamp, _ in frames]
    assert [(b - a) & 0xFFFFFFFF for a, b in zip(stamps, stamps[1:])] == [TICKS] * (n - 1)
    kinds = [[unit[0] & 0x1F for unit in units] for _, units in frames]
    keys = [k for k, types in enumerate(kinds) if 5 in types]
    assert keys == [0, 20, 40]  # one a second of frames
    sprop = re.search(r"sprop-parameter-sets=([^;\r\n]+)", sdp).group(1)
    parameter_sets = [base64.b64decode(p) for p in sprop.split(",")]
    for k, (_, units) in enumerate(frames):
        sets = [u for u in units if u[0] & 0x1F in (7, 8)]
        assert sets == (parameter_sets if k in keys else []), k  # SPS, PPS in band, as the SDP gives them
        if k in keys:  # before the key frame's slices (the first frame has x264's SEI too)
            assert kinds[k].index(7) < kinds[k].index(8) < kinds[k].index(5)
    assert any(d[12] & 0x1F == 28 for d in datagrams[:-1]), "no unit was fragmented: FU-A untested"
    assert stream.bytes_sent == sum(len(d) for d in datagrams[:-1])


def test_a_late_receiver_counts_what_came_what_was_lost_and_what_decodes(video_port):
    """tests/rtp_receiver.py's count_stream, which test_e2e_camera.py's stream test asserts with: a receiver that
    joined at frame 5 of 45 (key frames 0, 20, 40) counts from frame 20; a datagram lost in frame 25 spoils it and
    the frames after it up to the next key frame; a sender that skipped every other frame shows in the counts."""
    stream, datagrams = streamed(video_port, 45, 600)
    frames = rtp_frames(datagrams[:-1], stream.ssrc, 600)
    stamps = [stamp for stamp, _ in frames]
    by_frame = [[d for d in datagrams[:-1] if struct.unpack("!I", d[4:8])[0] == stamp] for stamp in stamps]
    assert len(by_frame) == 45 and sum(map(len, by_frame)) == len(datagrams) - 1
    late = [d for frame in by_frame[5:] for d in frame]
    assert count_stream(late, RATE_HZ) == StreamCount(slots=25, received=25, decodable=25, lost=0)
    assert len(decode_h264(h264_access_units(late))) in (24, 25)  # from the key frame on (the last may be held)

    lossy = late[:]
    lossy.remove(by_frame[25][0])  # one datagram of frame 25
    assert count_stream(lossy, RATE_HZ) == StreamCount(slots=25, received=24, decodable=10, lost=1)  # 20-24, 40-44

    skipping = [d for k, frame in enumerate(by_frame[20:]) if k % 2 == 0 for d in frame]  # frames 20, 22, ... 44
    renumbered = [d[:2] + struct.pack("!H", k) + d[4:] for k, d in enumerate(skipping)]  # no sequence gap
    count = count_stream(renumbered, RATE_HZ)
    assert (count.lost, count.received, count.slots) == (0, 13, 25)  # what the camera test calls a skipping stream


def test_a_send_the_network_refuses_is_counted_never_raised(video_port):
    # A broadcast from a socket without SO_BROADCAST: every sendto fails (EACCES) and nothing leaves the machine.
    with RtpVideoStream("255.255.255.255", video_port, W, H, RATE_HZ) as refused:
        for k in range(3):
            refused.send(scene(k)[0], k * PERIOD_US)
    assert (refused.frames_sent, refused.packets_sent) == (3, 0)
    assert refused.send_errors >= 4 and refused.last_send_error  # each frame's packets and the closing BYE
    with RtpVideoStream("127.0.0.1", video_port, W, H, RATE_HZ) as unheard:  # nobody bound: UDP does not care
        unheard.send(scene(0)[0], 0)
    assert unheard.send_errors == 0 and unheard.packets_sent > 0


BAD_FRAMES = {
    "transposed": np.zeros((W, H), np.uint8),
    "narrower": np.zeros((H, W - 2), np.uint8),
    "four channels": np.zeros((H, W, 4), np.uint8),
    "float": np.zeros((H, W), np.float32),
    "uint16": np.zeros((H, W), np.uint16),
    "a list": [[0] * W] * H,
}


@pytest.mark.parametrize("name", BAD_FRAMES)
def test_a_frame_of_the_wrong_size_or_type_is_a_value_error_and_the_next_good_one_goes(name, video_port, tmp_path):
    good = scene(0)[0]
    with RtpVideoStream("127.0.0.1", video_port, W, H) as stream, Mp4Recorder(tmp_path / "v.mp4", W, H) as recorder:
        for put in (stream.send, recorder.add):
            with pytest.raises(ValueError, match="video frame"):
                put(BAD_FRAMES[name], 0)
            put(good, 0)
            with pytest.raises(ValueError, match="not after the last one"):
                put(good, 0)  # simulated time must move on
    assert (stream.frames_sent, recorder.frames) == (1, 1)


@pytest.mark.parametrize("settings", [(W + 1, H, 20.0, 1000.0), (W, 0, 20.0, 1000.0), (W, H, 0.0, 1000.0)])
def test_impossible_settings_are_value_errors(settings, video_port, tmp_path):
    with pytest.raises(ValueError, match="video"):
        RtpVideoStream("127.0.0.1", video_port, *settings)
    with pytest.raises(ValueError, match="video"):
        Mp4Recorder(tmp_path / "v.mp4", *settings)


def test_the_mp4_file_has_every_frame_and_lasts_the_simulated_time(tmp_path):
    n, start_us, path = 30, 7_300_000, tmp_path / "flight.mp4"
    corners = []
    with Mp4Recorder(path, W, H, RATE_HZ) as recorder:
        for k in range(n):
            grey, corner = scene(k)
            recorder.add(np.dstack([grey] * 3), start_us + k * PERIOD_US)
            corners.append(corner)
    assert recorder.close() == (n, n / RATE_HZ)
    with av.open(str(path)) as container:
        stream = container.streams.video[0]
        assert (stream.codec_context.name, stream.codec_context.format.name) == ("h264", "yuv420p")
        assert abs(container.duration / 1e6 - n / RATE_HZ) < 0.5 / RATE_HZ
        frames = list(container.decode(stream))
    assert len(frames) == n
    assert [round(f.time * RATE_HZ) for f in frames] == list(range(n))  # from 0 s, at their simulated times
    for k in (0, n // 2, n - 1):
        assert_marker_at(frames[k].to_ndarray(format="gray"), corners[k])


def test_rgb_frames_keep_their_colours(tmp_path):
    frame = np.zeros((H, W, 3), np.uint8)
    frame[:, : W // 2] = (220, 30, 30)  # red, then blue: a swapped channel order shows
    frame[:, W // 2 :] = (30, 30, 220)
    with Mp4Recorder(tmp_path / "colours.mp4", W, H) as recorder:
        recorder.add(frame, 0)
    with av.open(str(tmp_path / "colours.mp4")) as container:
        [decoded] = [f.to_ndarray(format="rgb24") for f in container.decode(video=0)]
    assert np.abs(decoded[:, 8 : W // 2 - 8].astype(int) - (220, 30, 30)).max() <= 6
    assert np.abs(decoded[:, W // 2 + 8 : -8].astype(int) - (30, 30, 220)).max() <= 6


def test_an_unwritable_video_path_raises_the_video_write_error(tmp_path):
    (tmp_path / "a-file").write_text("")
    path = tmp_path / "a-file" / "flight.mp4"  # its parent is a regular file: unwritable, even for root
    with pytest.raises(VideoWriteError, match=re.escape(str(path))) as raised:
        Mp4Recorder(path, W, H)
    assert isinstance(raised.value, OSError) and raised.value.errno == errno.ENOTDIR
    if Path("/dev/full").exists():  # a full disk: the file's header cannot be written
        with pytest.raises(VideoWriteError, match="No space left"):
            Mp4Recorder("/dev/full", W, H)


# Run in its own process: the file-size limit (RLIMIT_FSIZE) holds for every file of the process.
FILE_TOO_LARGE = r"""
import json, resource, signal, sys
import numpy as np
from sitl.video_stream import Mp4Recorder, VideoWriteError
signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # a write past the limit fails with EFBIG instead of killing
resource.setrlimit(resource.RLIMIT_FSIZE, (100_000, resource.RLIM_INFINITY))
recorder = Mp4Recorder(sys.argv[1], 480, 360, 20.0, 2000.0)
noise = np.random.default_rng(0)
raised = []
for k in range(60):
    try:
        recorder.add(noise.integers(0, 256, (360, 480), dtype=np.uint8), k * 50_000)
    except VideoWriteError as exc:
        raised.append([k, str(exc)])
print(json.dumps({"raised": raised, "closed": recorder.close()}))
"""


def test_a_write_failing_mid_recording_raises_once_then_the_frames_after_it_are_ignored(tmp_path):
    path = tmp_path / "flight.mp4"
    done = subprocess.run(
        [sys.executable, "-c", FILE_TOO_LARGE, str(path)], cwd=ROOT, capture_output=True, text=True, timeout=60
    )
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout)
    [[k, text]] = out["raised"]  # once, at the frame whose write failed; the 60 - k - 1 after it did nothing
    assert 0 < k < 59 and text == f"video file {path}: File too large"
    assert out["closed"] == [k, k / RATE_HZ]  # close() after the failure: no second error, the frames before it


def test_annotated_frames_are_rgb_with_the_detection_drawn(video_port):
    grey, corner = scene(3)
    found = MarkerDetector(CAMERA).detect(grey)
    image = annotated_rgb(grey, found, CAMERA)
    assert image.shape == (H, W, 3) and image.dtype == np.uint8
    assert (image == (0, 255, 0)).all(axis=2).sum() > 200  # the marker's green outline
    assert (image == (255, 0, 0)).all(axis=2).any()  # the label, red (annotate draws BGR; the stream takes RGB)
    with RtpVideoStream("127.0.0.1", video_port, W, H) as stream:
        stream.send(image, 0)
    assert stream.send_errors == 0
