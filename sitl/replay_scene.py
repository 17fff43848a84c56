"""A flight's world rebuilt for its video: the MuJoCo model, its bodies posed from the logs, two views.

:class:`ReplayScene` compiles the world as the simulator built it (:func:`sitl.model.build_world_mjcf`: the vehicle
file's multicopter with its camera, and gimbal if it had one; the ground vehicle with the landing pad on its deck,
:func:`sitl.ugv.ugv_mjcf`) plus, for the chase view only, a checkered ground of 1 m squares (geom group 3) so that
motion over the ground shows; the onboard view sees the plain ground the simulator's camera saw.  Nothing is
simulated: each video frame sets the free joints' ``qpos`` from a :class:`Pose` and runs the kinematics.

Frames: a :class:`Pose` is in the truth log's frames (NED metres from the multicopter's start point on the ground;
roll, pitch, yaw in radians, FRD body); MuJoCo's ENU/FLU is reached only through :mod:`mavsim_core.frames`.  The
multicopter's start point is the world's origin (its truth and the UGV's are both measured from it).

:class:`ChaseCamera` follows the vehicle from behind (along its heading) and above, and frames the ground vehicle
with it when it is near; its look-at point, distance and heading follow their targets through first-order lags in
simulated time, so the picture neither shakes nor jumps.  Rendering is set up as :mod:`sitl.camera` does (no
shadows, reflections, skybox or multisampling): the scene, not the resolution, sets the cost.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco
import numpy as np

from mavsim_core.frames import ned_to_enu, quat_ned_frd_to_enu_flu
from mavsim_core.quaternion import from_euler
from params.vehicle import VehicleSpec
from sitl.model import GIMBAL_JOINTS, Placement, build_world_mjcf, part_name
from sitl.ugv import UgvGeometry, ugv_mjcf
from sitl.ugv_paths import Pose2
from vision.pad import PadLayout

FAST_FLAGS = ("mjRND_SHADOW", "mjRND_REFLECTION", "mjRND_SKYBOX")
GRID_GROUP = 3  # the chase view's checkered ground: a geom group MuJoCo hides unless a view turns it on
GRID_SQUARE_M = 1.0
GRID_RGB = ((0.45, 0.55, 0.45), (0.53, 0.63, 0.53))  # about the simulator's ground colour (0.5, 0.6, 0.5)


@dataclass(frozen=True)
class Pose:
    """Where everything is at one instant: the multicopter (NED m from its start point; roll, pitch, yaw rad), the
    UGV's deck centre (NED m) and yaw (rad) or None, the gimbal's joints (roll, pitch, yaw rad) or None."""

    pos_ned_m: tuple[float, float, float]
    rpy_rad: tuple[float, float, float]
    deck_ned_m: tuple[float, float, float] | None = None
    ugv_yaw_rad: float = 0.0
    gimbal_rpy_rad: tuple[float, float, float] | None = None


@dataclass(frozen=True)
class ChaseView:
    """A MuJoCo free camera: the point it looks at (ENU m), its distance (m), azimuth and elevation (deg)."""

    lookat_enu_m: tuple[float, float, float]
    distance_m: float
    azimuth_deg: float
    elevation_deg: float


class ChaseCamera:
    """Behind and above the vehicle, the UGV in the picture when it is near (``FRAME_BOTH_M``); smoothed.

    :meth:`view` takes simulated time (s) and the pose; each quantity follows its target with a first-order lag of
    its time constant (s of simulated time), the first call starting on target.  The heading is the vehicle's yaw:
    the camera looks where the vehicle's nose points, from ``ELEVATION_DEG`` above the horizon.
    """

    TAU_LOOKAT_S = 0.2  # the truth is smooth already: this only eases the framing in and out
    TAU_DISTANCE_S = 1.0
    TAU_HEADING_S = 1.5
    ELEVATION_DEG = -28.0
    MIN_DISTANCE_M = 5.0
    FRAME_BOTH_M = (10.0, 15.0)  # the UGV this near (horizontally): framed with the vehicle, faded out to the farther
    TOWARDS_UGV = 0.4  # the look-at point's share of the way from the vehicle to the UGV when framing both

    def __init__(self) -> None:
        self._t_s: float | None = None
        self._lookat = np.zeros(3)
        self._distance = self.MIN_DISTANCE_M
        self._azimuth = 0.0

    def view(self, t_s: float, pose: Pose) -> ChaseView:
        vehicle = np.array(pose.pos_ned_m, dtype=float)
        lookat, distance = vehicle, self.MIN_DISTANCE_M
        if pose.deck_ned_m is not None and np.all(np.isfinite(pose.deck_ned_m)):
            deck = np.array(pose.deck_ned_m, dtype=float)
            apart = math.hypot(*(deck - vehicle)[:2])
            near, far = self.FRAME_BOTH_M
            both = min(1.0, max(0.0, (far - apart) / (far - near)))  # 1 within near, 0 beyond far
            lookat = vehicle + both * self.TOWARDS_UGV * (deck - vehicle)
            distance += both * max(0.0, 3.5 + 1.2 * apart - self.MIN_DISTANCE_M)
        azimuth = 90.0 - math.degrees(pose.rpy_rad[2])  # MuJoCo's azimuth: from East towards North
        if self._t_s is None:
            self._lookat, self._distance, self._azimuth = lookat, distance, azimuth
        else:
            dt = max(0.0, t_s - self._t_s)
            a = 1.0 - math.exp(-dt / self.TAU_LOOKAT_S)
            self._lookat = self._lookat + a * (lookat - self._lookat)
            self._distance += (1.0 - math.exp(-dt / self.TAU_DISTANCE_S)) * (distance - self._distance)
            turn = (azimuth - self._azimuth + 180.0) % 360.0 - 180.0  # the short way round
            self._azimuth += (1.0 - math.exp(-dt / self.TAU_HEADING_S)) * turn
        self._t_s = t_s
        e, n, u = ned_to_enu(self._lookat).tolist()
        return ChaseView((e, n, u), self._distance, self._azimuth, self.ELEVATION_DEG)


class ReplayScene:
    """The flight's world (vehicle ``spec`` on its camera mount; the UGV with ``pad`` on its deck unless None) with
    a chase renderer of ``size`` (width, height px) and, when ``inset`` (width, height px) is given, the onboard
    camera's renderer of that size."""

    def __init__(
        self, spec: VehicleSpec, pad: PadLayout | None, size: tuple[int, int], inset: tuple[int, int] | None = None
    ) -> None:
        self.spec, self.geom = spec, UgvGeometry()
        self.model = _compile(spec, pad)
        width = max(size[0], inset[0] if inset else 0)
        height = max(size[1], inset[1] if inset else 0)
        self.model.vis.global_.offwidth = max(int(self.model.vis.global_.offwidth), width)
        self.model.vis.global_.offheight = max(int(self.model.vis.global_.offheight), height)
        self.data = mujoco.MjData(self.model)
        m = self.model
        self._root = int(m.jnt_qposadr[m.joint(part_name(0, "root")).id])
        self._ugv = int(m.jnt_qposadr[m.joint("ugv_root").id]) if pad is not None else None
        self._gimbal = None
        if spec.camera.gimballed:  # qpos addresses of the roll, pitch, yaw joints (the frame log's order)
            adr = {name: int(m.jnt_qposadr[m.joint(part_name(0, name)).id]) for name, _ in GIMBAL_JOINTS}
            self._gimbal = (adr["gimbal_roll"], adr["gimbal_pitch"], adr["gimbal_yaw"])
        self.chase = mujoco.Renderer(m, size[1], size[0])
        self._chase_option = mujoco.MjvOption()
        self._chase_option.geomgroup[GRID_GROUP] = 1
        self._camera = mujoco.MjvCamera()
        self._camera.type = mujoco.mjtCamera.mjCAMERA_FREE
        self.onboard = None
        if inset is not None and spec.camera.rate_hz > 0:
            self.onboard = mujoco.Renderer(m, inset[1], inset[0])
            self._onboard_camera = m.camera(part_name(0, "downward")).id
            self._onboard_option = mujoco.MjvOption()  # the default groups: the plain ground, as the simulator's

    def place(self, pose: Pose) -> None:
        """Put the bodies (and the gimbal's joints) where ``pose`` says; the kinematics and the camera poses after."""
        q, a = self.data.qpos, self._root
        q[a : a + 3] = ned_to_enu(np.array(pose.pos_ned_m, dtype=float))
        q[a + 3 : a + 7] = quat_ned_frd_to_enu_flu(from_euler(*pose.rpy_rad))
        if self._ugv is not None and pose.deck_ned_m is not None and np.all(np.isfinite(pose.deck_ned_m)):
            # The deck's centre is deck_top - wheel_radius above the UGV's body origin (the axle), the UGV level.
            above_axle_m = self.geom.deck_top_m - self.geom.wheel_radius_m
            origin = np.array(pose.deck_ned_m, dtype=float) + (0.0, 0.0, above_axle_m)
            u = self._ugv
            q[u : u + 3] = ned_to_enu(origin)
            q[u + 3 : u + 7] = quat_ned_frd_to_enu_flu(from_euler(0.0, 0.0, pose.ugv_yaw_rad))
        if self._gimbal is not None and pose.gimbal_rpy_rad is not None:
            for adr, angle in zip(self._gimbal, pose.gimbal_rpy_rad):
                if math.isfinite(angle):
                    q[adr] = angle
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)  # cameras and lights follow their bodies

    def render_chase(self, view: ChaseView) -> np.ndarray:
        """The chase view as RGB (height x width x 3, uint8)."""
        c = self._camera
        c.lookat[:] = view.lookat_enu_m
        c.distance, c.azimuth, c.elevation = view.distance_m, view.azimuth_deg, view.elevation_deg
        return _render(self.chase, self.data, c, self._chase_option)

    def render_onboard(self) -> np.ndarray | None:
        """The onboard camera's view as RGB (inset size), None when the scene has no inset."""
        if self.onboard is None:
            return None
        return _render(self.onboard, self.data, self._onboard_camera, self._onboard_option)

    def close(self) -> None:
        self.chase.close()
        if self.onboard is not None:
            self.onboard.close()


