"""The ground vehicle (UGV) in the simulated world: its ``SIM_UGV_*`` settings and its driver.

:class:`UgvSettings` are ``SIM_UGV_*`` parameters (the simulator's parameter service and
scenario files, :mod:`sitl.sim_params`).  ``SIM_UGV_EN`` is read once at start: with 1 the world
holds the UGV (:func:`sitl.model.build_model`).  The others act in flight: a new path, speed,
radius or acceleration limit re-plans the path from where the UGV is; a new start pose
(``SIM_UGV_X/Y/YAW``) puts it there, at rest.  Path 5 (manual) follows MANUAL_CONTROL
(:meth:`UgvDriver.manual`) and brakes to a stop when it stops arriving.

Frames: NED metres from the multicopter's start point on the ground (the frame of
:class:`sitl.simulation.Truth`), yaw in radians from North, positive towards East.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import mujoco
import numpy as np
from pymavlink.dialects.v20 import common as mavlink

from mavsim_core import quaternion
from mavsim_core.frames import ned_to_enu, quat_ned_frd_to_enu_flu
from sitl.sim_settings import (
    PATH_CIRCLE,
    PATH_FIGURE8,
    PATH_LINE,
    PATH_MANUAL,
    PATH_RANDOM,
    UgvSettings,
)
from sitl.ugv import Ugv, UgvGeometry, ugv_part
from sitl.ugv_paths import Pose2, UgvLimits, UgvPath, UnicycleCommand, circle, figure8, random_waypoints, straight_line

MANUAL_TIMEOUT_S = 0.5  # no MANUAL_CONTROL for this long: brake to a stop
MANUAL_SPEED_MAX_M_S = 3.0  # full stick forward
MANUAL_YAW_RATE_MAX_RAD_S = 1.0  # full stick yaw


@dataclass(frozen=True)
class UgvTruth:
    """The UGV's true state: the marker's centre on the deck (NED m from the multicopter's start),
    velocity (NED m/s) and yaw (rad)."""

    time_us: int
    deck_pos_ned_m: np.ndarray
    vel_ned_m_s: np.ndarray
    yaw_rad: float


def ugv_truth_messages(t: UgvTruth) -> list:
    """The UGV's truth for the truth port: LOCAL_POSITION_NED (deck centre, m, m/s) and ATTITUDE (yaw, rad)."""
    n, e, d = t.deck_pos_ned_m.tolist()
    vn, ve, vd = t.vel_ned_m_s.tolist()
    ms = t.time_us // 1000
    return [  # the attitude first: a client pairs each position with the yaw before it
        mavlink.MAVLink_attitude_message(ms, 0.0, 0.0, t.yaw_rad, 0.0, 0.0, 0.0),
        mavlink.MAVLink_local_position_ned_message(ms, n, e, d, vn, ve, vd),
    ]


def plan(settings: UgvSettings, start: Pose2, seed: int) -> UgvPath | None:
    """The path for the settings from ``start``; None for stop and manual."""
    limits = UgvLimits(accel_m_s2=settings.accel_m_s2)
    v = settings.speed_m_s
    if settings.path == PATH_LINE:
        return straight_line(start, v, limits)
    if settings.path == PATH_CIRCLE:
        return circle(start, settings.radius_m, v, limits)
    if settings.path == PATH_FIGURE8:
        return figure8(start, settings.radius_m, v, limits)
    if settings.path == PATH_RANDOM:
        return random_waypoints(start, v, np.random.default_rng(seed), limits)
    return None


class UgvDriver:
    """Drives the UGV of a MuJoCo world from its settings, once per lockstep period: ``origin_xy_enu`` is the world
    position (ENU m) the settings' NED frame starts from, ``k`` which ground vehicle of the world
    (:func:`sitl.ugv.ugv_part`)."""

    def __init__(
        self,
        model: mujoco.MjModel,
        data: mujoco.MjData,
        settings: UgvSettings,
        origin_xy_enu: tuple[float, float],
        seed: int = 0,
        geom: UgvGeometry = UgvGeometry(),
        k: int = 0,
    ) -> None:
        self.model, self.data, self.settings, self.geom = model, data, settings, geom
        self.origin_xy_enu = origin_xy_enu
        self.seed = seed
        self.ugv = Ugv(model, data, UgvLimits(accel_m_s2=settings.accel_m_s2), k)
        self._qadr = model.jnt_qposadr[model.joint(ugv_part(k, "ugv_root")).id]
        self._vadr = model.jnt_dofadr[model.joint(ugv_part(k, "ugv_root")).id]
        self._key: tuple | None = None
        self._start_key = (settings.north_m, settings.east_m, settings.yaw_deg)
        self._path: UgvPath | None = None
        self._path_t0_s = 0.0
        self._manual = UnicycleCommand(0.0, 0.0)
        self._manual_at_s = -math.inf
        self._prepared: tuple[float, tuple, UnicycleCommand] | None = None  # (time s, settings, command): prepare()
        self._truth: UgvTruth | None = None  # the latest truth (truth())

    def manual(self, x: float, r: float, time_s: float) -> None:
        """MANUAL_CONTROL x (forward) and r (yaw), each -1000..1000: switches the path to manual."""
        self.settings.path = PATH_MANUAL
        fwd = max(-1.0, min(1.0, x / 1000.0)) if math.isfinite(x) else 0.0
        yaw = max(-1.0, min(1.0, r / 1000.0)) if math.isfinite(r) else 0.0
        self._manual = UnicycleCommand(fwd * MANUAL_SPEED_MAX_M_S, yaw * MANUAL_YAW_RATE_MAX_RAD_S)
        self._manual_at_s = time_s

    def _pose(self) -> Pose2:
        p = self.ugv.state().pose
        return Pose2(p.north_m - self.origin_xy_enu[1], p.east_m - self.origin_xy_enu[0], p.yaw_rad)

    def _teleport(self, pose: Pose2) -> None:
        """Put the UGV at ``pose`` (NED from the multicopter's start), wheels on the ground, at rest."""
        pos = ned_to_enu(np.array([pose.north_m, pose.east_m, 0.0]))
        pos[0] += self.origin_xy_enu[0]
        pos[1] += self.origin_xy_enu[1]
        pos[2] = self.geom.wheel_radius_m
        q = quat_ned_frd_to_enu_flu(np.array([math.cos(pose.yaw_rad / 2), 0.0, 0.0, math.sin(pose.yaw_rad / 2)]))
        a, v = self._qadr, self._vadr
        self.data.qpos[a : a + 3], self.data.qpos[a + 3 : a + 7] = pos, q
        self.data.qvel[v : v + 6] = 0.0
        self.ugv.drive._v = 0.0

    def _keys(self) -> tuple[tuple, tuple]:
        """What the path depends on: the start pose, then the path, speed, radius and acceleration limit."""
        s = self.settings
        return (s.north_m, s.east_m, s.yaw_deg), (s.path, s.speed_m_s, s.radius_m, s.accel_m_s2)

    def prepare(self, time_s: float) -> None:
        """Work out the path follower's command for the period starting at ``time_s`` ahead of :meth:`step` (the
        simulator does it while it waits for the flight controller's answer, off the lockstep's critical path).
        :meth:`step` uses it only if nothing it depends on has changed since (the settings; the UGV moves only in
        the world's step), so the commands are those :meth:`step` alone would give."""
        self._prepared = None
        keys = self._keys()
        if self.settings.path != PATH_MANUAL and self._path is not None and keys == (self._start_key, self._key):
            self._prepared = (time_s, keys, self._path_command(time_s))

    def _path_command(self, time_s: float) -> UnicycleCommand:
        """The path follower's command at ``time_s`` from the UGV's pose now (:meth:`sitl.ugv.Ugv.command_for`)."""
        assert self._path is not None
        target = self._path.target(time_s - self._path_t0_s)
        pose = target.pose
        shifted = Pose2(pose.north_m + self.origin_xy_enu[1], pose.east_m + self.origin_xy_enu[0], pose.yaw_rad)
        return self.ugv.command_for(replace(target, pose=shifted))

    def step(self, time_s: float, dt_s: float) -> None:
        """Set the wheel commands for the period starting at ``time_s``."""
        prepared, self._prepared = self._prepared, None
        s = self.settings
        start_key, key = self._keys()
        if start_key != self._start_key:
            self._start_key = start_key
            self._teleport(s.start_pose())
            self._key = None
        if key != self._key:
            self._key = key
            self.ugv.limits = self.ugv.drive.limits = UgvLimits(accel_m_s2=s.accel_m_s2)
            self._path, self._path_t0_s = plan(s, self._pose(), self.seed), time_s
        if s.path == PATH_MANUAL:
            fresh = time_s - self._manual_at_s <= MANUAL_TIMEOUT_S
            self.ugv.command(self._manual if fresh else UnicycleCommand(0.0, 0.0), dt_s)
        elif self._path is None:
            self.ugv.command(UnicycleCommand(0.0, 0.0), dt_s)
        elif prepared is not None and prepared[0] == time_s and prepared[1] == (start_key, key):
            self.ugv.command(prepared[2], dt_s)
        else:
            self.ugv.command(self._path_command(time_s), dt_s)

    def truth(self, time_us: int) -> UgvTruth:
        """The UGV's truth at world time ``time_us``: worked out once per world time (the UGV moves only in the
        world's step, which moves the time on), however many read it (the truth log, the truth port, its radio)."""
        cached = self._truth
        if cached is not None and cached.time_us == time_us:
            return cached
        self._truth = t = self._truth_now(time_us)
        return t

    def _truth_now(self, time_us: int) -> UgvTruth:
        st = self.ugv.state()
        r = quaternion.to_matrix(st.quat_ned_frd)
        deck = st.position_ned_m + r @ np.array([0.0, 0.0, -(self.geom.deck_top_m - self.geom.wheel_radius_m)])
        deck[0] -= self.origin_xy_enu[1]
        deck[1] -= self.origin_xy_enu[0]
        return UgvTruth(time_us, deck, st.velocity_ned_m_s, st.yaw_rad)
