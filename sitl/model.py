"""Build the MuJoCo model (MJCF) of a vehicle from its vehicle file.

The vehicle file gives positions in body FRD; MuJoCo's body frame is FLU, so
every position is converted with :func:`sitl.frames.frd_to_flu`.  Each rotor is a
site with a ``general`` actuator whose gear is (0, 0, 1, 0, 0, -s k_M): the
control value is the rotor thrust T in newtons, pushing along the site's +z (up)
and giving the drag torque of [F eq. 4.9] about it (s = +1 for a rotor that
turns counter-clockwise seen from above, whose reaction turns the body clockwise).
"""

from __future__ import annotations

import math

import mujoco

from mavsim_core.constants import GRAVITY_M_S2, LOCKSTEP_DT_S
from mavsim_core.frames import frd_to_flu
from params.vehicle import VehicleSpec
from sitl.ugv import UgvMjcf, ugv_mjcf
from sitl.ugv_paths import Pose2

# One physics step per lockstep period (250 Hz).  MuJoCo's default contact time constant
# (0.02 s) needs a step of at most 0.01 s; rotor lag is integrated exactly (sitl.rotors).
PHYSICS_DT_S = LOCKSTEP_DT_S  # one MuJoCo step per lockstep period


def _v(x) -> str:
    return " ".join(f"{float(a):.6g}" for a in x)


def build_mjcf(spec: VehicleSpec, ugv: UgvMjcf | None = None) -> str:
    """Return the MJCF XML text of the world: ground plane and the vehicle.

    The vehicle starts on its legs facing North (body x along world +y, ENU).  ``ugv``
    (off by default) adds the ground vehicle's parts (:func:`sitl.ugv.ugv_mjcf`) after the
    vehicle's, so the vehicle's joint, actuator and sensor indices stay the same.
    """
    j = spec.inertia_kg_m2
    foot_depth_m = max(p[2] for p in spec.leg_positions_frd_m) + spec.leg_size_m[2] / 2
    geoms = [
        f'<geom name="frame" type="box" size="{_v(s / 2 for s in spec.body_size_m)}" '
        f'contype="1" conaffinity="1" mass="0" rgba="0.3 0.3 0.35 1"/>'
    ]
    for i, leg in enumerate(spec.leg_positions_frd_m):
        geoms.append(
            f'<geom name="leg{i + 1}" type="box" pos="{_v(frd_to_flu(leg))}" '
            f'size="{_v(s / 2 for s in spec.leg_size_m)}" mass="0" friction="0.8 0.01 0.001" rgba="0.2 0.2 0.2 1"/>'
        )
    sites = ['<site name="imu" pos="0 0 0" size="0.01"/>']
    cam = spec.camera
    if cam.rate_hz > 0:
        # MuJoCo's camera looks along its -z with image x right and y up: y = body forward (FLU +x),
        # z = body up, so it looks down with the top of the image towards the nose.
        fovy = math.degrees(2 * math.atan(math.tan(math.radians(cam.hfov_deg) / 2) * cam.height_px / cam.width_px))
        sites.append(
            f'<camera name="downward" pos="{_v(frd_to_flu(cam.position_frd_m))}" xyaxes="0 -1 0 1 0 0" '
            f'fovy="{fovy:.6g}"/>'
        )
    actuators = []
    for i, r in enumerate(spec.rotors):
        p = frd_to_flu(r.position_frd_m)
        colour = "0.1 0.6 0.1 0.6" if r.spin_ccw > 0 else "0.1 0.1 0.7 0.6"
        geoms.append(
            f'<geom name="prop{i + 1}" type="cylinder" pos="{_v(p)}" size="{spec.rotor_radius_m:.4g} 0.005" '
            f'contype="0" conaffinity="0" mass="0" rgba="{colour}"/>'
        )
        sites.append(f'<site name="rotor{i + 1}" pos="{_v(p)}" size="0.01"/>')
        actuators.append(
            f'<general name="rotor{i + 1}" site="rotor{i + 1}" ctrllimited="false" '
            f'gear="0 0 1 0 0 {-r.spin_ccw * spec.k_moment:.6g}"/>'
        )
    ugv_asset = f"\n  <asset>{ugv.asset}</asset>" if ugv else ""
    ugv_body = f"\n    {ugv.worldbody}" if ugv else ""
    ugv_actuators = f"\n{ugv.actuator}" if ugv else ""
    return f"""<mujoco model="{spec.name}">
  <option timestep="{PHYSICS_DT_S}" gravity="0 0 {-GRAVITY_M_S2}" integrator="implicitfast"/>
  <visual><global offwidth="{max(640, spec.camera.width_px)}" offheight="{max(480, spec.camera.height_px)}"/>
    <quality shadowsize="0" offsamples="0"/><map znear="0.0005"/></visual>{ugv_asset}
  <worldbody>
    <light pos="0 0 20" dir="0 0 -1" directional="true"/>
    <geom name="ground" type="plane" size="500 500 0.1" friction="1 0.01 0.001" rgba="0.5 0.6 0.5 1"/>
    <body name="vehicle" pos="0 0 {foot_depth_m + 0.001:.4f}" quat="0.70710678 0 0 0.70710678">
      <freejoint name="root"/>
      <inertial pos="0 0 0" mass="{spec.mass_kg:.6g}" diaginertia="{_v(j)}"/>
      {chr(10).join("      " + g for g in geoms)}
      {chr(10).join("      " + s for s in sites)}
    </body>{ugv_body}
  </worldbody>
  <actuator>
{chr(10).join("    " + a for a in actuators)}{ugv_actuators}
  </actuator>
  <sensor>
    <accelerometer name="accel" site="imu"/>
    <gyro name="gyro" site="imu"/>
  </sensor>
</mujoco>
"""


def build_model(spec: VehicleSpec, ugv_start: Pose2 | None = None) -> mujoco.MjModel:
    """Compile the MJCF and set the vehicle's inertia to the file's exactly.

    ``ugv_start`` (NED m, yaw rad; None, the default, leaves it out) adds the ground vehicle
    (:mod:`sitl.ugv`) there.

    [F]'s Firefly inertia, diag(0.0347563, 0.0458929, 0.0977), breaks the triangle
    inequality I_xx + I_yy >= I_zz that every real mass distribution satisfies, and MuJoCo's
    compiler refuses such a body.  The model is therefore compiled with ``balanceinertia``
    and the file's values are written into ``body_inertia`` afterwards: the rigid-body
    equations ([F eq. 4.5]) use J as given, which is what [F] specifies.
    """
    ugv = ugv_mjcf(ugv_start) if ugv_start is not None else None
    xml = build_mjcf(spec, ugv)
    j = spec.inertia_kg_m2
    if j[0] + j[1] < j[2] or j[0] + j[2] < j[1] or j[1] + j[2] < j[0]:
        xml = xml.replace("<option ", '<compiler balanceinertia="true"/>\n  <option ', 1)
    model = mujoco.MjModel.from_xml_string(xml, ugv.assets if ugv else None)
    model.body_inertia[model.body("vehicle").id] = j
    mujoco.mj_setConst(model, mujoco.MjData(model))  # recompute what the compiler derived from the inertia
    return model
