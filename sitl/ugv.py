"""The ground vehicle (UGV) in MuJoCo: a differential drive with a caster and an ArUco deck.

MuJoCo's frames (ENU world, FLU body) as in :mod:`sitl.model`; the pose and velocity this
module reports are NED (m, m/s, rad), converted only through :mod:`mavsim_core.frames`.
Two driven wheels on hinge joints (``velocity`` actuators, rad/s), a passive ball caster,
real contact with the ground, and a flat deck on top textured with the landing pad's ArUco markers
(:mod:`vision.pad`: by default four markers of ``DICT_ARUCO_ORIGINAL`` of the seed's 0.333 m around a small
one at the deck's centre; the pad frame is the UGV's body frame, x forward, y left) on white.  The texture is
drawn with OpenCV when the MJCF is built and encoded as PNG, handed to MuJoCo as an in-memory asset
(``from_xml_string(xml, assets)``), so no file is left behind.

Kinematics: v = r (w_l + w_r) / 2, yaw rate (FLU, positive left) = r (w_r - w_l) / b.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial

import cv2
import mujoco
import numpy as np

from mavsim_core.constants import GRAVITY_M_S2, LOCKSTEP_DT_S
from mavsim_core.frames import enu_to_ned, ned_to_enu, quat_enu_flu_to_ned_frd, quat_ned_frd_to_enu_flu
from mavsim_core.quaternion import yaw_of
from sitl.ugv_paths import PathTarget, Pose2, UgvLimits, UnicycleCommand, unicycle_command
from vision.marker import MARKER_BITS, MARKER_SIZE_M, dictionary
from vision.pad import NESTED_PAD, PadLayout

TEXEL_M = MARKER_SIZE_M / ((MARKER_BITS + 2) * 16)  # the deck texture's pixel: the seed marker's cell / 16


@dataclass(frozen=True)
class UgvGeometry:
    """Sizes in metres, masses in kg.  ``track_m`` is b, the distance between the wheels."""

    wheel_radius_m: float = 0.1
    track_m: float = 0.6
    wheel_x_m: float = 0.15  # axle ahead of the chassis centre (body x)
    caster_x_m: float = -0.3
    chassis_half_m: tuple[float, float, float] = (0.38, 0.26, 0.07)
    deck_side_m: float = 1.3  # the quadcopter's legs span 1.01 m: room for 15 cm of error each way
    chassis_mass_kg: float = 20.0
    wheel_mass_kg: float = 1.0

    @property
    def deck_top_m(self) -> float:
        """Height of the deck's top surface above the ground."""
        return self.wheel_radius_m + 0.05 + 2 * self.chassis_half_m[2] + 0.01


def pad_png(pad: PadLayout = NESTED_PAD, deck_side_m: float = UgvGeometry.deck_side_m) -> tuple[bytes, float]:
    """The deck texture as PNG bytes (the pad's markers on white) and the deck side it covers (m).

    One texel is :data:`TEXEL_M` (the seed marker's cell is 16 texels, so it is drawn exactly as before the pad
    had more markers); each marker is drawn ``round(size_m / TEXEL_M)`` texels wide at its offset rounded to a
    texel (the default pad's markers are whole texels and cells: 112 and 42 texels, 0.33 m = 110.99 texels).
    The image's right is the pad's +x (the UGV's forward), its top the pad's +y (the UGV's left).
    """
    seed_px = (MARKER_BITS + 2) * 16
    side_px = int(round(deck_side_m / TEXEL_M / 2)) * 2 + seed_px % 2
    img = np.full((side_px, side_px), 255, np.uint8)
    for m in pad.markers:
        px = int(round(m.size_m / TEXEL_M))
        if px < MARKER_BITS + 2:
            raise ValueError(f"marker {m.marker_id}: {m.size_m} m is less than a texel a cell on the deck")
        left = int(round(side_px / 2 + m.x_m / TEXEL_M - px / 2))
        top = int(round(side_px / 2 - m.y_m / TEXEL_M - px / 2))
        if left < 0 or top < 0 or left + px > side_px or top + px > side_px:
            raise ValueError(f"marker {m.marker_id} does not fit on the {deck_side_m:g} m deck")
        img[top : top + px, left : left + px] = cv2.aruco.generateImageMarker(dictionary(), m.marker_id, px)
    ok, png = cv2.imencode(".png", cv2.cvtColor(img, cv2.COLOR_GRAY2BGR))
    if not ok:
        raise RuntimeError("OpenCV could not encode the deck texture as PNG")
    return png.tobytes(), side_px * TEXEL_M


def _v(x) -> str:
    return " ".join(f"{float(a):.6g}" for a in x)


def ugv_part(k: int, name: str) -> str:
    """The MJCF name of ground vehicle ``k``'s part ``name`` ("ugv", "ugv_root", "ugv_deck", "ugv_wheel_left", its
    texture's files ...): UGV 0 keeps the bare names (a world with one UGV is as before, name for name), UGV k >= 1
    has them prefixed ``v<k>_`` (the UGV of vehicle k of a world of several, as :func:`sitl.model.part_name`)."""
    return name if k == 0 else f"v{k}_{name}"


