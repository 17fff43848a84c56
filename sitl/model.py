"""Build the MuJoCo model (MJCF) of a world from vehicle files: one multicopter, or several side by side.

The vehicle file gives positions in body FRD; MuJoCo's body frame is FLU, so
every position is converted with :func:`sitl.frames.frd_to_flu`.  Each rotor is a
site with a ``general`` actuator whose gear is (0, 0, 1, 0, 0, -s k_M): the
control value is the rotor thrust T in newtons, pushing along the site's +z (up)
and giving the drag torque of [F eq. 4.9] about it (s = +1 for a rotor that
turns counter-clockwise seen from above, whose reaction turns the body clockwise).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from functools import partial
from typing import Sequence

import mujoco

from mavsim_core.constants import GRAVITY_M_S2, LOCKSTEP_DT_S
from mavsim_core.frames import frd_to_flu
from params.vehicle import VehicleSpec
from sitl.ugv import UgvMjcf, ugv_mjcf
from sitl.ugv_paths import Pose2
from vision.pad import NESTED_PAD, PadLayout

# One physics step per lockstep period (250 Hz).  MuJoCo's default contact time constant
# (0.02 s) needs a step of at most 0.01 s; rotor lag is integrated exactly (sitl.rotors).
PHYSICS_DT_S = LOCKSTEP_DT_S  # one MuJoCo step per lockstep period


def _v(x) -> str:
    return " ".join(f"{float(a):.6g}" for a in x)


def part_name(k: int, name: str) -> str:
    """The MJCF name of vehicle ``k``'s part ``name`` ("vehicle", "root", "imu", "rotor1", "accel", "downward",
    ...): vehicle 0 keeps the bare names (a one-vehicle world is the single-vehicle model, name for name),
    vehicle k >= 1 has them prefixed ``v<k>_``."""
    return name if k == 0 else f"v{k}_{name}"


@dataclass(frozen=True)
class Placement:
    """One multicopter of a world: its vehicle file and where it starts, ENU metres (East, North) from the
    world's origin (vehicle 0's spot), on its legs facing North."""

    spec: VehicleSpec
    offset_en_m: tuple[float, float] = (0.0, 0.0)


def _vehicle_parts(k: int, place: Placement) -> tuple[str, list[str], list[str]]:
    """Vehicle ``k``'s body (MJCF text), its rotor actuators and its IMU sensors."""
    spec, n = place.spec, partial(part_name, k)
    j = spec.inertia_kg_m2
    foot_depth_m = max(p[2] for p in spec.leg_positions_frd_m) + spec.leg_size_m[2] / 2
    geoms = [
        f'<geom name="{n("frame")}" type="box" size="{_v(s / 2 for s in spec.body_size_m)}" '
        f'contype="1" conaffinity="1" mass="0" rgba="0.3 0.3 0.35 1"/>'
    ]
    for i, leg in enumerate(spec.leg_positions_frd_m):
        geoms.append(
            f'<geom name="{n(f"leg{i + 1}")}" type="box" pos="{_v(frd_to_flu(leg))}" '
            f'size="{_v(s / 2 for s in spec.leg_size_m)}" mass="0" friction="0.8 0.01 0.001" rgba="0.2 0.2 0.2 1"/>'
        )
    sites = [f'<site name="{n("imu")}" pos="0 0 0" size="0.01"/>']
    cam = spec.camera
    actuators = []
    if cam.rate_hz > 0:
        fovy = math.degrees(2 * math.atan(math.tan(math.radians(cam.hfov_deg) / 2) * cam.height_px / cam.width_px))
        if cam.gimballed:
            sites.append(_gimbal_body(k, cam, fovy))
        else:
            # MuJoCo's camera looks along its -z with image x right and y up: y = body forward (FLU +x),
            # z = body up, so it looks down with the top of the image towards the nose.
            sites.append(
                f'<camera name="{n("downward")}" pos="{_v(frd_to_flu(cam.position_frd_m))}" xyaxes="0 -1 0 1 0 0" '
                f'fovy="{fovy:.6g}"/>'
            )
    for i, r in enumerate(spec.rotors):
        p = frd_to_flu(r.position_frd_m)
        colour = "0.1 0.6 0.1 0.6" if r.spin_ccw > 0 else "0.1 0.1 0.7 0.6"
        geoms.append(
            f'<geom name="{n(f"prop{i + 1}")}" type="cylinder" pos="{_v(p)}" size="{spec.rotor_radius_m:.4g} 0.005" '
            f'contype="0" conaffinity="0" mass="0" rgba="{colour}"/>'
        )
        sites.append(f'<site name="{n(f"rotor{i + 1}")}" pos="{_v(p)}" size="0.01"/>')
        actuators.append(
            f'<general name="{n(f"rotor{i + 1}")}" site="{n(f"rotor{i + 1}")}" ctrllimited="false" '
            f'gear="0 0 1 0 0 {-r.spin_ccw * spec.k_moment:.6g}"/>'
        )
    if cam.gimballed:  # after the rotors: each vehicle's rotor actuators stay contiguous
        actuators += _gimbal_actuators(k, cam.gimbal)
    e, north = place.offset_en_m
    body = f"""<body name="{n("vehicle")}" pos="{e:.6g} {north:.6g} {foot_depth_m + 0.001:.4f}" \
quat="0.70710678 0 0 0.70710678">
      <freejoint name="{n("root")}"/>
      <inertial pos="0 0 0" mass="{spec.mass_kg:.6g}" diaginertia="{_v(j)}"/>
      {chr(10).join("      " + g for g in geoms)}
      {chr(10).join("      " + s for s in sites)}
    </body>"""
    imu = n("imu")
    sensors = [f'<accelerometer name="{n("accel")}" site="{imu}"/>', f'<gyro name="{n("gyro")}" site="{imu}"/>']
    return body, actuators, sensors


