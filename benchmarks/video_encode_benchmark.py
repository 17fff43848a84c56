"""Benchmark: what the camera's video out costs a frame, H.264 over RTP and into an MP4 file (sitl/video_stream.py).

Frames: a textured ground with the pad's marker (vision/marker.py) moving a few pixels a frame, greyscale (as the
simulator's camera renders them) or RGB, at the quad_x camera's size (480 x 360, 20 Hz: params/vehicles/quad_x.toml)
and at 640 x 480.  Each row sends --frames frames through one sink as fast as they are encoded, stamped 1/20 s of
simulated time apart: the RTP stream (libx264 ultrafast, tune zerolatency, to UDP 127.0.0.1:--port, where nothing
needs to listen) or the MP4 recorder (ultrafast, into a temporary file, removed after).  It prints per row the wall
milliseconds a frame (mean and 95th percentile: conversion to yuv420p, encoding, packetising and sending or
muxing), the CPU milliseconds a frame of this process (the encoder runs one thread), and the bit rate of what went
out at 20 Hz (kbit/s: RTP datagrams with their headers, or the file's size over its duration).

Usage: ``python benchmarks/video_encode_benchmark.py [--frames 400] [--sizes 480x360 640x480]``
"""

from __future__ import annotations

import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from sitl.video_stream import Mp4Recorder, RtpVideoStream  # noqa: E402
from vision.marker import marker_image  # noqa: E402

from _cli import parser  # noqa: E402
from _progress import Progress  # noqa: E402

RATE_HZ = 20.0
PERIOD_US = 50_000
STREAM_KBIT_S, RECORD_KBIT_S = 1000.0, 2000.0  # the classes' defaults


def frames(width: int, height: int, count: int, rgb: bool):
    """``count`` frames (uint8, grey H x W or RGB H x W x 3): the marker sliding over a textured ground."""
    ground = (96 + 48 * np.sin(np.add.outer(np.arange(height) / 9.0, np.arange(width) / 13.0))).astype(np.uint8)
    marker = marker_image(max(4, height // 30))
    span_x, span_y = width - marker.shape[1], height - marker.shape[0]
    for k in range(count):
        frame = ground.copy()
        x, y = (5 * k) % span_x, (3 * k) % span_y
        frame[y : y + marker.shape[0], x : x + marker.shape[1]] = marker
        yield np.dstack([frame] * 3) if rgb else frame


def measure(sink: str, width: int, height: int, rgb: bool, count: int, port: int, progress: Progress) -> dict:
    """Wall s of each frame's send/add, CPU s of them all, and bits out, for one sink, size and input."""
    with tempfile.TemporaryDirectory() as tmp:
        path = Path(tmp) / "video.mp4"
        out: RtpVideoStream | Mp4Recorder
        if sink == "stream":
            out = RtpVideoStream("127.0.0.1", port, width, height, RATE_HZ, STREAM_KBIT_S)
        else:
            out = Mp4Recorder(path, width, height, RATE_HZ, RECORD_KBIT_S)
        put = out.send if isinstance(out, RtpVideoStream) else out.add
        walls, cpu = [], 0.0
        for k, frame in enumerate(frames(width, height, count, rgb)):
            c0, t0 = time.process_time(), time.perf_counter()
            put(frame, k * PERIOD_US)
            walls.append(time.perf_counter() - t0)
            cpu += time.process_time() - c0
            progress.done()
        c0 = time.process_time()
        out.close()
        cpu += time.process_time() - c0
        bits = 8 * (out.bytes_sent if isinstance(out, RtpVideoStream) else path.stat().st_size)
    return {"walls": np.array(walls), "cpu": cpu, "kbit_s": bits / (count / RATE_HZ) / 1000.0}


def main() -> None:
    ap = parser(__doc__)
    ap.add_argument("--frames", type=int, default=400, help="frames a row")
    ap.add_argument("--sizes", nargs="+", default=["480x360", "640x480"], help="frame sizes, WIDTHxHEIGHT (px)")
    ap.add_argument("--port", type=int, default=5619, help="UDP port the stream sends to on 127.0.0.1")
    args = ap.parse_args()
    try:
        sizes = [tuple(int(v) for v in s.lower().split("x")) for s in args.sizes]
    except ValueError:
        ap.error(f"--sizes {' '.join(args.sizes)}: WIDTHxHEIGHT each, e.g. 480x360")
    rows = [(sink, w, h, rgb) for w, h in sizes for sink in ("stream", "recorder") for rgb in (False, True)]
    progress = Progress(len(rows) * args.frames, "frames")
    results = [(row, measure(*row, args.frames, args.port, progress)) for row in rows]
    progress.close()
    print(
        f"{args.frames} frames a row, {RATE_HZ:g} Hz of simulated time; stream {STREAM_KBIT_S:g} kbit/s target, "
        f"recorder {RECORD_KBIT_S:g} kbit/s"
    )
    print("| sink | size | input | wall ms/frame mean | wall ms/frame p95 | CPU ms/frame | kbit/s out at 20 Hz |")
    print("|---|---|---|---|---|---|---|")
    for (sink, w, h, rgb), r in results:
        walls = 1e3 * r["walls"]
        print(
            f"| {sink} | {w}x{h} | {'RGB' if rgb else 'grey'} | {walls.mean():.2f} | {np.percentile(walls, 95):.2f} | "
            f"{1e3 * r['cpu'] / len(walls):.2f} | {r['kbit_s']:.0f} |"
        )


if __name__ == "__main__":
    main()
