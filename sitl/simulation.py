"""The physics core of the simulator: one MuJoCo world with its multicopters, wind and ground vehicle.

No sockets and no clocks: :meth:`World.step` advances simulated time by one lockstep period for
given motor commands (one array per vehicle); the process loop (``sitl.lockstep``) does the I/O.
Each vehicle is a :class:`sitl.multicopter.Multicopter` (rotors, aerodynamics, battery, the wind
at its position, sensors); truth is returned in MAVLink frames (NED, FRD), each vehicle's from its
own start point.  :class:`Simulation` is the one-vehicle world with the single-vehicle interface
(``sim.truth()``, ``sim.step(commands)``, ``sim.rotors`` ...); :class:`VehicleView` gives vehicle k
of a larger world the same interface, which is what a lockstep link reads.

Several vehicles: vehicle k starts ``spacing`` metres East of vehicle k-1 (:func:`spread`), its
sensors' home is the geodetic position of its own start point, its seed is
:func:`sitl.multicopter.vehicle_seed` (the world's seed for vehicle 0).  The air and the ground
vehicle are the world's: one ``WindSettings`` (each vehicle meets its own turbulence draws, at its
height and airspeed) and one ``UgvSettings``; sensor, motor and camera settings are each vehicle's.  With
``ugvs`` (``sitl --count N`` with the UGV) each vehicle has a ground vehicle of its own instead: UGV k with
vehicle k's settings, NED from vehicle k's start, its seed :func:`~sitl.multicopter.vehicle_seed`, its deck's pad
with marker ids of its own (:func:`vision.pad.vehicle_pad`; :attr:`VehicleView.pad`).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Sequence

import mujoco
import numpy as np

from mavsim_core.constants import LOCKSTEP_DT_S
from mavsim_core.geodesy import ned_to_geodetic
from params.vehicle import VehicleSpec
from sitl.model import PHYSICS_DT_S, Placement, build_world_model
from sitl.multicopter import Multicopter, SensorTruth, Truth, vehicle_seed
from sitl.sim_settings import CameraSettings, MotorSettings, SensorSettings, WindSettings
from sitl.ugv_paths import Pose2
from sitl.ugv_world import UgvDriver, UgvSettings, UgvTruth
from vision.pad import vehicle_pad

__all__ = ["LOCKSTEP_DT_S", "SensorTruth", "Simulation", "Truth", "VehicleView", "World", "spread"]

_STEP_US = int(LOCKSTEP_DT_S * 1e6)  # simulated microseconds per World.step
SPACING_M = 3.0  # between two vehicles' start points, East, as PX4's multi-vehicle launch scripts spread them
# ... in a world where each has its own ground vehicle: a circle of up to 3 m radius near its vehicle's start (with
# the deck's 1.84 m diagonal) stays clear of its neighbours'; UGVs driving the same path from the same pose (each
# NED from its own vehicle's start) drive translated copies of it, 10 m apart, and never meet
UGV_SPACING_M = 10.0


def spread(spec: VehicleSpec, count: int, spacing_m: float = SPACING_M) -> list[Placement]:
    """``count`` vehicles of ``spec`` in a row along East, ``spacing_m`` apart, vehicle 0 at the origin."""
    return [Placement(spec, (spacing_m * k, 0.0)) for k in range(count)]


def _nth(items: Sequence | None, k: int):
    return items[k] if items is not None and k < len(items) else None


class World:
    """One MuJoCo world: the multicopters of ``placements``, the ground, the ground vehicle (``ugv.enabled``).

    ``home``: LAT, LON, ALT of the world's origin (vehicle 0's start point).  ``sensors``, ``motors``,
    ``cameras``: each vehicle's settings (missing or None: defaults).  The settings objects are read on
    every step, so a ``SIM_*`` parameter changed between steps acts on the next.
    """

    def __init__(
        self,
        placements: Sequence[Placement],
        home: tuple[float, float, float],
        seed: int = 0,
        wind: WindSettings | None = None,
        ugv: UgvSettings | None = None,
        *,
        sensors: Sequence[SensorSettings | None] | None = None,
        motors: Sequence[MotorSettings | None] | None = None,
        cameras: Sequence[CameraSettings | None] | None = None,
        ugvs: Sequence[UgvSettings] | None = None,
    ) -> None:
        self.ugv_settings = ugv if ugv is not None else UgvSettings()
        self.wind_settings = wind if wind is not None else WindSettings()
        # One ground vehicle (``ugv``), or one per multicopter (``ugvs``: vehicle k's settings, NED from its start)
        own = list(ugvs) if ugvs is not None and self.ugv_settings.enabled else None
        self.ugv_settings_of = own or [self.ugv_settings] * len(placements)
        self.pads = [vehicle_pad(s.pad(), k) for k, s in enumerate(self.ugv_settings_of)] if own else None
        if own:
            starts = [_shifted(s.start_pose(), p.offset_en_m) for s, p in zip(own, placements)]
            self.model = build_world_model(placements, ugvs=list(zip(starts, self.pads)))  # type: ignore[arg-type]
        else:
            ugv_start = self.ugv_settings.start_pose() if self.ugv_settings.enabled else None
            self.model = build_world_model(placements, ugv_start=ugv_start, pad=self.ugv_settings.pad())
        self.data = mujoco.MjData(self.model)
        self.vehicles = [
            Multicopter(
                self.model,
                k,
                p.spec,
                _home_of(home, p),
                vehicle_seed(seed, k),
                self.wind_settings,
                _nth(sensors, k),
                _nth(motors, k),
                _nth(cameras, k),
            )  # fmt: skip
            for k, p in enumerate(placements)
        ]
        for v in self.vehicles:
            v.bind(self.data)  # its views of the world's arrays (v.ctrl ...)
            if v.gimbal is not None:  # the camera where it looks before the vehicle settles (not the servos' zero)
                v.gimbal.place(self.data, v.sensor_truth(self.data).r_ned_frd)
        self._settle()
        self.ugvs: list[UgvDriver] = []
        if own:  # each its own settings, NED from its own vehicle's start, its own seed (a random path)
            self.ugvs = [
                UgvDriver(self.model, self.data, s, v.start_xy_enu, vehicle_seed(seed, k), k=k)
                for k, (s, v) in enumerate(zip(own, self.vehicles))
            ]
        elif self.ugv_settings.enabled:  # the UGV's settings are NED from vehicle 0's start
            self.ugvs = [UgvDriver(self.model, self.data, self.ugv_settings, self.vehicles[0].start_xy_enu, seed)]
        self.ugv = self.ugvs[0] if self.ugvs else None
        self.time_us = 0
        self.substeps = round(LOCKSTEP_DT_S / PHYSICS_DT_S)

    def _settle(self, seconds: float = 1.0) -> None:
        """Let the vehicles come to rest on their legs before simulated time starts."""
        for _ in range(round(seconds / PHYSICS_DT_S)):
            mujoco.mj_step(self.model, self.data)
        self.data.time = 0.0
        for v in self.vehicles:
            v.settled(self.data)
        mujoco.mj_forward(self.model, self.data)

    def step(self, motor_commands: Sequence[np.ndarray]) -> None:
        """Advance one lockstep period with each vehicle's motor commands 0..1 (one per rotor), in vehicle order."""
        vehicles, d = self.vehicles, self.data
        cmds = [[float(x) for x in c[: v.rotors.n]] for v, c in zip(vehicles, motor_commands)]  # as numpy's float()
        for v in vehicles:
            v.apply_motor_failure()
        for ugv in self.ugvs:
            ugv.step(self.time_us * 1e-6, LOCKSTEP_DT_S)
        for v in vehicles:
            if v.gimbal is not None:  # the gimbal's own controller, on the airframe's attitude now
                v.gimbal.step(d, v.sensor_truth(d).r_ned_frd, LOCKSTEP_DT_S)
        for _ in range(self.substeps):
            for v, c in zip(vehicles, cmds):
                v.ctrl[:] = v.rotors.step(c, PHYSICS_DT_S)  # a list of thrusts (N) into the vehicle's d.ctrl slice
                v.apply_aerodynamics(d, PHYSICS_DT_S)
            mujoco.mj_step(self.model, d)
        for v in vehicles:
            m = v.motor_settings
            v.battery.step(v.rotors.shaft_power_w(), LOCKSTEP_DT_S, m.battery_drain_s, m.battery_min_pct / 100.0)
        self.time_us += _STEP_US

    def prepare_step(self) -> None:
        """What the next :meth:`step` needs that the flight controller's answer does not change, worked out ahead:
        the ground vehicles' path commands (:meth:`sitl.ugv_world.UgvDriver.prepare`; the lockstep calls it while it
        waits for the actuator controls).  The step gives the same world with or without it."""
        for ugv in self.ugvs:
            ugv.prepare(self.time_us * 1e-6)

    @property
    def own_ugvs(self) -> bool:
        """Each multicopter has a ground vehicle of its own (``ugvs``)."""
        return self.pads is not None

    def ugv_of(self, k: int) -> UgvDriver | None:
        """The ground vehicle vehicle ``k`` lands on: its own, or the world's one; None without one."""
        return self.ugvs[k] if self.own_ugvs else self.ugv

    def ugv_truth(self, k: int = 0) -> UgvTruth | None:
        """Vehicle ``k``'s ground vehicle's truth (deck centre, NED from vehicle ``k``'s start point), None without
        one."""
        if self.ugv is None:
            return None
        if self.own_ugvs:
            return self.ugvs[k].truth(self.time_us)
        t = self.ugv.truth(self.time_us)
        if k == 0:
            return t
        (e0, n0), (ek, nk) = self.vehicles[0].start_xy_enu, self.vehicles[k].start_xy_enu
        return replace(t, deck_pos_ned_m=t.deck_pos_ned_m - np.array([nk - n0, ek - e0, 0.0]))