# The gimbal's joints from the frame out: (name, hinge axis in body FLU for a positive angle about FRD's x, y or z).
GIMBAL_JOINTS = (("gimbal_yaw", "0 0 -1"), ("gimbal_roll", "1 0 0"), ("gimbal_pitch", "0 -1 0"))
# Each gimbal link: nearly massless (the vehicle file's mass already holds the camera), with the motor's reflected
# inertia as joint armature; the position servo's gain and damping put its own response at ~100 rad/s, well inside
# what a 4 ms step integrates, so the vehicle file's time constant (the servo input's filter) sets the response.
GIMBAL_LINK_MASS_KG = 1e-5
GIMBAL_ARMATURE_KG_M2 = 1e-5
GIMBAL_KP_NM_RAD = 0.1
GIMBAL_KV_NM_S_RAD = 2e-3


def _gimbal_body(k: int, cam, fovy_deg: float) -> str:
    """The 3-axis gimbal under vehicle ``k`` (yaw, roll, pitch links from the frame out, pivot at the camera's
    position) carrying the ``downward`` camera.  At zero angles the camera looks forward along body x, image top
    up (PX4's pitch 0); a pitch of -90 deg looks straight down with the top of the image towards the nose."""
    n, g = partial(part_name, k), cam.gimbal
    ranges = {"gimbal_yaw": g.yaw_range_deg, "gimbal_roll": g.roll_range_deg, "gimbal_pitch": g.pitch_range_deg}
    inertial = f'<inertial pos="0 0 0" mass="{GIMBAL_LINK_MASS_KG:g}" diaginertia="1e-9 1e-9 1e-9"/>'
    # MuJoCo's camera looks along its -z, image x right and y up: x = body right (FLU -y), y = body up.
    camera = f'<camera name="{n("downward")}" pos="0 0 0" xyaxes="0 -1 0 0 0 1" fovy="{fovy_deg:.6g}"/>'
    look = '<geom type="box" size="0.02 0.015 0.015" contype="0" conaffinity="0" mass="0" rgba="0.1 0.1 0.1 1"/>'
    inner = f"{look}{camera}"
    for name, axis in reversed(GIMBAL_JOINTS):
        lo, hi = ranges[name]
        joint = (
            f'<joint name="{n(name)}" type="hinge" axis="{axis}" limited="true" range="{lo:g} {hi:g}" '
            f'armature="{GIMBAL_ARMATURE_KG_M2:g}"/>'
        )
        pos = f' pos="{_v(frd_to_flu(cam.position_frd_m))}"' if name == "gimbal_yaw" else ""
        inner = f'<body name="{n(name)}"{pos}>{joint}{inertial}{inner}</body>'
    return inner


def _gimbal_actuators(k: int, g) -> list[str]:
    """Position servos of the gimbal's joints (setpoint in rad, through the first-order filter ``timeconst``)."""
    return [
        f'<position name="{part_name(k, name)}" joint="{part_name(k, name)}" kp="{GIMBAL_KP_NM_RAD:g}" '
        f'kv="{GIMBAL_KV_NM_S_RAD:g}" timeconst="{g.time_constant_s:g}"/>'
        for name, _ in GIMBAL_JOINTS
    ]


