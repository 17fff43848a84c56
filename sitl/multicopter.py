"""One multicopter of a simulated world: its MuJoCo body, rotors, aerodynamics, battery, wind, sensors.

No sockets and no clocks.  A :class:`sitl.simulation.World` holds one :class:`Multicopter` per
vehicle in its one MjModel/MjData; each reads and writes only its own slice of them (free joint,
rotor actuators, IMU sensors, external wrench).  Truth is returned in MAVLink frames (NED, FRD)
through :mod:`mavsim_core.frames`, the only place that converts, with the position measured from
the vehicle's own start point on the ground (its flight controller's home).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import mujoco
import numpy as np

from mavsim_core.constants import GRAVITY_M_S2
from params.vehicle import VehicleSpec
from sitl.aerodynamics import Aerodynamics
from sitl.battery import Battery
from sitl.gimbal import Gimbal
from sitl.model import part_name
from sitl.rotors import RotorModel
from sitl.sensors import SensorSuite
from sitl.sim_settings import CameraSettings, MotorSettings, SensorSettings, WindSettings
from sitl.wind import WindModel


@dataclass(frozen=True)
class Truth:
    """Ground truth in MAVLink frames; position is NED (m) from the start point on the ground."""

    time_us: int
    pos_ned_m: np.ndarray
    vel_ned_m_s: np.ndarray
    accel_ned_m_s2: np.ndarray
    q_ned_frd: np.ndarray  # (w, x, y, z)
    r_ned_frd: np.ndarray  # the same attitude as a 3x3 matrix taking FRD vectors to NED
    rate_frd_rad_s: np.ndarray
    specific_force_frd_m_s2: np.ndarray
    wind_ned_m_s: np.ndarray


class SensorTruth(NamedTuple):
    """The subset of :class:`Truth` the sensor models read, as float tuples (NED/FRD, SI)."""

    specific_force_frd_m_s2: tuple[float, float, float]
    rate_frd_rad_s: tuple[float, float, float]
    r_ned_frd: tuple[tuple[float, float, float], ...]  # rows; takes FRD vectors to NED
    pos_ned_m: tuple[float, float, float]
    vel_ned_m_s: tuple[float, float, float]


def vehicle_seed(seed: int, k: int) -> int:
    """The random seed of vehicle ``k`` of a world started with ``seed``: ``seed`` itself for vehicle 0 (a
    one-vehicle world draws what the single-vehicle simulator always drew), a mix of both for the others."""
    if k == 0:
        return seed
    return int(np.random.SeedSequence([seed, k]).generate_state(1)[0])


class Multicopter:
    """Vehicle ``k`` of a compiled world (:func:`sitl.model.build_world_model`) and its models.

    The settings objects (``wind_settings``, ``sensors.settings``, ``motor_settings``) are read on every
    step.  ``home`` (lat deg, lon deg, alt m AMSL) is the geodetic position of the vehicle's start point.
    """

    def __init__(
        self,
        model: mujoco.MjModel,
        k: int,
        spec: VehicleSpec,
        home: tuple[float, float, float],
        seed: int,
        wind: WindSettings,
        sensors: SensorSettings | None = None,
        motors: MotorSettings | None = None,
        camera: CameraSettings | None = None,
    ) -> None:
        self.index, self.spec = k, spec
        self.body = model.body(part_name(k, "vehicle")).id
        root = model.joint(part_name(k, "root")).id
        self.qadr, self.vadr = int(model.jnt_qposadr[root]), int(model.jnt_dofadr[root])
        self.ctrl0 = model.actuator(part_name(k, "rotor1")).id
        self.accel_adr = model.sensor(part_name(k, "accel")).adr[0]
        self.gyro_adr = model.sensor(part_name(k, "gyro")).adr[0]
        self.rotors = RotorModel(spec)
        self.ctrl1 = self.ctrl0 + self.rotors.n
        self.aero = Aerodynamics(spec)
        self.battery = Battery(spec.battery_cells, spec.battery_capacity_mah, spec.battery_resistance_ohm)
        self.wind_settings = wind
        self.motor_settings = motors if motors is not None else MotorSettings()
        self.camera_settings = camera if camera is not None else CameraSettings()
        # Independent random streams: changing one model's draws never changes another's.
        self.wind = WindModel(wind, seed=seed * 7919 + 1)  # the turbulence this vehicle meets
        self.sensors = SensorSuite(*home, seed=seed, settings=sensors)
        self.gimbal = Gimbal(model, k, spec.camera.gimbal) if spec.camera.gimballed else None  # the camera's
        self.wind_enu = (0.0, 0.0, 0.0)
        self._failure: tuple | None = None  # (motor, efficiency) last applied to the rotors' efficiency list
        self._failure_list: list[float] | None = None
        self.start_xy_enu = (0.0, 0.0)  # set by the world once the vehicle has settled on its legs
        self._data: mujoco.MjData | None = None  # the MjData the views of :meth:`bind` look into

    def bind(self, d: mujoco.MjData) -> None:
        """Views of this vehicle's slices of ``d``, made once (an MjData's arrays never move; slicing one
        on every step costs more than the arithmetic that reads it)."""
        a, v, s = self.qadr, self.vadr, self.accel_adr
        self._qpos = d.qpos[a : a + 7]  # position ENU (m), then the FLU -> ENU quaternion (w, x, y, z)
        self._qvel_lin = d.qvel[v : v + 3]  # velocity, world ENU (m/s)
        self._qvel = d.qvel[v : v + 6]  # velocity ENU, then the angular velocity in the body frame FLU (rad/s)
        self._accel = d.sensordata[s : s + 3]  # the accelerometer: specific force, body FLU (m/s^2)
        self._xmat = d.xmat[self.body]  # body FLU -> world ENU, row-major
        self._xfrc = d.xfrc_applied[self.body]  # external force and torque at the centre of mass, world ENU
        self.ctrl = d.ctrl[self.ctrl0 : self.ctrl1]  # the rotor actuators' thrusts (N)
        self._data = d

    def settled(self, data: mujoco.MjData) -> None:
        """Take the vehicle's present ground position as its start point (the origin of its truth)."""
        a = self.qadr
        self.start_xy_enu = tuple(data.qpos[a : a + 2].tolist())

    def apply_motor_failure(self) -> None:
        """The rotors' efficiencies from SIM_MOT_FAIL/SIM_MOT_EFF (set again only when those change)."""
        m, eff = self.motor_settings, self.rotors.efficiency
        key = (m.fail_motor, m.fail_efficiency)
        if key == self._failure and eff is self._failure_list:
            return
        for i in range(self.rotors.n):
            eff[i] = m.fail_efficiency if i + 1 == m.fail_motor else 1.0
        self._failure, self._failure_list = key, eff

    def apply_aerodynamics(self, d: mujoco.MjData, dt_s: float) -> None:
        """Wind for this step, then rotor drag, rolling moment and body drag as an external wrench."""
        if d is not self._data:
            self.bind(d)
        vx, vy, vz = self._qvel_lin.tolist()  # world ENU
        wn, we, wd = self.wind.step(dt_s, self._qpos.item(2), math.sqrt(vx * vx + vy * vy + vz * vz))
        self.wind_enu = (we, wn, -wd)
        ax, ay, az = we - vx, wn - vy, -wd - vz  # V_a = V_wind - V_n ([F eq. 4.11], ENU
        r0, r1, r2, r3, r4, r5, r6, r7, r8 = self._xmat.tolist()  # body FLU -> world ENU, row-major
        bx = r0 * ax + r3 * ay + r6 * az  # R^T V_a
        by = r1 * ax + r4 * ay + r7 * az
        bz = r2 * ax + r5 * ay + r8 * az
        fx, fy, fz, mx, my, mz = self.aero.wrench_flu(self.rotors.speeds, (bx, by, bz))
        self._xfrc[:] = (
            r0 * fx + r1 * fy + r2 * fz,
            r3 * fx + r4 * fy + r5 * fz,
            r6 * fx + r7 * fy + r8 * fz,
            r0 * mx + r1 * my + r2 * mz,
            r3 * mx + r4 * my + r5 * mz,
            r6 * mx + r7 * my + r8 * mz,
        )

    def sensor_truth(self, d: mujoco.MjData) -> SensorTruth:
        """The true state the sensors need, as plain floats (cheap: called every lockstep period).

        The same frames and values as :meth:`truth`; the attitude matrix is built from the
        FLU->ENU quaternion in ``qpos`` (after the step, like :meth:`truth`; MuJoCo's ``xmat``
        still holds the attitude before it) as R_ned_frd = P R_enu_flu F with P the ENU->NED
        swap and F = diag(1, -1, -1) the FRD->FLU flip (the conversions of :mod:`mavsim_core.frames`).
        """
        if d is not self._data:
            self.bind(d)
        fx, fy, fz = self._accel.tolist()
        e, n, u, w, x, y, z = self._qpos.tolist()
        ve, vn, vu, p, q, r = self._qvel.tolist()
        r00, r01, r02 = 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)
        r10, r11, r12 = 2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)
        r20, r21, r22 = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
        e0, n0 = self.start_xy_enu
        return SensorTruth(  # positional: a third cheaper than by keyword
            (fx, -fy, -fz),  # specific_force_frd_m_s2
            (p, -q, -r),  # rate_frd_rad_s
            ((r10, -r11, -r12), (r00, -r01, -r02), (-r20, r21, r22)),  # r_ned_frd
            (n - n0, e - e0, -u),  # pos_ned_m
            (vn, ve, -vu),  # vel_ned_m_s
        )

    def truth(self, d: mujoco.MjData, time_us: int) -> Truth:
        """The full truth (NumPy arrays, MAVLink frames): the conversions of :mod:`mavsim_core.frames` written out
        on plain floats (the same numbers, bit for bit), the attitude matrix by MuJoCo's ``mju_quat2Mat``."""
        if d is not self._data:
            self.bind(d)
        e, n, u, w, x, y, z = self._qpos.tolist()
        ve, vn, vu, p, q, r = self._qvel.tolist()  # free-joint angular velocity is in the body frame
        fx, fy, fz = self._accel.tolist()
        q_ned_frd, rot, f_frd, accel_ned = _attitude_arrays(_quat_ned_frd(w, x, y, z), (fx, -fy, -fz))
        e0, n0 = self.start_xy_enu
        we, wn, wu = self.wind_enu
        return Truth(
            time_us,
            np.array((n - n0, e - e0, -u)),  # pos_ned_m
            np.array((vn, ve, -vu)),  # vel_ned_m_s
            accel_ned,  # accel_ned_m_s2
            q_ned_frd,
            rot,  # r_ned_frd
            np.array((p, -q, -r)),  # rate_frd_rad_s
            f_frd,  # specific_force_frd_m_s2
            np.array((wn, we, -wu)),  # wind_ned_m_s
        )

    def attitude_truth(self, d: mujoco.MjData) -> tuple[tuple[float, float, float, float], list[float]]:
        """:meth:`truth`'s ``q_ned_frd`` (w, x, y, z) and ``accel_ned_m_s2`` (m/s^2) as floats, the same bits: with
        :meth:`sensor_truth` (position, velocity, rate) all the truth port sends, without building a :class:`Truth`."""
        if d is not self._data:
            self.bind(d)
        w, x, y, z = self._qpos.tolist()[3:]
        fx, fy, fz = self._accel.tolist()
        q = _quat_ned_frd(w, x, y, z)
        return q, _attitude_arrays(q, (fx, -fy, -fz))[3].tolist()


