"""The downward camera: MuJoCo offscreen rendering of the vehicle's ``downward`` camera.

Headless with ``MUJOCO_GL=egl`` (set by ``sitl`` before MuJoCo is imported).  The scene is
set up for speed, since its settings, not the resolution, set the cost: no shadows, no
reflections, no skybox, no multisampling (about 2-3 ms per 640x480 frame on a 2-core machine
against ~30 ms with MuJoCo's defaults).  Frames are greyscale ``uint8`` (height, width), what
the marker detector reads, with optional Gaussian pixel noise drawn from a seeded bank, so
the same seed gives the same frames.

``SIM_CAM_RENDER`` 1 draws the same scene without OpenGL instead (:mod:`sitl.deck_render`, the deck and the ground
only); :func:`open_camera` builds the one the setting asks for.  Both add the same noise (:class:`FrameNoise`).
"""

from __future__ import annotations

import time

import cv2
import mujoco
import numpy as np

from params.vehicle import CameraSpec

NOISE_BANK = 4  # noise images drawn once at start; each frame adds one of them, rolled
RENDER_MUJOCO, RENDER_FAST = 0, 1  # SIM_CAM_RENDER


class FrameNoise:
    """The pixel noise of a camera seeded ``seed``: a bank of noise images drawn at start, one of them rolled by a
    random number of rows added to each frame.  A frame not rendered makes the same draws (:meth:`skip`), so the
    frames after it are the same whether it was rendered or not."""

    def __init__(self, spec: CameraSpec, seed: int) -> None:
        self.height_px = spec.height_px
        self._rng = np.random.default_rng(seed * 104729 + 5)
        self._noise = [
            self._rng.standard_normal((spec.height_px, spec.width_px)).astype(np.float32) for _ in range(NOISE_BANK)
        ]
        self._sum = np.empty((spec.height_px, spec.width_px), np.float32)  # a frame plus its noise, reused

    def add(self, grey: np.ndarray, noise_grey: float) -> np.ndarray:
        """``grey`` (uint8) with the next noise image times ``noise_grey`` added (as it is when that is 0)."""
        if noise_grey <= 0.0:
            return grey
        k = int(self._rng.integers(NOISE_BANK))
        shift = int(self._rng.integers(grey.shape[0]))
        # the noise image rolled down by ``shift`` rows, added in its two parts (no rolled copy made)
        noise, base, out, h = self._noise[k], grey.astype(np.float32), self._sum, grey.shape[0]
        cv2.scaleAdd(noise[h - shift :], noise_grey, base[:shift], out[:shift])
        cv2.scaleAdd(noise[: h - shift], noise_grey, base[shift:], out[shift:])
        return cv2.convertScaleAbs(out)

    def skip(self, noise_grey: float) -> None:
        """The draws :meth:`add` makes, without a frame."""
        if noise_grey > 0.0:
            self._rng.integers(NOISE_BANK)
            self._rng.integers(self.height_px)


class DownwardCamera:
    """Renders the ``downward`` camera of a model built with a [camera] (:func:`sitl.model.build_model`)."""

    def __init__(self, model: mujoco.MjModel, spec: CameraSpec, seed: int = 0, camera: str = "downward") -> None:
        self.spec = spec
        self.renderer = mujoco.Renderer(model, spec.height_px, spec.width_px)
        self.option = mujoco.MjvOption()
        for flag in ("mjRND_SHADOW", "mjRND_REFLECTION", "mjRND_SKYBOX"):
            self.renderer.scene.flags[getattr(mujoco.mjtRndFlag, flag)] = 0
        self._camera = model.camera(camera).id
        self.noise = FrameNoise(spec, seed)
        self.frames = 0
        self.render_s = 0.0
        self.last_rgb: np.ndarray | None = None  # the latest capture in colour (RGB, height x width x 3)

    def capture(self, data: mujoco.MjData, noise_grey: float = 0.0) -> np.ndarray:
        """The current view as a greyscale image (uint8, height x width)."""
        t0 = time.perf_counter()
        r = self.renderer
        r.update_scene(data, camera=self._camera, scene_option=self.option)
        for flag in ("mjRND_SHADOW", "mjRND_REFLECTION", "mjRND_SKYBOX"):
            r.scene.flags[getattr(mujoco.mjtRndFlag, flag)] = 0
        self.last_rgb = rgb = r.render()  # (the video, photos and recordings use the colour frame, without noise)
        grey = self.noise.add(cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY), noise_grey)
        self.frames += 1
        self.render_s += time.perf_counter() - t0
        return grey

    def skip(self, noise_grey: float = 0.0) -> None:
        """A frame not rendered (nothing it could show is wanted): counted, with the noise draws a capture
        makes, so the frames after it are the same as if it had been rendered."""
        self.noise.skip(noise_grey)
        self.frames += 1

    def close(self) -> None:
        self.renderer.close()


def open_camera(
    model: mujoco.MjModel, spec: CameraSpec, seed: int = 0, render: int = RENDER_MUJOCO, camera: str = "downward"
):
    """The camera ``SIM_CAM_RENDER`` (``render``) asks for: MuJoCo's render (:class:`DownwardCamera`, 0) or the
    deck-and-ground renderer (:class:`sitl.deck_render.DeckCamera`, 1); the same interface, the same noise.
    ``camera``: the model's camera to render (vehicle k's is ``sitl.model.part_name(k, "downward")``)."""
    if int(render) == RENDER_FAST:
        from sitl.deck_render import DeckCamera

        return DeckCamera(model, spec, seed, camera)
    return DownwardCamera(model, spec, seed, camera)