def _shifted(pose: Pose2, offset_en_m: tuple[float, float]) -> Pose2:
    """``pose`` (NED m from a vehicle's start point) from the world's origin, the vehicle starting at ``offset_en_m``
    (ENU m: East, North)."""
    return Pose2(pose.north_m + offset_en_m[1], pose.east_m + offset_en_m[0], pose.yaw_rad)


def _home_of(home: tuple[float, float, float], p: Placement) -> tuple[float, float, float]:
    """The geodetic position of a placement's start point (the world's ``home`` for vehicle 0's)."""
    e, n = p.offset_en_m
    return home if (e, n) == (0.0, 0.0) else ned_to_geodetic(np.array([n, e, 0.0]), *home)


class VehicleView:
    """Vehicle ``k`` of a :class:`World` with the single-vehicle interface (what a lockstep link reads).

    Its models (``rotors``, ``battery``, ``sensors`` ...) are the vehicle's own objects; ``model``,
    ``data``, ``ugv``, ``wind_settings`` and ``ugv_settings`` are the world's.
    """

    def __init__(self, world: World, k: int) -> None:
        v = world.vehicles[k]
        self.world, self.index, self.vehicle = world, k, v
        self.spec, self.model, self.data, self.ugv = v.spec, world.model, world.data, world.ugv_of(k)
        self.rotors, self.aero, self.battery, self.sensors, self.wind = v.rotors, v.aero, v.battery, v.sensors, v.wind
        self.wind_settings, self.ugv_settings = world.wind_settings, world.ugv_settings_of[k]
        # the pad on the deck it lands on (its own ids when each vehicle has its own ground vehicle, vision.pad)
        self.pad = world.pads[k] if world.pads is not None else world.ugv_settings.pad()
        self.motor_settings, self.camera_settings = v.motor_settings, v.camera_settings

    @property
    def time_us(self) -> int:
        return self.world.time_us

    @property
    def _start_xy_enu(self) -> tuple[float, float]:
        return self.vehicle.start_xy_enu

    @property
    def wind_enu(self) -> tuple[float, float, float]:
        return self.vehicle.wind_enu

    def sensor_truth(self) -> SensorTruth:
        """The true state the sensors need, as plain floats (:meth:`sitl.multicopter.Multicopter.sensor_truth`)."""
        return self.vehicle.sensor_truth(self.data)

    def truth(self) -> Truth:
        return self.vehicle.truth(self.data, self.world.time_us)

    def attitude_truth(self) -> tuple[tuple[float, float, float, float], list[float]]:
        """``truth().q_ned_frd`` and ``truth().accel_ned_m_s2`` as floats (:meth:`Multicopter.attitude_truth`)."""
        return self.vehicle.attitude_truth(self.data)

    def ugv_truth(self) -> UgvTruth | None:
        """The ground vehicle's truth (deck centre, NED from this vehicle's start point), None without one."""
        return self.world.ugv_truth(self.index)


class Simulation(VehicleView):
    """One vehicle in its world (a one-vehicle :class:`World`, seen through :class:`VehicleView`).

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
        world = World([Placement(spec)], home, seed, wind, ugv, sensors=[sensors], motors=[motors], cameras=[camera])
        super().__init__(world, 0)

    def step(self, motor_commands: np.ndarray) -> None:
        """Advance one lockstep period with motor commands 0..1 (one per rotor)."""
        self.world.step((motor_commands,))
