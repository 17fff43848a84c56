"""What the camera benchmarks share (camera_profile.py, camera_fast_path.py): a camera-on landing flown for its logs,
and the states its camera frames were captured in, put back into a MuJoCo model of the world it was flown in.

Not a benchmark itself (the leading underscore).  :func:`fly_landing` runs ``flight-demo --scenario ugv-landing``
(the simulator and the flight controller at full speed, one landing) with ``--log-dir`` and ``SIM_*`` parameters,
and reads what it printed (the real-time factor) and the simulator's camera line.  :class:`LandingFrames` reads
that flight's truth log, frame log and world (sitl/truth_log.py, sitl/flight_setup.py) and poses a model for each
frame: the multicopter (position, attitude), the UGV (its deck's centre, its yaw; level) and the gimbal's joints
as recorded at the frame's capture, then the kinematics and the cameras, as the companion's state copy had them
(to a physics step: the truth is logged every 4 ms, the captures fall on that grid).
"""

from __future__ import annotations

import math
import os
import re
import resource
import subprocess
import sys
import time
from dataclasses import dataclass
from pathlib import Path

os.environ.setdefault("MUJOCO_GL", "egl")  # headless rendering, before MuJoCo is imported (as sitl does)

import mujoco  # noqa: E402
import numpy as np  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT))

from mavsim_core.frames import ned_to_enu, quat_enu_flu_to_ned_frd, quat_ned_frd_to_enu_flu  # noqa: E402
from mavsim_core.quaternion import from_euler  # noqa: E402
from sitl.gimbal import camera_to_body  # noqa: E402
from sitl.marker_view import deck_centre_enu  # noqa: E402
from sitl.model import GIMBAL_JOINTS, Placement, build_world_model  # noqa: E402
from sitl.replay_video import read_flight  # noqa: E402
from sitl.ugv import UgvGeometry  # noqa: E402
from sitl.ugv_paths import Pose2  # noqa: E402
from vision.landing_target import CameraMount  # noqa: E402


@dataclass
class FlownLanding:
    """One ``flight-demo --scenario ugv-landing``: its logs, what it printed and how long it took (wall s)."""

    log_dir: Path
    truth: Path | None
    ok: bool
    real_time_factor: float
    camera_line: str
    wall_s: float
    cpu_s: float  # the CPU time of the demo and everything it started (the simulator, the flight controller)
    output: str

    @property
    def frames(self) -> int:
        """The camera frames of the whole simulation (the simulator's camera line), 0 if it printed none."""
        m = re.search(r"camera: (\d+) frames", self.camera_line)
        return int(m.group(1)) if m else 0


def fly_landing(instance: int, log_dir: Path, sim_params: dict[str, float], timeout_s: float = 600.0) -> FlownLanding:
    """Fly the demo's landing on instance ``instance`` with ``sim_params`` (``--sitl-arg=--param=NAME=VALUE``)."""
    log_dir.mkdir(parents=True, exist_ok=True)
    cmd = [sys.executable, "-m", "gcs.launcher.demo", "-i", str(instance), "--scenario", "ugv-landing"]
    cmd += ["--log-dir", str(log_dir)] + [f"--sitl-arg=--param={k}={v:g}" for k, v in sim_params.items()]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    t0 = time.perf_counter()
    done = subprocess.run(cmd, cwd=ROOT, capture_output=True, text=True, timeout=timeout_s)
    wall = time.perf_counter() - t0
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    cpu = (after.ru_utime + after.ru_stime) - (before.ru_utime + before.ru_stime)
    out = done.stdout + done.stderr
    rtf = re.search(r"real-time factor: ([0-9.]+)", out)
    sitl_log = log_dir / "sitl.log"
    lines = sitl_log.read_text().splitlines() if sitl_log.exists() else []
    camera = next((ln.removeprefix("[sitl] ") for ln in reversed(lines) if "] camera:" in ln), "")
    truths = sorted(log_dir.glob("*.truth.npy"), key=lambda p: p.stat().st_mtime)
    ok = done.returncode == 0 and "flight demo: OK" in out
    return FlownLanding(
        log_dir, truths[-1] if truths else None, ok, float(rtf.group(1)) if rtf else math.nan, camera, wall, cpu, out
    )