def _render(renderer: mujoco.Renderer, data: mujoco.MjData, camera, option: mujoco.MjvOption) -> np.ndarray:
    renderer.update_scene(data, camera=camera, scene_option=option)
    for flag in FAST_FLAGS:
        renderer.scene.flags[getattr(mujoco.mjtRndFlag, flag)] = 0
    return renderer.render()


def _compile(spec: VehicleSpec, pad: PadLayout | None) -> mujoco.MjModel:
    """The world's model (one multicopter at the origin, the UGV if ``pad``) with the chase view's ground grid.

    Inertia is balanced whatever the vehicle file says: nothing is simulated, only drawn."""
    ugv = ugv_mjcf(Pose2(0.0, 0.0, 0.0), pad=pad) if pad is not None else None
    mj = mujoco.MjSpec.from_string(build_world_mjcf([Placement(spec)], ugv), assets=ugv.assets if ugv else None)
    mj.compiler.balanceinertia = True
    mj.add_texture(
        name="replay_grid",
        type=mujoco.mjtTexture.mjTEXTURE_2D,
        builtin=mujoco.mjtBuiltin.mjBUILTIN_CHECKER,
        rgb1=list(GRID_RGB[0]),
        rgb2=list(GRID_RGB[1]),
        width=256,
        height=256,
    )
    material = mj.add_material(name="replay_grid", texuniform=True, texrepeat=[0.5 / GRID_SQUARE_M] * 2)
    material.textures[mujoco.mjtTextureRole.mjTEXROLE_RGB] = "replay_grid"
    mj.worldbody.add_geom(
        name="replay_grid",
        type=mujoco.mjtGeom.mjGEOM_PLANE,
        size=[500.0, 500.0, 0.1],
        pos=[0.0, 0.0, 0.001],  # a millimetre above the simulator's ground, which it hides in the chase view
        material="replay_grid",
        group=GRID_GROUP,
        contype=0,
        conaffinity=0,
    )
    return mj.compile()