def build_world_mjcf(vehicles: Sequence[Placement], ugv: UgvMjcf | Sequence[UgvMjcf] | None = None) -> str:
    """Return the MJCF XML text of a world: ground plane, the multicopters, the ground vehicle.

    Each vehicle starts on its legs facing North (body x along world +y, ENU) at its placement.
    Vehicle k's joint, actuators and sensors come after vehicle k-1's, so vehicle 0's indices are
    those of a one-vehicle world; ``ugv`` (off by default) adds the ground vehicle's parts
    (:func:`sitl.ugv.ugv_mjcf`) after all of them; a sequence of them: several ground vehicles (each its own names).
    """
    ugvs = [] if ugv is None else [ugv] if isinstance(ugv, UgvMjcf) else list(ugv)
    parts = [_vehicle_parts(k, place) for k, place in enumerate(vehicles)]
    bodies = "\n    ".join(b for b, _, _ in parts)
    actuators = [a for _, acts, _ in parts for a in acts]
    sensors = [s for _, _, sens in parts for s in sens]
    first = vehicles[0].spec
    width = max(640, *(v.spec.camera.width_px for v in vehicles))
    height = max(480, *(v.spec.camera.height_px for v in vehicles))
    ugv_asset = f"\n  <asset>{''.join(u.asset for u in ugvs)}</asset>" if ugvs else ""
    ugv_body = "".join(f"\n    {u.worldbody}" for u in ugvs)
    ugv_actuators = "".join(f"\n{u.actuator}" for u in ugvs)
    return f"""<mujoco model="{first.name}">
  <option timestep="{PHYSICS_DT_S}" gravity="0 0 {-GRAVITY_M_S2}" integrator="implicitfast"/>
  <visual><global offwidth="{width}" offheight="{height}"/>
    <quality shadowsize="0" offsamples="0"/><map znear="0.0005"/></visual>{ugv_asset}
  <worldbody>
    <light pos="0 0 20" dir="0 0 -1" directional="true"/>
    <geom name="ground" type="plane" size="500 500 0.1" friction="1 0.01 0.001" rgba="0.5 0.6 0.5 1"/>
    {bodies}{ugv_body}
  </worldbody>
  <actuator>
{chr(10).join("    " + a for a in actuators)}{ugv_actuators}
  </actuator>
  <sensor>
{chr(10).join("    " + s for s in sensors)}
  </sensor>
</mujoco>
"""


def build_mjcf(spec: VehicleSpec, ugv: UgvMjcf | None = None) -> str:
    """The MJCF XML text of a one-vehicle world (:func:`build_world_mjcf`): ground plane and the vehicle."""
    return build_world_mjcf([Placement(spec)], ugv)


def build_model(spec: VehicleSpec, ugv_start: Pose2 | None = None) -> mujoco.MjModel:
    """The one-vehicle world of ``spec`` (:func:`build_world_model`); ``ugv_start`` as there."""
    return build_world_model([Placement(spec)], ugv_start)


def build_world_model(
    vehicles: Sequence[Placement],
    ugv_start: Pose2 | None = None,
    pad: PadLayout = NESTED_PAD,
    *,
    ugvs: Sequence[tuple[Pose2, PadLayout]] | None = None,
) -> mujoco.MjModel:
    """Compile the MJCF and set each vehicle's inertia to its file's exactly.

    ``ugv_start`` (NED m from vehicle 0's spot, yaw rad; None, the default, leaves it out) adds the ground
    vehicle (:mod:`sitl.ugv`) there, the landing pad ``pad`` (:mod:`vision.pad`) on its deck.  ``ugvs`` instead
    adds several: ground vehicle k (names :func:`sitl.ugv.ugv_part`) at its start pose (NED m from vehicle 0's
    spot, yaw rad) with its own pad.

    [F]'s Firefly inertia, diag(0.0347563, 0.0458929, 0.0977), breaks the triangle
    inequality I_xx + I_yy >= I_zz that every real mass distribution satisfies, and MuJoCo's
    compiler refuses such a body.  The model is therefore compiled with ``balanceinertia``
    and the file's values are written into ``body_inertia`` afterwards: the rigid-body
    equations ([F eq. 4.5]) use J as given, which is what [F] specifies.
    """
    if ugvs is None:
        ugvs = [(ugv_start, pad)] if ugv_start is not None else []
    parts = [ugv_mjcf(start, pad=pad_k, k=k) for k, (start, pad_k) in enumerate(ugvs)]
    xml = build_world_mjcf(vehicles, parts)
    if any(_unbalanced(v.spec.inertia_kg_m2) for v in vehicles):
        xml = xml.replace("<option ", '<compiler balanceinertia="true"/>\n  <option ', 1)
    assets = {name: png for u in parts for name, png in u.assets.items()}
    model = mujoco.MjModel.from_xml_string(xml, assets or None)
    for k, v in enumerate(vehicles):
        model.body_inertia[model.body(part_name(k, "vehicle")).id] = v.spec.inertia_kg_m2
    mujoco.mj_setConst(model, mujoco.MjData(model))  # recompute what the compiler derived from the inertia
    return model


def _unbalanced(j) -> bool:
    """True if a diagonal inertia breaks the triangle inequality (MuJoCo's compiler would refuse it)."""
    return j[0] + j[1] < j[2] or j[0] + j[2] < j[1] or j[1] + j[2] < j[0]