_GRAVITY_NED = np.array([0.0, 0.0, GRAVITY_M_S2])


def _attitude_arrays(q_ned_frd: tuple, f_frd: tuple) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """q_ned_frd, R_ned_frd (MuJoCo's ``mju_quat2Mat`` of it), the specific force f (FRD) as arrays, and the
    acceleration a = R f + g (NED, m/s^2)."""
    q = np.array(q_ned_frd)
    f = np.array(f_frd)
    rot = np.empty(9)
    mujoco.mju_quat2Mat(rot, q)
    rot = rot.reshape(3, 3)
    return q, rot, f, rot @ f + _GRAVITY_NED


_SQRT_HALF = math.sqrt(0.5)


def _hamilton(aw: float, ax: float, ay: float, az: float, bw: float, bx: float, by: float, bz: float) -> tuple:
    """The Hamilton product a * b of :func:`mavsim_core.quaternion.mul`, on floats (the same expressions)."""
    return (
        aw * bw - ax * bx - ay * by - az * bz,
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
    )


def _quat_ned_frd(w: float, x: float, y: float, z: float) -> tuple:
    """:func:`mavsim_core.frames.quat_enu_flu_to_ned_frd` of MuJoCo's FLU -> ENU quaternion, on floats:
    q_ned_enu * q * q_flu_frd, its w made non-negative."""
    t = _hamilton(0.0, _SQRT_HALF, _SQRT_HALF, 0.0, w, x, y, z)  # q_ned_enu = (0, sqrt(1/2), sqrt(1/2), 0)
    o = _hamilton(t[0], t[1], t[2], t[3], 0.0, 1.0, 0.0, 0.0)  # q_flu_frd = (0, 1, 0, 0)
    return (-o[0], -o[1], -o[2], -o[3]) if o[0] < 0 else o
