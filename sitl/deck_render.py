"""The downward camera's fast path (``SIM_CAM_RENDER`` 1): the deck and the ground drawn with OpenCV, as MuJoCo
draws them, without OpenGL.

What the camera looks for is flat: the ground plane and the top of the ground vehicle's deck with the landing
pad's texture.  A plane's image is a homography of it, so the deck is its texture warped into the image
(``cv2.warpPerspective``), the ground a smooth shade under it; no GL context, no Mesa rasteriser.  Left out:
everything else in the world (the multicopter's own legs and propellers at the image's edge, the deck's 1 cm
sides, the UGV's chassis and wheels under it, other vehicles); ``benchmarks/camera_fast_path.py`` counts how
often they would have covered a marker.

How MuJoCo draws it (its classic OpenGL renderer, fixed-function lighting; checked against its renders, see
tests/test_deck_render.py and ``benchmarks/camera_fast_path.py``):

- The camera (``downward``): a pinhole looking along its -z with image x right and y up, vertical field of view
  ``cam_fovy``; the pixel (u right, v down) of a point (x, y, z) in the camera's frame is
  (cx + f x / -z, cy - f y / -z) with f = (height / 2) / tan(fovy / 2) and (cx, cy) the image's centre
  ((width - 1) / 2, (height - 1) / 2: pixel centres at integers).  Its pose: ``cam_xpos``/``cam_xmat``.
- The deck (geom ``ugv_deck``, a box with a cube texture): its top face carries the "front" image of the
  texture (:func:`sitl.ugv.pad_png`), stretched over the face, the image's right along the box's +x (the UGV's
  forward) and its top along +y (left).  Sampled as OpenGL's ``GL_LINEAR_MIPMAP_LINEAR`` with the level of
  detail of each pixel, log2 of the larger of the texture's two derivative lengths (texels per pixel, OpenGL's
  formula; Mesa's cheaper approximations fit its renders worse), from the exact homography's derivatives on an
  8 px grid; the mipmaps each level halved (rounded down) with a bilinear filter (a box filter fits worse).  The
  deck covers the pixels whose centre its face covers (OpenGL's rule), its texture clamped at the edges.  Lit by
  the scene's lights with its material's colour and no specular: white (255) and black (0) unless the camera
  looks at the deck more than ~60 deg off its normal (the headlight's share then falls below full white).
- The ground (geom ``ground``, a plane of MuJoCo's default material: specular 0.5, shininess 0.5): OpenGL's
  per-vertex (Gouraud) lighting with a local viewer, on the quads MuJoCo tessellates a plane into (5.05 m for
  the 500 m ground), each split along its (x1, y0)-(x0, y1) diagonal, the colour interpolated across each
  triangle.  That is the brightness gradient of its renders (a specular highlight sampled at the vertices);
  reproduced per vertex here, evaluated on a 16 px grid and interpolated.  Above the horizon: MuJoCo's clear
  colour, black.

Noise-free, the frames differ from MuJoCo's by 0.2 grey levels on average, a frame's 99th percentile 1-2 levels
(marker edges far away, where the two filter the texture a little differently), the ground's shade to a level;
both then get the same pixel noise (:class:`sitl.camera.FrameNoise`: same seed, same draws).  A frame costs
1.5-2 ms of CPU here against MuJoCo's 5-6 ms (Mesa's llvmpipe), and needs no GL context.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import cv2
import mujoco
import numpy as np

from params.vehicle import CameraSpec
from sitl.camera import FrameNoise

LOD_GRID_PX = 8  # the level of detail is computed every this many pixels and interpolated
GROUND_GRID_PX = 16  # the ground's shade likewise
GREY_WEIGHTS = np.array((0.299, 0.587, 0.114))  # cv2.COLOR_RGB2GRAY's
DEFAULT_SPECULAR, DEFAULT_SHININESS = 0.5, 0.5  # a geom without a material (MuJoCo's mjv_initGeom)
MAX_PLANE_GRID = 200  # MuJoCo's mjMAXPLANEGRID: a plane is drawn as at most this many quads a side
FRONT_FACE = 4  # a cube texture's faces in the model: right, left, up, down, front, back


def plane_grid(half_m: float, spacing_m: float) -> np.ndarray:
    """The coordinates (m) of the vertex lines MuJoCo draws a plane of half-size ``half_m`` and grid spacing
    ``spacing_m`` (its size's third number) with (``makePlane`` in its render context)."""
    step = max(spacing_m, half_m / (MAX_PLANE_GRID - 2))
    n = int(math.floor(half_m / max(step, 1e-15)))
    n -= n % 2
    pad = half_m - n * step
    lines = [-half_m, -half_m + pad] + [-half_m + pad + k * 2 * step for k in range(1, n + 1)] + [half_m]
    return np.maximum.accumulate(np.array(lines))


class _Lights:
    """The scene's lights as MuJoCo hands them to OpenGL: the headlight (at the camera, along its axis) and the
    model's directional lights; each (direction towards the light, ambient, diffuse, specular)."""

    def __init__(self, model: mujoco.MjModel) -> None:
        hl = model.vis.headlight
        self.head = (np.array(hl.ambient), np.array(hl.diffuse), np.array(hl.specular)) if hl.active else None
        self.model_lights = [i for i in range(model.nlight) if model.light_active[i]]
        if any(model.light_type[i] != mujoco.mjtLightType.mjLIGHT_DIRECTIONAL for i in self.model_lights):
            raise ValueError("the fast camera renders directional lights only")
        self.model = model

    def at(self, data: mujoco.MjData, cam_back: np.ndarray) -> list[tuple[np.ndarray, ...]]:
        m = self.model
        out = [] if self.head is None else [(cam_back, *self.head)]
        for i in self.model_lights:
            d = -np.asarray(data.light_xdir[i], dtype=float)
            out.append((d / np.linalg.norm(d), m.light_ambient[i], m.light_diffuse[i], m.light_specular[i]))
        return out


def _material(model: mujoco.MjModel, geom: int) -> tuple[np.ndarray, float, float, float]:
    """(rgb, emission, specular, shininess) of ``geom`` as MuJoCo's scene has them (``setMaterial``)."""
    rgba, mat = model.geom_rgba[geom], int(model.geom_matid[geom])
    if mat < 0:
        return np.array(rgba[:3], dtype=float), 0.0, DEFAULT_SPECULAR, DEFAULT_SHININESS
    own = np.any(np.abs(rgba - (0.5, 0.5, 0.5, 1.0)) > 1e-6)
    rgb = np.array((rgba if own else model.mat_rgba[mat])[:3], dtype=float)
    return rgb, float(model.mat_emission[mat]), float(model.mat_specular[mat]), float(model.mat_shininess[mat])


def deck_geoms(model: mujoco.MjModel) -> list[int]:
    """The deck geoms of every ground vehicle of ``model`` (``ugv_deck``, ``v1_ugv_deck`` ...: sitl.ugv.ugv_part)."""
    names = [(model.geom(i).name, i) for i in range(model.ngeom)]
    decks = [i for name, i in names if name == "ugv_deck" or (name.startswith("v") and name.endswith("_ugv_deck"))]
    if not decks:
        raise ValueError("the fast camera needs a ground vehicle's deck (geom ugv_deck)")
    return decks


@dataclass(frozen=True)
class _DeckFace:
    """One deck's top as the renderer draws it: its geom, half-sizes (m), colour and emission, texture's mipmaps
    and the coverage image (warped to the image, nearest texel)."""

    geom: int
    half: np.ndarray
    rgb: np.ndarray
    emission: float
    levels: list[np.ndarray]
    cover: np.ndarray

    @staticmethod
    def of(model: mujoco.MjModel, geom: int) -> _DeckFace:
        rgb, emission, _, _ = _material(model, geom)
        levels = _mipmaps(_front_face(model, geom))
        return _DeckFace(geom, np.array(model.geom_size[geom], dtype=float), rgb, emission, levels,
                         np.full_like(levels[0], 1))  # fmt: skip


class DeckRenderer:
    """Draws the ``downward`` camera's view of the ground and the deck (``width`` x ``height`` px, grey uint8)."""

    def __init__(self, model: mujoco.MjModel, width: int, height: int, camera: str = "downward") -> None:
        self.width, self.height = width, height
        self.cam = model.camera(camera).id
        self.f = 0.5 * height / math.tan(math.radians(float(model.cam_fovy[self.cam])) / 2)
        self.cx, self.cy = (width - 1) / 2, (height - 1) / 2
        self.znear = float(model.vis.map.znear * model.stat.extent)
        self.lights = _Lights(model)
        self.decks = [_DeckFace.of(model, g) for g in deck_geoms(model)]  # every ground vehicle's, its own texture
        self.ground = model.geom("ground").id
        g = self.ground
        if np.any(np.abs(model.geom_pos[g]) > 1e-9) or np.any(np.abs(model.geom_quat[g] - (1, 0, 0, 0)) > 1e-9):
            raise ValueError("the fast camera needs the ground plane at the world's origin, level")
        self.ground_rgb, self.ground_emission, self.ground_specular, shininess = _material(model, g)
        self.ground_exponent = 128.0 * shininess
        self.grid = (plane_grid(model.geom_size[g][0], model.geom_size[g][2]),
                     plane_grid(model.geom_size[g][1], model.geom_size[g][2]))  # fmt: skip
        cw, ch = max(1, width // GROUND_GRID_PX), max(1, height // GROUND_GRID_PX)  # the shade's grid, as cv2.resize
        u, v = np.meshgrid((np.arange(cw) + 0.5) * width / cw - 0.5, (np.arange(ch) + 0.5) * height / ch - 0.5)
        self._ground_rays = self._rays(u, v, np.eye(3))  # camera frame
        corners_u, corners_v = np.array([0.0, width - 1, 0.0, width - 1]), np.array([0.0, 0.0, height - 1, height - 1])
        self._corner_rays = self._rays(corners_u, corners_v, np.eye(3))

    # -- the frame ------------------------------------------------------------------------------
    def render(self, data: mujoco.MjData) -> np.ndarray:
        """The view from the state ``data`` (kinematics and camera poses current, as for MuJoCo's renderer)."""
        rot = np.asarray(data.cam_xmat[self.cam], dtype=float).reshape(3, 3)
        eye = np.asarray(data.cam_xpos[self.cam], dtype=float)
        lights = self.lights.at(data, rot[:, 2])
        img = self._ground(rot, eye, lights)
        tops = []
        for face in self.decks:
            g = np.asarray(data.geom_xmat[face.geom], dtype=float).reshape(3, 3)
            top = data.geom_xpos[face.geom] + g[:, 2] * face.half[2]
            if (eye - top) @ g[
                :, 2
            ] > 1e-6:  # the top faces the camera (from below, MuJoCo shows the box's other faces)
                tops.append((-float(np.linalg.norm(eye - top)), face))
        for _, face in sorted(tops, key=lambda t: t[0]):  # the farthest first: a nearer deck is drawn over it
            self._deck(img, face, self._deck_homography(data, face, rot, eye), data, lights)
        return img

    def _rays(self, u: np.ndarray, v: np.ndarray, rot: np.ndarray) -> np.ndarray:
        """World directions (not unit) of the rays through pixels (u, v) (arrays of one shape): (..., 3)."""
        cam = np.stack([(u - self.cx) / self.f, -(v - self.cy) / self.f, -np.ones_like(u)], axis=-1)
        return cam @ rot.T

    # -- the ground -----------------------------------------------------------------------------
    def _ground(self, rot: np.ndarray, eye: np.ndarray, lights) -> np.ndarray:
        w, h = self.width, self.height
        d = self._ground_rays @ rot.T  # through the shade's grid of pixels, world frame
        dz = np.minimum(d[..., 2], -1e-3 * np.linalg.norm(d, axis=-1))  # (above the horizon: the far ground)
        t = -eye[2] / dz
        x, y = eye[0] + t * d[..., 0], eye[1] + t * d[..., 1]
        rgb = np.floor(self._ground_colour(x, y, eye, lights) * 255.0 + 0.5)
        grey = np.clip(np.rint(rgb @ GREY_WEIGHTS), 0, 255).astype(np.uint8)
        img = cv2.resize(grey, (w, h), interpolation=cv2.INTER_LINEAR)
        if np.any(self._corner_rays @ rot[2] >= 0.0):  # the horizon in view: MuJoCo's clear colour above it
            uu, vv = np.arange(w, dtype=float), np.arange(h, dtype=float)
            up = (rot[2, 0] * (uu - self.cx) / self.f)[None, :] - (rot[2, 1] * (vv - self.cy) / self.f)[:, None]
            img[up - rot[2, 2] >= 0.0] = 0
        return img

    def _ground_colour(self, x: np.ndarray, y: np.ndarray, eye: np.ndarray, lights) -> np.ndarray:
        """The ground's colour (rgb 0-1, (..., 3)) at (x, y): the vertex colours of the triangle it lies in,
        interpolated (OpenGL's Gouraud shading of MuJoCo's plane quads)."""
        gx, gy = self.grid
        i = np.clip(np.searchsorted(gx, x) - 1, 0, len(gx) - 2)
        j = np.clip(np.searchsorted(gy, y) - 1, 0, len(gy) - 2)
        i0, j0 = int(i.min()), int(j.min())
        vx, vy = np.meshgrid(gx[i0 : int(i.max()) + 2], gy[j0 : int(j.max()) + 2], indexing="ij")
        c = self._vertex_colours(vx, vy, eye, lights)
        a, b = i - i0, j - j0
        fx = ((x - gx[i]) / (gx[i + 1] - gx[i]))[..., None]
        fy = ((y - gy[j]) / (gy[j + 1] - gy[j]))[..., None]
        c00, c10, c11, c01 = c[a, b], c[a + 1, b], c[a + 1, b + 1], c[a, b + 1]
        low = c00 + fx * (c10 - c00) + fy * (c01 - c00)
        high = c11 + (1 - fx) * (c01 - c11) + (1 - fy) * (c10 - c11)
        return np.where(fx + fy <= 1.0, low, high)

    def _vertex_colours(self, x: np.ndarray, y: np.ndarray, eye: np.ndarray, lights) -> np.ndarray:
        """OpenGL's fixed-function lighting (local viewer) of the ground at its vertices (x, y, 0): (..., 3)."""
        view = np.stack([eye[0] - x, eye[1] - y, np.full_like(x, eye[2])], axis=-1)
        view /= np.linalg.norm(view, axis=-1, keepdims=True)
        rgb = self.ground_rgb
        c = np.zeros(x.shape + (3,)) + self.ground_emission * rgb + (0.0 if lights else 0.3) * rgb
        for to_light, ambient, diffuse, specular in lights:
            c += ambient * rgb
            if to_light[2] > 0.0:  # the plane's normal is +z
                c += diffuse * rgb * to_light[2]
                half = view + to_light
                cos_h = np.maximum(half[..., 2] / np.linalg.norm(half, axis=-1), 0.0)
                c += (specular * self.ground_specular) * (cos_h**self.ground_exponent)[..., None]
        return np.clip(c, 0.0, 1.0)

    # -- the deck -------------------------------------------------------------------------------
    def _deck_homography(self, data: mujoco.MjData, face: _DeckFace, rot: np.ndarray, eye: np.ndarray) -> np.ndarray:
        """3x3: the deck texture's level-0 pixel (column, row, 1) -> the image's (u w, v w, w), w the depth (m)."""
        g = np.asarray(data.geom_xmat[face.geom], dtype=float).reshape(3, 3)
        a, b, hz = face.half
        n = face.levels[0].shape[1], face.levels[0].shape[0]
        # the texel (X, Y) is at x = (X + 0.5) 2a / n - a, y = b - (Y + 0.5) 2b / n on the face at z = hz
        ex, ey = g[:, 0] * (2 * a / n[0]), -g[:, 1] * (2 * b / n[1])
        origin = data.geom_xpos[face.geom] + g[:, 2] * hz + g[:, 0] * (a / n[0] - a) - g[:, 1] * (b / n[1] - b)
        to_cam = rot.T @ np.column_stack([ex, ey, origin - eye])
        k = np.array([[self.f, 0.0, -self.cx], [0.0, -self.f, -self.cy], [0.0, 0.0, -1.0]])  # (x, y, z) -> depth
        return k @ to_cam

    def _deck(self, img: np.ndarray, face: _DeckFace, hom: np.ndarray, data: mujoco.MjData, lights) -> None:
        """Draw the deck's top into ``img`` (in place): the pixels whose centre it covers (OpenGL's rule), each its
        texture sampled trilinearly at the pixel's level of detail, clamped at the texture's edges."""
        n_y, n_x = face.levels[0].shape
        corners = hom @ np.array([[-0.5, n_x - 0.5, n_x - 0.5, -0.5], [-0.5, -0.5, n_y - 0.5, n_y - 0.5], [1.0] * 4])
        depth = corners[2]
        if np.all(depth <= self.znear):
            return
        w, h = self.width, self.height
        clip = None
        if np.all(depth > self.znear):  # the region the deck's corners span
            uv = corners[:2] / depth
            x0, y0 = max(0, int(math.floor(uv[0].min())) - 1), max(0, int(math.floor(uv[1].min())) - 1)
            x1, y1 = min(w, int(math.ceil(uv[0].max())) + 2), min(h, int(math.ceil(uv[1].max())) + 2)
            if x0 >= x1 or y0 >= y1:
                return
        else:  # the deck's plane crosses the camera's: only the pixels whose ray meets it in front of the lens
            x0, y0, x1, y1 = 0, 0, w, h
            inv = np.linalg.inv(hom)[2]  # . (u, v, 1) = 1 / the depth of the point of the plane the ray meets
            per_depth = np.add.outer(inv[1] * np.arange(h), inv[0] * np.arange(w)) + inv[2]
            clip = (per_depth <= 0.0) | (per_depth >= 1.0 / self.znear)
        shift = np.array([[1.0, 0.0, -x0], [0.0, 1.0, -y0], [0.0, 0.0, 1.0]]) @ hom
        size = (x1 - x0, y1 - y0)
        cover = cv2.warpPerspective(face.cover, shift, size, flags=cv2.INTER_NEAREST, borderMode=cv2.BORDER_CONSTANT)
        if clip is not None:
            cover[clip] = 0
        if not cv2.countNonZero(cover):
            return
        lod = self._lod(np.linalg.inv(shift), len(face.levels), *size)
        lo, hi, _, _ = cv2.minMaxLoc(lod, cover)
        scale = self._deck_light(data, face, lights)
        out = weight = None
        for level in range(int(lo), int(math.ceil(hi)) + 1):
            tex = face.levels[level] if scale >= 1.0 else cv2.convertScaleAbs(face.levels[level], alpha=scale)
            sx, sy = n_x / tex.shape[1], n_y / tex.shape[0]  # the level's texel X is level 0's (X + 0.5) s - 0.5
            to_level0 = np.array([[sx, 0.0, 0.5 * sx - 0.5], [0.0, sy, 0.5 * sy - 0.5], [0.0, 0.0, 1.0]])
            layer = cv2.warpPerspective(tex, shift @ to_level0, size, flags=cv2.INTER_LINEAR,
                                        borderMode=cv2.BORDER_REPLICATE)  # fmt: skip
            w_l = np.clip(1.0 - np.abs(lod - level), 0.0, 1.0)
            if out is None:
                out, weight = layer, w_l
            else:
                out, weight = cv2.blendLinear(out, layer, weight, w_l), weight + w_l
        np.copyto(img[y0:y1, x0:x1], out, where=cover.view(bool))

    def _lod(self, inv: np.ndarray, n_levels: int, w: int, h: int) -> np.ndarray:
        """OpenGL's level of detail (clamped to the mipmaps) of each pixel of a w x h region whose pixel -> texel
        homography is ``inv``: log2 of the larger derivative length, on a grid, interpolated."""
        cw, ch = max(1, w // LOD_GRID_PX), max(1, h // LOD_GRID_PX)
        u, v = np.meshgrid((np.arange(cw) + 0.5) * w / cw - 0.5, (np.arange(ch) + 0.5) * h / ch - 0.5)
        big_x, big_y, big_w = (inv[r, 0] * u + inv[r, 1] * v + inv[r, 2] for r in range(3))
        big_w = np.where(np.abs(big_w) < 1e-12, 1e-12, big_w)
        x, y = big_x / big_w, big_y / big_w
        dxu, dxv = (inv[0, 0] - x * inv[2, 0]) / big_w, (inv[0, 1] - x * inv[2, 1]) / big_w
        dyu, dyv = (inv[1, 0] - y * inv[2, 0]) / big_w, (inv[1, 1] - y * inv[2, 1]) / big_w
        rho = np.maximum(np.hypot(dxu, dyu), np.hypot(dxv, dyv))
        lod = np.clip(np.log2(np.maximum(rho, 1e-9)), 0.0, n_levels - 1).astype(np.float32)
        return cv2.resize(lod, (w, h), interpolation=cv2.INTER_LINEAR)

    def _deck_light(self, data: mujoco.MjData, face: _DeckFace, lights) -> float:
        """The deck's lit share of its texture (<= 1): its lights' ambient and diffuse, no specular (grey)."""
        normal = np.asarray(data.geom_xmat[face.geom], dtype=float).reshape(3, 3)[:, 2]
        rgb = face.rgb
        c = face.emission * rgb + (0.0 if lights else 0.3) * rgb
        for to_light, ambient, diffuse, _ in lights:
            c = c + ambient * rgb + diffuse * rgb * max(0.0, float(normal @ to_light))
        return float(np.clip(c, 0.0, 1.0) @ GREY_WEIGHTS)


def _front_face(model: mujoco.MjModel, geom: int) -> np.ndarray:
    """The grey image on the top face of the box ``geom``: its cube texture's "front" face."""
    mat = int(model.geom_matid[geom])
    tex = int(np.max(model.mat_texid[mat])) if mat >= 0 else -1
    if tex < 0 or model.tex_type[tex] != mujoco.mjtTexture.mjTEXTURE_CUBE:
        raise ValueError("the fast camera needs the deck's cube texture")
    n, c, adr = int(model.tex_width[tex]), int(model.tex_nchannel[tex]), int(model.tex_adr[tex])
    faces = np.asarray(model.tex_data[adr : adr + 6 * n * n * c]).reshape(6, n, n, c)
    face = np.ascontiguousarray(faces[FRONT_FACE, :, :, :3])
    return cv2.cvtColor(face, cv2.COLOR_RGB2GRAY)


def _mipmaps(level0: np.ndarray) -> list[np.ndarray]:
    """The mipmap chain of ``level0`` (each level half the last, rounded down, at least 1 px; bilinear)."""
    levels = [level0]
    while max(levels[-1].shape) > 1:
        h, w = levels[-1].shape
        levels.append(cv2.resize(levels[-1], (max(1, w // 2), max(1, h // 2)), interpolation=cv2.INTER_LINEAR))
    return levels


class DeckCamera:
    """The fast path's camera: :class:`sitl.camera.DownwardCamera`'s interface (``capture``, ``skip``, ``frames``,
    ``render_s``, ``last_rgb``, ``close``) and its noise (same seed, same draws), :class:`DeckRenderer`'s picture.
    ``last_rgb`` is the frame without noise, grey in three channels (made when asked for)."""

    def __init__(self, model: mujoco.MjModel, spec: CameraSpec, seed: int = 0, camera: str = "downward") -> None:
        self.spec = spec
        self.renderer = DeckRenderer(model, spec.width_px, spec.height_px, camera)
        self.noise = FrameNoise(spec, seed)
        self.frames = 0
        self.render_s = 0.0
        self._clean: np.ndarray | None = None
        self._rgb: np.ndarray | None = None

    @property
    def last_rgb(self) -> np.ndarray | None:
        """The latest capture without noise, RGB (height x width x 3, the grey in each channel)."""
        if self._rgb is None and self._clean is not None:
            self._rgb = cv2.cvtColor(self._clean, cv2.COLOR_GRAY2RGB)
        return self._rgb

    def capture(self, data: mujoco.MjData, noise_grey: float = 0.0) -> np.ndarray:
        """The current view as a greyscale image (uint8, height x width)."""
        t0 = time.perf_counter()
        self._clean, self._rgb = self.renderer.render(data), None
        grey = self.noise.add(self._clean, noise_grey)
        self.frames += 1
        self.render_s += time.perf_counter() - t0
        return grey

    def skip(self, noise_grey: float = 0.0) -> None:
        """A frame not rendered: counted, with the noise draws a capture makes (as DownwardCamera.skip)."""
        self.noise.skip(noise_grey)
        self.frames += 1

    def close(self) -> None:
        pass