@dataclass(frozen=True)
class UgvMjcf:
    """MJCF fragments to merge into a world: ``asset``, ``worldbody`` and ``actuator`` children.

    ``assets`` are the PNG files the ``asset`` part names, to pass to
    ``mujoco.MjModel.from_xml_string(xml, assets)`` (nothing is written to disk).
    """

    asset: str
    worldbody: str
    actuator: str
    assets: dict[str, bytes]


def ugv_mjcf(start: Pose2, geom: UgvGeometry = UgvGeometry(), pad: PadLayout = NESTED_PAD, k: int = 0) -> UgvMjcf:
    """UGV ``k``'s MJCF parts (names :func:`ugv_part`), its body ``ugv`` at ``start`` (NED m from the world's origin,
    yaw rad) on the ground, ``pad`` on its deck."""
    n = partial(ugv_part, k)
    deck_png, white_png = n("ugv_deck_pad.png"), n("ugv_white.png")
    deck_bytes, deck = pad_png(pad, geom.deck_side_m)
    side_px = cv2.imdecode(np.frombuffer(deck_bytes, np.uint8), cv2.IMREAD_GRAYSCALE).shape[0]
    white = cv2.imencode(".png", np.full((side_px, side_px, 3), 255, np.uint8))[1].tobytes()  # cube faces: same size
    g, r = geom, geom.wheel_radius_m
    pos = ned_to_enu(np.array([start.north_m, start.east_m, 0.0]))
    pos[2] = r
    q = quat_ned_frd_to_enu_flu(np.array([math.cos(start.yaw_rad / 2), 0.0, 0.0, math.sin(start.yaw_rad / 2)]))
    ch = g.chassis_half_m
    chassis_z = 0.05 + ch[2]  # 5 cm above the axle; the deck (1 cm) on top: deck_top_m
    deck_z = chassis_z + ch[2] + 0.005
    # MuJoCo's cube texture puts "front" on the box's +z (top) face: the marker looks up.
    asset = (
        f'<texture name="{n("ugv_deck")}" type="cube" fileup="{white_png}" filedown="{white_png}" '
        f'fileleft="{white_png}" fileright="{white_png}" filefront="{deck_png}" fileback="{white_png}"/>\n'
        f'<material name="{n("ugv_deck")}" texture="{n("ugv_deck")}" rgba="1 1 1 1" specular="0" shininess="0"/>'
    )
    wheels = []
    for side, y in (("left", g.track_m / 2), ("right", -g.track_m / 2)):
        wheels.append(
            f'<body name="{n(f"ugv_wheel_{side}")}" pos="{g.wheel_x_m:.4g} {y:.4g} 0">'
            f'<joint name="{n(f"ugv_wheel_{side}")}" type="hinge" axis="0 1 0" damping="0.01"/>'
            f'<geom type="cylinder" size="{r:.4g} 0.025" quat="0.70710678 0.70710678 0 0" '
            f'mass="{g.wheel_mass_kg:.4g}" friction="1.2 0.01 0.001" rgba="0.1 0.1 0.1 1"/></body>'
        )
    caster_r = 0.05
    worldbody = f"""<body name="{n("ugv")}" pos="{_v(pos)}" quat="{_v(q)}">
  <freejoint name="{n("ugv_root")}"/>
  <geom name="{n("ugv_chassis")}" type="box" pos="0 0 {chassis_z:.4g}" size="{_v(ch)}" mass="{g.chassis_mass_kg:.4g}"
        rgba="0.7 0.5 0.1 1"/>
  <geom name="{n("ugv_deck")}" type="box" pos="0 0 {deck_z:.4g}" size="{deck / 2:.5g} {deck / 2:.5g} 0.005" mass="0.5"
        material="{n("ugv_deck")}" friction="1 0.01 0.001"/>
  {"".join(wheels)}
  <body name="{n("ugv_caster")}" pos="{g.caster_x_m:.4g} 0 {caster_r - r:.4g}">
    <joint name="{n("ugv_caster")}" type="ball" damping="0.001"/>
    <geom type="sphere" size="{caster_r}" mass="0.2" friction="0.5 0.005 0.0001" rgba="0.6 0.6 0.6 1"/>
  </body>
</body>"""
    actuator = "\n".join(
        f'<velocity name="{n(f"ugv_wheel_{s}")}" joint="{n(f"ugv_wheel_{s}")}" kv="{20.0:.4g}" ctrllimited="true" '
        f'ctrlrange="-60 60" forcelimited="true" forcerange="-20 20"/>'
        for s in ("left", "right")
    )
    return UgvMjcf(asset, worldbody, actuator, {deck_png: deck_bytes, white_png: white})