class CameraWorld:
    """A MuJoCo model of the camera's world (the multicopter ``spec`` on its camera mount, the UGV with ``pad`` on
    its deck) whose state :meth:`pose` sets."""

    def __init__(self, spec, pad) -> None:
        self.spec, self.pad = spec, pad
        self.model = build_world_model([Placement(spec)], ugv_start=Pose2(0.0, 0.0, 0.0), pad=pad)
        self.data = mujoco.MjData(self.model)
        self.camera_id = self.model.camera("downward").id
        m = self.model
        self._root = int(m.jnt_qposadr[m.joint("root").id])
        self._ugv = int(m.jnt_qposadr[m.joint("ugv_root").id])
        self._gimbal = (
            {name: int(m.jnt_qposadr[m.joint(name).id]) for name, _ in GIMBAL_JOINTS} if spec.camera.gimballed
            else None
        )  # fmt: skip

    def pose(self, pos_ned, rpy, deck_ned, ugv_yaw: float, joints: dict[str, float] | None) -> mujoco.MjData:
        """``self.data`` with the multicopter at ``pos_ned`` (m from its start point on the ground) and ``rpy``
        (rad), the UGV's deck centre at ``deck_ned`` with ``ugv_yaw`` (level), the gimbal's ``joints`` (rad, by
        joint name); the kinematics and the cameras after."""
        q, a, u = self.data.qpos, self._root, self._ugv
        q[a : a + 3] = ned_to_enu(np.array(pos_ned, dtype=float))
        q[a + 3 : a + 7] = quat_ned_frd_to_enu_flu(from_euler(*rpy))
        geom = UgvGeometry()
        origin = np.array(deck_ned, dtype=float) + (0.0, 0.0, geom.deck_top_m - geom.wheel_radius_m)
        q[u : u + 3] = ned_to_enu(origin)
        q[u + 3 : u + 7] = quat_ned_frd_to_enu_flu(from_euler(0.0, 0.0, ugv_yaw))
        if self._gimbal is not None and joints is not None:
            for name, angle in joints.items():
                q[self._gimbal[name]] = angle
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)
        return self.data

    # -- what the companion computes from the same state (sitl/companion.py) ---------------------------------
    def attitude(self) -> np.ndarray:
        """The multicopter's attitude (w, x, y, z), FRD -> NED."""
        return quat_enu_flu_to_ned_frd(np.array(self.data.qpos[self._root + 3 : self._root + 7]))

    def mount(self) -> CameraMount:
        """The camera's mount at this state: the fixed one, or the gimbal's rotation from its joints."""
        fixed = CameraMount(position_frd_m=self.spec.camera.position_frd_m)
        if self._gimbal is None:
            return fixed
        j = tuple(float(self.data.qpos[self._gimbal[n]]) for n in ("gimbal_yaw", "gimbal_roll", "gimbal_pitch"))
        return CameraMount(fixed.position_frd_m, np.array(camera_to_body(j)))  # type: ignore[arg-type]

    def truth_frd(self) -> np.ndarray:
        """The deck's centre from the multicopter's centre of mass along its body FRD axes (m)."""
        veh = self.model.body("vehicle").id
        flu = self.data.xmat[veh].reshape(3, 3).T @ (deck_centre_enu(self.model, self.data) - self.data.xpos[veh])
        return np.array([flu[0], -flu[1], -flu[2]])


class LandingFrames(CameraWorld):
    """The frames of the flight whose truth log is ``truth`` (see the module docstring) in the world it was flown
    in: ``len()`` of them, :meth:`place` poses ``self.data`` as at frame k's capture."""

    def __init__(self, truth: Path) -> None:
        logs = read_flight(truth)
        if logs.frames is None:
            raise ValueError(f"{truth}: no camera frame log beside it")
        super().__init__(logs.setup.vehicle_spec(), logs.setup.pad_layout())
        self.truth, self.frames = logs.truth, logs.frames
        t = self.truth["time_us"]
        self._rows = [min(int(np.searchsorted(t, f)), len(t) - 1) for f in self.frames["time_us"]]

    def __len__(self) -> int:
        return len(self.frames)

    def place(self, k: int) -> mujoco.MjData:
        """``self.data`` as at frame ``k``'s capture (kinematics and cameras current)."""
        row, fr = self.truth[self._rows[k]], self.frames[k]
        joints = None
        if self._gimbal is not None and np.isfinite(fr["gimbal_pitch_deg"]):
            joints = {
                "gimbal_yaw": math.radians(float(fr["gimbal_yaw_deg"])),
                "gimbal_roll": math.radians(float(fr["gimbal_roll_deg"])),
                "gimbal_pitch": math.radians(float(fr["gimbal_pitch_deg"])),
            }
        pose = (float(row["pos_n_m"]), float(row["pos_e_m"]), float(row["pos_d_m"]))
        rpy = (float(row["roll_rad"]), float(row["pitch_rad"]), float(row["yaw_rad"]))
        deck = (float(row["ugv_n_m"]), float(row["ugv_e_m"]), float(row["ugv_d_m"]))
        return self.pose(pose, rpy, deck, float(row["ugv_yaw_rad"]), joints)


def load_line() -> str:
    """The machine's load (1, 5, 15 min averages) and core count, to print beside timings."""
    one, five, fifteen = os.getloadavg()
    return f"load average {one:.2f} / {five:.2f} / {fifteen:.2f} on {os.cpu_count()} cores"
