"""The camera gimbal in the simulator: a 3-axis gimbal device that holds the camera where it is told to look.

The gimbal's joints, from the frame out, are yaw, roll and pitch (:data:`sitl.model.GIMBAL_JOINTS`), so its
rotation from the body is R_bg = Rz(yaw) Rx(roll) Ry(pitch) (FRD, right-handed; the gimbal frame's x is the
optical axis, y the image's right, z the image's down: PX4's gimbal frame).  Its own controller, like a real
gimbal's, reads the airframe's attitude (here the truth, as the gimbal's IMU would measure it), turns the wanted
camera attitude into joint angles, holds them inside the joints' ranges, moves the setpoint no faster than the
vehicle file's ``max_rate_deg_s`` and hands it to MuJoCo's position servos (whose ``timeconst`` is the motors'
first-order response, :mod:`sitl.model`).

A setpoint (:class:`GimbalSetpoint`) is what gimbal protocol v2's GIMBAL_DEVICE_SET_ATTITUDE carries: roll, pitch
and yaw of the camera (rad); roll and pitch in the earth frame (locked to the horizon), yaw either relative to
the vehicle's heading (follow, PX4's default) or in the earth frame (lock, from North).  With no setpoint it
holds the vehicle file's neutral pitch (down for the landing camera), level, facing the vehicle's heading.

Frames: NED world, FRD body, radians.  Time is an input.  Pure floats on the hot path (250 Hz).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import mujoco

from mavsim_core import quaternion
from params.vehicle import GimbalSpec
from sitl.model import GIMBAL_JOINTS, part_name

Rows = tuple[tuple[float, float, float], tuple[float, float, float], tuple[float, float, float]]


@dataclass(frozen=True, slots=True)
class GimbalSetpoint:
    """The camera's wanted attitude: ``rows`` takes the gimbal frame to the earth frame (NED) when ``yaw_earth``,
    else to the vehicle's heading frame (NED turned by the vehicle's yaw: roll and pitch still to the horizon,
    yaw relative to the nose), as GIMBAL_DEVICE_SET_ATTITUDE's quaternion with or without YAW_LOCK.  A rotation,
    not Euler angles: looking straight down, roll and yaw are one rotation and angles would not say which."""

    rows: Rows
    yaw_earth: bool = False

    @staticmethod
    def from_angles(roll_rad: float, pitch_rad: float, yaw_rad: float, yaw_earth: bool = False) -> GimbalSetpoint:
        """From ZYX Euler angles (rad; PX4's signs: pitch down negative, yaw right positive)."""
        return GimbalSetpoint(earth_rotation(roll_rad, pitch_rad, yaw_rad), yaw_earth)

    @staticmethod
    def from_quaternion(q_wxyz, yaw_earth: bool = False) -> GimbalSetpoint:
        """From a (w, x, y, z) quaternion (normalised here); ValueError if it is not finite or zero."""
        w, x, y, z = (float(c) for c in q_wxyz)
        n = math.sqrt(w * w + x * x + y * y + z * z)
        if not math.isfinite(n) or n < 1e-6:
            raise ValueError("gimbal attitude: the quaternion is not finite or zero")
        return GimbalSetpoint(_rows(quaternion.to_matrix((w / n, x / n, y / n, z / n))), yaw_earth)


def body_yaw_rad(r_ned_frd: Rows) -> float:
    """The vehicle's heading (ZYX yaw, rad, from North toward East) from its FRD -> NED rotation rows."""
    return math.atan2(r_ned_frd[1][0], r_ned_frd[0][0])


def earth_rotation(roll: float, pitch: float, yaw: float) -> Rows:
    """Rz(yaw) Ry(pitch) Rx(roll) as rows: the gimbal frame -> NED for ZYX Euler angles (rad)."""
    return _rows(quaternion.to_matrix(quaternion.from_euler(roll, pitch, yaw)))


def _rows(m) -> Rows:
    """A 3x3 array as a tuple of float rows."""
    return tuple(tuple(float(x) for x in r) for r in m)  # type: ignore[return-value]


def _mul(a: Rows, b: Rows) -> Rows:
    """a b for 3x3 matrices given as rows."""
    return tuple(  # type: ignore[return-value]
        tuple(sum(a[i][k] * b[k][j] for k in range(3)) for j in range(3)) for i in range(3)
    )


def joint_rotation(yaw: float, roll: float, pitch: float) -> Rows:
    """R_bg = Rz(yaw) Rx(roll) Ry(pitch) as rows: the gimbal frame -> body FRD for joint angles (rad)."""
    ca, sa, cb, sb, cc, sc = (
        math.cos(yaw),
        math.sin(yaw),
        math.cos(roll),
        math.sin(roll),
        math.cos(pitch),
        math.sin(pitch),
    )
    return (
        (ca * cc - sa * sb * sc, -sa * cb, ca * sc + sa * sb * cc),
        (sa * cc + ca * sb * sc, ca * cb, sa * sc - ca * sb * cc),
        (-cb * sc, sb, cb * cc),
    )


def joint_angles_for(r_bg: Rows) -> tuple[float, float, float]:
    """(yaw, roll, pitch) joint angles (rad) of a gimbal-to-body rotation R_bg = Rz Rx Ry (rows)."""
    roll = math.asin(max(-1.0, min(1.0, r_bg[2][1])))
    return math.atan2(-r_bg[0][1], r_bg[1][1]), roll, math.atan2(-r_bg[2][0], r_bg[2][2])


def wanted_joint_angles(r_ned_frd: Rows, sp: GimbalSetpoint) -> tuple[float, float, float]:
    """The joint angles (yaw, roll, pitch; rad, not yet limited) that put the camera at ``sp`` on a vehicle whose
    attitude is ``r_ned_frd`` (FRD -> NED rows): those of R_bg = R_nb^T R_ng (:func:`joint_angles_for`), of which
    only five elements are needed, each a dot product of a column of R_nb with one of R_ng (written out: this
    runs every lockstep period)."""
    (a00, a01, a02), (a10, a11, a12), (a20, a21, a22) = r_ned_frd
    (g00, g01, g02), (g10, g11, g12), (g20, g21, g22) = sp.rows
    if not sp.yaw_earth:  # R_ng = Rz(heading) R_sp
        h = math.atan2(a10, a00)
        c, s = math.cos(h), math.sin(h)
        g00, g01, g02, g10, g11, g12 = (
            c * g00 - s * g10, c * g01 - s * g11, c * g02 - s * g12,
            s * g00 + c * g10, s * g01 + c * g11, s * g02 + c * g12,
        )  # fmt: skip
    b01 = a00 * g01 + a10 * g11 + a20 * g21
    b11 = a01 * g01 + a11 * g11 + a21 * g21
    b20 = a02 * g00 + a12 * g10 + a22 * g20
    b21 = a02 * g01 + a12 * g11 + a22 * g21
    b22 = a02 * g02 + a12 * g12 + a22 * g22
    return math.atan2(-b01, b11), math.asin(max(-1.0, min(1.0, b21))), math.atan2(-b20, b22)


def camera_attitude(r_ned_frd: Rows, joints: tuple[float, float, float]) -> Rows:
    """The gimbal frame -> NED (rows) of a vehicle attitude and joint angles (yaw, roll, pitch; rad)."""
    return _mul(r_ned_frd, joint_rotation(*joints))


# OpenCV's camera frame (x image right, y image down, z optical axis) -> the gimbal frame (x optical axis, y right,
# z down): the columns are the camera's axes in the gimbal frame.
GIMBAL_FROM_CAMERA = ((0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0))


def camera_to_body(joints: tuple[float, float, float]) -> Rows:
    """OpenCV's camera frame -> body FRD (rows) for the gimbal's joint angles (yaw, roll, pitch; rad): what the
    vision companion's :class:`vision.landing_target.CameraMount` takes.  At (0, 0, -90 deg) it is the fixed
    downward camera's rotation."""
    return _mul(joint_rotation(*joints), GIMBAL_FROM_CAMERA)


class Gimbal:
    """Vehicle ``k``'s gimbal device in a compiled world: its joints' limits and setpoint slew, its servos' inputs.

    :meth:`step` once per lockstep period with the vehicle's attitude; :attr:`setpoint` is what it holds
    (:class:`GimbalSetpoint`; ``None``: the neutral, down).  :meth:`joints` reads the encoders (rad).
    """

    def __init__(self, model: mujoco.MjModel, k: int, spec: GimbalSpec) -> None:
        self.spec = spec
        names = [part_name(k, name) for name, _ in GIMBAL_JOINTS]
        jids = [model.joint(n).id for n in names]
        self._qadr = [int(model.jnt_qposadr[j]) for j in jids]
        self._vadr = [int(model.jnt_dofadr[j]) for j in jids]
        self._act = [model.actuator(n).id for n in names]
        self._actadr = [int(model.actuator_actadr[a]) for a in self._act]
        rad = math.radians
        self.limits = tuple(
            (rad(lo), rad(hi)) for lo, hi in (spec.yaw_range_deg, spec.roll_range_deg, spec.pitch_range_deg)
        )
        self.max_rate_rad_s = rad(spec.max_rate_deg_s)
        self.neutral = GimbalSetpoint.from_angles(0.0, rad(spec.neutral_pitch_deg), 0.0)
        self.setpoint: GimbalSetpoint | None = None
        self.command = (0.0, 0.0, rad(spec.neutral_pitch_deg))  # the servos' setpoint (yaw, roll, pitch), rad
        self.at_limit = False  # the latest wanted attitude needed a joint beyond its range

    def place(self, data: mujoco.MjData, r_ned_frd: Rows) -> None:
        """Put the joints, the servos' filters and their setpoints where the setpoint wants them (start-up)."""
        self.command = self._limited(wanted_joint_angles(r_ned_frd, self.setpoint or self.neutral))
        for i, angle in enumerate(self.command):
            data.qpos[self._qadr[i]] = angle
            data.qvel[self._vadr[i]] = 0.0
            data.ctrl[self._act[i]] = angle
            if self._actadr[i] >= 0:
                data.act[self._actadr[i]] = angle

    def step(self, data: mujoco.MjData, r_ned_frd: Rows, dt_s: float) -> None:
        """One control period: the wanted joint angles for the vehicle's attitude, limited, slewed, to the servos."""
        wanted = self._limited(wanted_joint_angles(r_ned_frd, self.setpoint or self.neutral))
        step = self.max_rate_rad_s * dt_s
        (c0, c1, c2), (w0, w1, w2) = self.command, wanted
        cmd = (
            c0 + max(-step, min(step, w0 - c0)),
            c1 + max(-step, min(step, w1 - c1)),
            c2 + max(-step, min(step, w2 - c2)),
        )
        self.command = cmd
        ctrl, (a0, a1, a2) = data.ctrl, self._act
        ctrl[a0], ctrl[a1], ctrl[a2] = cmd

    def _limited(self, angles: tuple[float, float, float]) -> tuple[float, float, float]:
        """Each angle (in -pi..pi) held inside its joint's range; ``at_limit`` says whether one had to be."""
        (y, r, p), ((ylo, yhi), (rlo, rhi), (plo, phi)) = angles, self.limits
        out = (min(yhi, max(ylo, y)), min(rhi, max(rlo, r)), min(phi, max(plo, p)))
        self.at_limit = out != (y, r, p)
        return out

    def joints(self, data: mujoco.MjData) -> tuple[float, float, float]:
        """The encoders: the joints' angles now (yaw, roll, pitch; rad)."""
        q = data.qpos
        return q[self._qadr[0]], q[self._qadr[1]], q[self._qadr[2]]

    def joint_rates(self, data: mujoco.MjData) -> tuple[float, float, float]:
        """The joints' angular rates now (yaw, roll, pitch; rad/s)."""
        v = data.qvel
        return v[self._vadr[0]], v[self._vadr[1]], v[self._vadr[2]]
