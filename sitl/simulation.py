"""The physics core of the simulator: MuJoCo rigid body, rotors, battery, sensors.

No sockets and no clocks: :meth:`Simulation.step` advances simulated time by one
lockstep period for given motor commands; the process loop (``sitl.lockstep``)
does the I/O.  Truth is returned in MAVLink frames (NED, FRD) through
:mod:`sitl.frames`, the only place that converts.
"""

from __future__ import annotations

from dataclasses import dataclass

import mujoco
import numpy as np

from params.vehicle import GRAVITY_M_S2, VehicleSpec
from sitl.battery import Battery
from sitl.frames import enu_to_ned, flu_to_frd, quat_enu_flu_to_ned_frd
from sitl.model import PHYSICS_DT_S, build_model
from sitl.rotors import RotorModel
from sitl.sensors import NoiseLevels, SensorSuite

LOCKSTEP_DT_S = 0.004  # 250 Hz sensor and control rate


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


class Simulation:
    def __init__(self, spec: VehicleSpec, home: tuple[float, float, float], seed: int = 0,
                 noise: NoiseLevels = NoiseLevels()) -> None:
        self.spec = spec
        self.model = build_model(spec)
        self.data = mujoco.MjData(self.model)
        self._settle()
        self.rotors = RotorModel(spec)
        self.battery = Battery()
        self.sensors = SensorSuite(*home, seed=seed, noise=noise)
        self.time_us = 0
        self.substeps = round(LOCKSTEP_DT_S / PHYSICS_DT_S)
        self._accel_adr = self.model.sensor("accel").adr[0]
        self._gyro_adr = self.model.sensor("gyro").adr[0]

    def _settle(self, seconds: float = 1.0) -> None:
        """Let the vehicle come to rest on its legs before simulated time starts."""
        for _ in range(round(seconds / PHYSICS_DT_S)):
            mujoco.mj_step(self.model, self.data)
        self.data.time = 0.0
        self._start_xy_enu = self.data.qpos[0:2].copy()
        mujoco.mj_forward(self.model, self.data)

    def step(self, motor_commands: np.ndarray) -> None:
        """Advance one lockstep period with motor commands 0..1 (one per rotor)."""
        cmds = np.asarray(motor_commands, dtype=float)[: self.rotors.n]
        for _ in range(self.substeps):
            self.data.ctrl[:] = self.rotors.step(cmds, PHYSICS_DT_S)
            mujoco.mj_step(self.model, self.data)
        self.battery.step(self.rotors.shaft_power_w(), LOCKSTEP_DT_S)
        self.time_us += int(LOCKSTEP_DT_S * 1e6)

    def truth(self) -> Truth:
        d = self.data
        sd = d.sensordata
        q = quat_enu_flu_to_ned_frd(d.qpos[3:7])
        f_frd = flu_to_frd(sd[self._accel_adr:self._accel_adr + 3])
        r = np.empty(9)
        mujoco.mju_quat2Mat(r, q)
        r = r.reshape(3, 3)
        accel_ned = r @ f_frd + np.array([0.0, 0.0, GRAVITY_M_S2])  # a = R f + g
        return Truth(
            time_us=self.time_us,
            pos_ned_m=enu_to_ned(np.array([d.qpos[0] - self._start_xy_enu[0], d.qpos[1] - self._start_xy_enu[1], d.qpos[2]])),
            vel_ned_m_s=enu_to_ned(d.qvel[0:3]),
            accel_ned_m_s2=accel_ned,
            q_ned_frd=q,
            r_ned_frd=r,
            rate_frd_rad_s=flu_to_frd(d.qvel[3:6]),  # free-joint angular velocity is in the body frame
            specific_force_frd_m_s2=f_frd,
        )