def build_ugv_world(start: Pose2, pad: PadLayout = NESTED_PAD) -> mujoco.MjModel:
    """A world with only the ground plane and the UGV (tests, tools); 4 ms step as :mod:`sitl.model`."""
    parts = ugv_mjcf(start, pad=pad)
    xml = f"""<mujoco model="ugv_world">
  <option timestep="{LOCKSTEP_DT_S}" gravity="0 0 {-GRAVITY_M_S2}" integrator="implicitfast"/>
  <visual><global offwidth="640" offheight="480"/><quality shadowsize="0" offsamples="0"/></visual>
  <asset>{parts.asset}</asset>
  <worldbody>
    <light pos="0 0 20" dir="0 0 -1" directional="true"/>
    <geom name="ground" type="plane" size="500 500 0.1" friction="1 0.01 0.001" rgba="0.5 0.6 0.5 1"/>
    {parts.worldbody}
  </worldbody>
  <actuator>{parts.actuator}</actuator>
</mujoco>"""
    return mujoco.MjModel.from_xml_string(xml, parts.assets)


@dataclass(frozen=True)
class UgvState:
    """True state in NED: position (m), velocity (m/s), attitude quaternion FRD->NED (w,x,y,z), yaw (rad)."""

    position_ned_m: np.ndarray
    velocity_ned_m_s: np.ndarray
    quat_ned_frd: np.ndarray
    yaw_rad: float

    @property
    def pose(self) -> Pose2:
        return Pose2(float(self.position_ned_m[0]), float(self.position_ned_m[1]), self.yaw_rad)


def wheel_speeds(cmd: UnicycleCommand, geom: UgvGeometry = UgvGeometry()) -> tuple[float, float]:
    """Wheel rates (rad/s, left, right) for a speed (m/s) and a NED yaw rate (rad/s, + turns right)."""
    w_flu = -cmd.yaw_rate_rad_s  # FLU yaw rate is positive to the left
    b, r = geom.track_m, geom.wheel_radius_m
    return (cmd.speed_m_s - w_flu * b / 2) / r, (cmd.speed_m_s + w_flu * b / 2) / r


class UgvDrive:
    """Slew-limits a unicycle command to the acceleration limits and turns it into wheel rates."""

    def __init__(self, limits: UgvLimits = UgvLimits(), geom: UgvGeometry = UgvGeometry()) -> None:
        self.limits, self.geom = limits, geom
        self._v = 0.0

    def wheels(self, cmd: UnicycleCommand, dt_s: float) -> tuple[float, float]:
        """Wheel rates (rad/s) for ``cmd`` after ``dt_s`` seconds since the last call."""
        dv = self.limits.accel_m_s2 * dt_s
        self._v = min(max(cmd.speed_m_s, self._v - dv), self._v + dv)
        return wheel_speeds(UnicycleCommand(self._v, cmd.yaw_rate_rad_s), self.geom)


class Ugv:
    """The UGV inside a MuJoCo model: follows a path (time as input) and reports its truth in NED."""

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, limits: UgvLimits = UgvLimits(), k: int = 0) -> None:
        self.model, self.data, self.limits = model, data, limits
        self.drive = UgvDrive(limits)
        self._body = model.body(ugv_part(k, "ugv")).id
        self._act = (
            model.actuator(ugv_part(k, "ugv_wheel_left")).id,
            model.actuator(ugv_part(k, "ugv_wheel_right")).id,
        )

    def state(self) -> UgvState:
        """True pose and velocity of the ``ugv`` body (its origin, at axle height)."""
        d, b = self.data, self._body
        q = quat_enu_flu_to_ned_frd(np.array(d.xquat[b]))
        vel6 = np.zeros(6)
        mujoco.mj_objectVelocity(self.model, d, mujoco.mjtObj.mjOBJ_BODY, b, vel6, 0)
        return UgvState(enu_to_ned(d.xpos[b]), enu_to_ned(vel6[3:]), q, yaw_of(q))

    def pose(self) -> Pose2:
        """``state().pose`` without the velocity (the path follower's input, every step): the same numbers."""
        d, b = self.data, self._body
        x, y = d.xpos[b][:2]
        return Pose2(float(y), float(x), yaw_of(quat_enu_flu_to_ned_frd(np.array(d.xquat[b]))))

    def command(self, cmd: UnicycleCommand, dt_s: float = LOCKSTEP_DT_S) -> None:
        """Set the wheel actuators for ``cmd`` (call once per physics step of ``dt_s``)."""
        left, right = self.drive.wheels(cmd, dt_s)
        self.data.ctrl[self._act[0]], self.data.ctrl[self._act[1]] = left, right

    def command_for(self, target: PathTarget) -> UnicycleCommand:
        """The command that tracks ``target`` (from :meth:`sitl.ugv_paths.UgvPath.target`) from the pose now."""
        return unicycle_command(target, self.pose(), self.limits)

    def follow(self, target: PathTarget, dt_s: float = LOCKSTEP_DT_S) -> UnicycleCommand:
        """Track ``target``: :meth:`command_for`, applied; return the command used."""
        cmd = self.command_for(target)
        self.command(cmd, dt_s)
        return cmd
