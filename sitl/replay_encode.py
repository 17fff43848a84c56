"""Video files from RGB frames with PyAV: MP4 (H.264, yuv420p) and animated WebP.

A :class:`FrameWriter` takes frames (height x width x 3 uint8 RGB, all of one size) in order, the k-th shown from
k / fps seconds on (frame k's presentation time is exactly k / fps: its ``pts`` is k in a time base of 1 / fps), so
N frames last N / fps seconds.  H.264 in yuv420p is what every player and browser plays; its width and height must
be even.  The animated WebP loops forever (a README preview).
"""

from __future__ import annotations

from fractions import Fraction
from pathlib import Path

import av
import numpy as np

MP4_CRF = 23  # x264's default quality
MP4_PRESET = "veryfast"  # 2-3 ms a 640x360 frame here; slower presets save bytes, not quality worth the time
# libwebp's 0-100 (lossy).  Its animation encoder keeps a block of the previous frame wherever the new one is "close
# enough", a closeness that loosens as the quality drops: below ~80 the moving checkered ground leaves visible stale
# blocks.  85: a 12 s landing at 480x270 and 12.5 fps is 1.2 MB, with no block off by more than 40 grey levels.
WEBP_QUALITY = 85


class FrameWriter:
    """One video file open for writing: ``codec`` in the ``container`` format (None: from the file's name)."""

    def __init__(
        self,
        path: str | Path,
        size: tuple[int, int],
        fps: Fraction,
        codec: str,
        pix_fmt: str,
        options: dict[str, str],
        container: str | None = None,
        container_options: dict[str, str] | None = None,
    ) -> None:
        width, height = size
        if pix_fmt == "yuv420p" and (width % 2 or height % 2):
            raise ValueError(f"{width}x{height}: H.264 in yuv420p needs an even width and height")
        self.path, self.size, self.fps = Path(path), size, Fraction(fps)
        out = av.open(str(path), "w", format=container, options=container_options or {})
        try:
            stream = out.add_stream(codec, rate=self.fps)
            if not isinstance(stream, av.VideoStream):
                raise ValueError(f"{codec} is not a video encoder")
            stream.width, stream.height, stream.pix_fmt = width, height, pix_fmt
            stream.options = dict(options)
        except BaseException:
            out.close()
            raise
        self._out: av.container.OutputContainer | None = out
        self._stream = stream
        self.frames = 0

    def write(self, rgb: np.ndarray) -> None:
        """The next frame (height x width x 3, uint8 RGB)."""
        if rgb.shape[1::-1] != self.size:
            raise ValueError(f"a {rgb.shape[1]}x{rgb.shape[0]} frame in a {self.size[0]}x{self.size[1]} video")
        frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(rgb), format="rgb24")
        frame.pts, frame.time_base = self.frames, 1 / self.fps
        if self._out is None:
            raise ValueError(f"{self.path}: written after it was closed")
        for packet in self._stream.encode(frame):
            self._out.mux(packet)
        self.frames += 1

    def close(self) -> None:
        """Flush the encoder and finish the file (again: nothing)."""
        if self._out is None:
            return
        try:
            for packet in self._stream.encode():
                self._out.mux(packet)
        finally:
            self._out.close()
            self._out = None

    def __enter__(self) -> FrameWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def mp4_writer(path: str | Path, size: tuple[int, int], fps: Fraction) -> FrameWriter:
    """An MP4 file of H.264 in yuv420p (x264, ``MP4_CRF``, ``MP4_PRESET``)."""
    return FrameWriter(path, size, fps, "libx264", "yuv420p", {"crf": str(MP4_CRF), "preset": MP4_PRESET}, "mp4")


def webp_writer(path: str | Path, size: tuple[int, int], fps: Fraction, quality: int = WEBP_QUALITY) -> FrameWriter:
    """An animated WebP that loops forever (lossy, ``quality`` 0-100)."""
    options = {"quality": str(quality), "compression_level": "4"}
    return FrameWriter(path, size, fps, "libwebp_anim", "yuv420p", options, "webp", {"loop": "0"})
