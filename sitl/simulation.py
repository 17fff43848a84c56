"""The physics core of the simulator: MuJoCo rigid body, rotors, aerodynamics, wind, battery, sensors.

No sockets and no clocks: :meth:`Simulation.step` advances simulated time by one
lockstep period for given motor commands; the process loop (``sitl.lockstep``)
does the I/O.  Truth is returned in MAVLink frames (NED, FRD) through
:mod:`sitl.frames`, the only place that converts.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import NamedTuple

import mujoco
import numpy as np

from mavsim_core.constants import GRAVITY_M_S2, LOCKSTEP_DT_S
from mavsim_core.frames import enu_to_ned, flu_to_frd, quat_enu_flu_to_ned_frd
from params.vehicle import VehicleSpec
from sitl.aerodynamics import Aerodynamics
from sitl.battery import Battery
from sitl.model import PHYSICS_DT_S, build_model
from sitl.rotors import RotorModel
from sitl.sensors import SensorSuite
from sitl.sim_settings import CameraSettings, MotorSettings, SensorSettings, WindSettings
from sitl.ugv_world import UgvDriver, UgvSettings, UgvTruth
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


class Simulation:
    """One vehicle in its world.

    The settings objects (``wind_settings``, ``sensors.settings``, ``motor_settings``)
    are read on every step, so a ``SIM_*`` parameter changed between steps acts on the next.
    """

    def __init__(
        self,
        spec: VehicleSpec,
        home: tuple[float, float, float],
        seed: int = 0,
        wind: WindSettings | None = None,
        sensors: SensorSettings | None = None,
        motors: MotorSettings | None = None,
        ugv: UgvSettings | None = None,
        camera: CameraSettings | None = None,
    ) -> None:
        self.spec = spec
        self.ugv_settings = ugv if ugv is not None else UgvSettings()
        self.camera_settings = camera if camera is not None else CameraSettings()
        ugv_start = self.ugv_settings.start_pose() if self.ugv_settings.enabled else None
        self.model = build_model(spec, ugv_start=ugv_start)
        self.data = mujoco.MjData(self.model)
        self._body = self.model.body("vehicle").id
        self._settle()
        # The ground vehicle (SIM_UGV_EN=1), driven from its SIM_UGV_* settings every period.
        self.ugv = UgvDriver(self.model, self.data, self.ugv_settings, self._start_xy_enu, seed) if ugv_start else None
        self.rotors = RotorModel(spec)
        self.aero = Aerodynamics(spec)
        self.battery = Battery(spec.battery_cells, spec.battery_capacity_mah, spec.battery_resistance_ohm)
        self.wind_settings = wind if wind is not None else WindSettings()
        self.motor_settings = motors if motors is not None else MotorSettings()
        # Independent random streams: changing one model's draws never changes another's.
        self.wind = WindModel(self.wind_settings, seed=seed * 7919 + 1)
        self.sensors = SensorSuite(*home, seed=seed, settings=sensors)
        self.wind_enu = (0.0, 0.0, 0.0)
        self.time_us = 0
        self.substeps = round(LOCKSTEP_DT_S / PHYSICS_DT_S)
        self._accel_adr = self.model.sensor("accel").adr[0]
        self._gyro_adr = self.model.sensor("gyro").adr[0]

    def _settle(self, seconds: float = 1.0) -> None:
        """Let the vehicle come to rest on its legs before simulated time starts."""
        for _ in range(round(seconds / PHYSICS_DT_S)):
            mujoco.mj_step(self.model, self.data)
        self.data.time = 0.0
        self._start_xy_enu = tuple(self.data.qpos[0:2].tolist())
        mujoco.mj_forward(self.model, self.data)

    def _apply_motor_failure(self) -> None:
        m, eff = self.motor_settings, self.rotors.efficiency
        for i in range(self.rotors.n):
            eff[i] = m.fail_efficiency if i + 1 == m.fail_motor else 1.0

    def _apply_aerodynamics(self, dt_s: float) -> None:
        """Wind for this step, then rotor drag, rolling moment and body drag as an external wrench."""
        d = self.data
        vx, vy, vz = d.qvel[0:3].tolist()  # world ENU
        wn, we, wd = self.wind.step(dt_s, float(d.qpos[2]), math.sqrt(vx * vx + vy * vy + vz * vz))
        self.wind_enu = (we, wn, -wd)
        ax, ay, az = we - vx, wn - vy, -wd - vz  # V_a = V_wind - V_n ([F eq. 4.11], ENU
        r0, r1, r2, r3, r4, r5, r6, r7, r8 = d.xmat[self._body].tolist()  # body FLU -> world ENU, row-major
        bx = r0 * ax + r3 * ay + r6 * az  # R^T V_a
        by = r1 * ax + r4 * ay + r7 * az
        bz = r2 * ax + r5 * ay + r8 * az
        fx, fy, fz, mx, my, mz = self.aero.wrench_flu(self.rotors.speeds, (bx, by, bz))
        d.xfrc_applied[self._body] = (
            r0 * fx + r1 * fy + r2 * fz,
            r3 * fx + r4 * fy + r5 * fz,
            r6 * fx + r7 * fy + r8 * fz,
            r0 * mx + r1 * my + r2 * mz,
            r3 * mx + r4 * my + r5 * mz,
            r6 * mx + r7 * my + r8 * mz,
        )

    def step(self, motor_commands: np.ndarray) -> None:
        """Advance one lockstep period with motor commands 0..1 (one per rotor)."""
        cmds = np.asarray(motor_commands, dtype=float)[: self.rotors.n].tolist()
        self._apply_motor_failure()
        if self.ugv is not None:
            self.ugv.step(self.time_us * 1e-6, LOCKSTEP_DT_S)
        n = self.rotors.n
        for _ in range(self.substeps):
            self.data.ctrl[:n] = self.rotors.step(cmds, PHYSICS_DT_S)  # a list of thrusts, N
            self._apply_aerodynamics(PHYSICS_DT_S)
            mujoco.mj_step(self.model, self.data)
        m = self.motor_settings
        self.battery.step(self.rotors.shaft_power_w(), LOCKSTEP_DT_S, m.battery_drain_s, m.battery_min_pct / 100.0)
        self.time_us += int(LOCKSTEP_DT_S * 1e6)

    def ugv_truth(self) -> UgvTruth | None:
        """The ground vehicle's truth (deck centre, NED from the start point), None without one."""
        return self.ugv.truth(self.time_us) if self.ugv is not None else None

    def sensor_truth(self) -> SensorTruth:
        """The true state the sensors need, as plain floats (cheap: called every lockstep period).

        The same frames and values as :meth:`truth`; the attitude matrix is built from the
        FLU->ENU quaternion in ``qpos`` (after the step, like :meth:`truth`; MuJoCo's ``xmat``
        still holds the attitude before it) as R_ned_frd = P R_enu_flu F with P the ENU->NED
        swap and F = diag(1, -1, -1) the FRD->FLU flip (the conversions of :mod:`sitl.frames`).
        """
        d = self.data
        a = self._accel_adr
        fx, fy, fz = d.sensordata[a : a + 3].tolist()
        w, x, y, z = d.qpos[3:7].tolist()
        r00, r01, r02 = 1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)
        r10, r11, r12 = 2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)
        r20, r21, r22 = 2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)
        e, n, u = d.qpos[0:3].tolist()
        ve, vn, vu = d.qvel[0:3].tolist()
        p, q, r = d.qvel[3:6].tolist()
        return SensorTruth(
            specific_force_frd_m_s2=(fx, -fy, -fz),
            rate_frd_rad_s=(p, -q, -r),
            r_ned_frd=((r10, -r11, -r12), (r00, -r01, -r02), (-r20, r21, r22)),
            pos_ned_m=(n - self._start_xy_enu[1], e - self._start_xy_enu[0], -u),
            vel_ned_m_s=(vn, ve, -vu),
        )

    def truth(self) -> Truth:
        d = self.data
        sd = d.sensordata
        q = quat_enu_flu_to_ned_frd(d.qpos[3:7])
        f_frd = flu_to_frd(sd[self._accel_adr : self._accel_adr + 3])
        r = np.empty(9)
        mujoco.mju_quat2Mat(r, q)
        r = r.reshape(3, 3)
        accel_ned = r @ f_frd + np.array([0.0, 0.0, GRAVITY_M_S2])  # a = R f + g
        return Truth(
            time_us=self.time_us,
            pos_ned_m=enu_to_ned(
                np.array([d.qpos[0] - self._start_xy_enu[0], d.qpos[1] - self._start_xy_enu[1], d.qpos[2]])
            ),
            vel_ned_m_s=enu_to_ned(d.qvel[0:3]),
            accel_ned_m_s2=accel_ned,
            q_ned_frd=q,
            r_ned_frd=r,
            rate_frd_rad_s=flu_to_frd(d.qvel[3:6]),  # free-joint angular velocity is in the body frame
            specific_force_frd_m_s2=f_frd,
            wind_ned_m_s=enu_to_ned(self.wind_enu),
        )
