"""The downward camera: MuJoCo offscreen rendering of the vehicle's ``downward`` camera.

Headless with ``MUJOCO_GL=egl`` (set by ``sitl`` before MuJoCo is imported).  The scene is
set up for speed, since its settings, not the resolution, set the cost: no shadows, no
reflections, no skybox, no multisampling (about 2-3 ms per 640x480 frame on a 2-core machine
against ~30 ms with MuJoCo's defaults).  Frames are greyscale ``uint8`` (height, width), what
the marker detector reads, with optional Gaussian pixel noise drawn from a seeded bank, so
the same seed gives the same frames.
"""

from __future__ import annotations

import time

import cv2
import mujoco
import numpy as np

from params.vehicle import CameraSpec

NOISE_BANK = 4  # noise images drawn once at start; each frame adds one of them, rolled


class DownwardCamera:
    """Renders the ``downward`` camera of a model built with a [camera] (:func:`sitl.model.build_model`)."""

    def __init__(self, model: mujoco.MjModel, spec: CameraSpec, seed: int = 0) -> None:
        self.spec = spec
        self.renderer = mujoco.Renderer(model, spec.height_px, spec.width_px)
        self.option = mujoco.MjvOption()
        for flag in ("mjRND_SHADOW", "mjRND_REFLECTION", "mjRND_SKYBOX"):
            self.renderer.scene.flags[getattr(mujoco.mjtRndFlag, flag)] = 0
        self._camera = model.camera("downward").id
        self._rng = np.random.default_rng(seed * 104729 + 5)
        self._noise = [
            self._rng.standard_normal((spec.height_px, spec.width_px)).astype(np.float32) for _ in range(NOISE_BANK)
        ]
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
        grey = cv2.cvtColor(rgb, cv2.COLOR_RGB2GRAY)
        if noise_grey > 0.0:
            k = int(self._rng.integers(NOISE_BANK))
            shift = int(self._rng.integers(grey.shape[0]))
            noise = np.roll(self._noise[k], shift, axis=0)
            grey = cv2.convertScaleAbs(cv2.scaleAdd(noise, noise_grey, grey.astype(np.float32)))
        self.frames += 1
        self.render_s += time.perf_counter() - t0
        return grey

    def skip(self, noise_grey: float = 0.0) -> None:
        """A frame not rendered (nothing it could show is wanted): counted, with the noise draws a capture
        makes, so the frames after it are the same as if it had been rendered."""
        if noise_grey > 0.0:
            self._rng.integers(NOISE_BANK)
            self._rng.integers(self.spec.height_px)
        self.frames += 1

    def close(self) -> None:
        self.renderer.close()
