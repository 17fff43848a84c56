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
from mavsim_core.frames import enu_to_ned, flu_to_frd, quat_enu_flu_to_ned_frd
from params.vehicle import VehicleSpec
from sitl.aerodynamics import Aerodynamics
from sitl.battery import Battery
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
        self.wind_enu = (0.0, 0.0, 0.0)
        self._failure: tuple | None = None  # (motor, efficiency) last applied to the rotors' efficiency list
        self._failure_list: list[float] | None = None
        self.start_xy_enu = (0.0, 0.0)  # set by the world once the vehicle has settled on its legs

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
        a, v = self.qadr, self.vadr
        vx, vy, vz = d.qvel[v : v + 3].tolist()  # world ENU
        wn, we, wd = self.wind.step(dt_s, float(d.qpos[a + 2]), math.sqrt(vx * vx + vy * vy + vz * vz))
        self.wind_enu = (we, wn, -wd)
        ax, ay, az = we - vx, wn - vy, -wd - vz  # V_a = V_wind - V_n ([F eq. 4.11], ENU
        r0, r1, r2, r3, r4, r5, r6, r7, r8 = d.xmat[self.body].tolist()  # body FLU -> world ENU, row-major
        bx = r0 * ax + r3 * ay + r6 * az  # R^T V_a
        by = r1 * ax + r4 * ay + r7 * az
        bz = r2 * ax + r5 * ay + r8 * az
        fx, fy, fz, mx, my, mz = self.aero.wrench_flu(self.rotors.speeds, (bx, by, bz))
        d.xfrc_applied[self.body] = (
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
        a, s, v = self.qadr, self.accel_adr, self.vadr
        fx, fy, fz = d.sensordata[s : s + 3].tolist()
        w, x, y, z = d.qpos[a + 3 : a + 7].tolist()
        r00, r01, r02 = 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)
        r10, r11, r12 = 2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)
        r20, r21, r22 = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
        e, n, u = d.qpos[a : a + 3].tolist()
        ve, vn, vu = d.qvel[v : v + 3].tolist()
        p, q, r = d.qvel[v + 3 : v + 6].tolist()
        return SensorTruth(
            specific_force_frd_m_s2=(fx, -fy, -fz),
            rate_frd_rad_s=(p, -q, -r),
            r_ned_frd=((r10, -r11, -r12), (r00, -r01, -r02), (-r20, r21, r22)),
            pos_ned_m=(n - self.start_xy_enu[1], e - self.start_xy_enu[0], -u),
            vel_ned_m_s=(vn, ve, -vu),
        )

    def truth(self, d: mujoco.MjData, time_us: int) -> Truth:
        a, s, v = self.qadr, self.accel_adr, self.vadr
        q = quat_enu_flu_to_ned_frd(d.qpos[a + 3 : a + 7])
        f_frd = flu_to_frd(d.sensordata[s : s + 3])
        r = np.empty(9)
        mujoco.mju_quat2Mat(r, q)
        r = r.reshape(3, 3)
        accel_ned = r @ f_frd + np.array([0.0, 0.0, GRAVITY_M_S2])  # a = R f + g
        return Truth(
            time_us=time_us,
            pos_ned_m=enu_to_ned(
                np.array([d.qpos[a] - self.start_xy_enu[0], d.qpos[a + 1] - self.start_xy_enu[1], d.qpos[a + 2]])
            ),
            vel_ned_m_s=enu_to_ned(d.qvel[v : v + 3]),
            accel_ned_m_s2=accel_ned,
            q_ned_frd=q,
            r_ned_frd=r,
            rate_frd_rad_s=flu_to_frd(d.qvel[v + 3 : v + 6]),  # free-joint angular velocity is in the body frame
            specific_force_frd_m_s2=f_frd,
            wind_ned_m_s=enu_to_ned(self.wind_enu),
        )
