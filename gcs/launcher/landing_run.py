"""One precision landing on the ground vehicle (UGV), flown through MAVLink and scored from the truth.

Used by ``flight-demo --scenario ugv-landing`` and ``benchmarks/landing_benchmark.py``.

The flight, as a user would fly it with any ground station: arm, take off to the preparation
height (``PLD_PREP_ALT``, 2.8 m), fly to the meeting point (a point on the UGV's path a few metres
ahead of it, where a crew would send the multicopter), start the UGV (``SIM_UGV_SPD`` over the
simulator's MAVLink port), then MAV_CMD_NAV_LAND with param 2 = 2 (precision landing, target
required) and wait until the flight controller cuts the motors on the deck.  Nothing here
steers the multicopter towards the UGV: the camera, the vision companion and the flight
controller's landing state machine do.

Scoring (simulator truth on UDP 14740+I, NED metres from the multicopter's start point): the
touchdown error is the horizontal distance from the multicopter's centre to the marker's centre
at the disarm; success is what a pilot would call a landing (:mod:`.deck_stance`): disarmed with its
centre over the deck and, ``STAY_ON_DECK_S`` later, all its feet on the deck and standing level on it
(its height above the deck that above flat ground, measured before the take-off, within 2 cm).  A
vehicle resting on the deck's edge is a failure whose reason says so.

Reproducible (``LandingSetup.deterministic``, the default): the simulator starts held
(``SIM_HOLD_MS`` = :data:`START_HOLD_MS`) and the flight is driven through holds
(:mod:`gcs.launcher.sim_stepper`): every command is sent while the simulation holds, every condition is
read at a hold every 0.1 s of simulated time (its ``CHECK_EVERY_S``; 0.5 s while waiting to be ready to
arm), the score is the truth at a hold, and the phases' limits are simulated seconds (``*_SIM_S``).
The same setup and seeds then give the same result to the last digit, whatever the machine's load or the
executor; ``timeout_s`` stays a wall-clock safety net.  Without it the script acts when the telemetry
arrives (what a person does with a ground station).
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from typing import Callable

from pymavlink.dialects.v20 import common as mavlink

from params.vehicle import load_vehicle
from sitl.ugv import UgvGeometry
from sitl.ugv_paths import Pose2, UgvPath, circle, figure8, straight_line

from ..client import VehicleClient
from ..errors import GcsTimeout
from ..sim_client import SimClient
from .deck_stance import STAY_ON_DECK_S, Stance, stance
from .sim_stepper import SimStepper, SimTimeout

PATH_CODES = {"static": 0, "line": 1, "circle": 2, "figure8": 3, "random": 4}
CAMERA_MOUNT_CODES = {"gimbal": 2, "fixed": 1}  # SIM_CAM_MOUNT: the 3-axis gimbal, the seed's body-fixed camera
PAD_LAYOUT_CODES = {"nested": 0, "single": 1}  # SIM_PAD_LAYOUT: the nested pad, the seed's single marker
PREP_ALT_M = 2.8  # PLD_PREP_ALT's default, [F 3]
ARRIVAL_RADIUS_M = 0.3
START_HOLD_MS = 100  # a reproducible run: the simulator holds from t = 0.1 s until the script moves the hold
READY_CHECK_EVERY_S = 0.5  # the same while waiting for it to be ready to arm (seconds: the estimator converging)
READY_SIM_S, TAKEOFF_SIM_S, MEET_SIM_S, LAND_SIM_S = 60.0, 60.0, 120.0, 180.0  # its phases' limits
WINDY = {  # params/scenarios/windy.toml's wind: 5 m/s from the West, turbulence and gusts
    "SIM_WIND_SPD": 5.0,
    "SIM_WIND_DIR": 270.0,
    "SIM_WIND_TURB": 1.0,
    "SIM_GUST_SPD": 2.0,
}


def deck_model_params(geom: UgvGeometry | None = None) -> dict[str, float]:
    """The flight controller's settings for landing on the simulated UGV, as its crew would set them for the deck
    they fly to: the marker's heading fused into the deck model (``PLD_DECK_HDG`` 2), its lag behind the UGV's
    turning axle learnt from the UGV's geometry (``PLD_DECK_LAG``: the pad sits on the chassis' centre,
    ``wheel_x_m`` behind the wheels' axle; docs/landing.md, "The marker's heading in the deck model")."""
    return {"PLD_DECK_HDG": 2, "PLD_DECK_LAG": (geom or UgvGeometry()).wheel_x_m}


@dataclass(frozen=True)
class LandingSetup:
    """One landing: vehicle, UGV path and speed, wind, seeds and the randomised geometry.

    ``ugv_start``: the UGV's start pose (NED m from the multicopter's start point, yaw rad);
    ``meet_after_m``: how far along its path (m) the UGV passes under the meeting point;
    ``meet_offset_m``: the meeting point's (north, east) offset from that point on the path (m);
    ``camera``: ``"gimbal"`` or ``"fixed"`` (``SIM_CAM_MOUNT``; None: the vehicle file's ``[camera] mount``);
    ``pad``: ``"nested"`` or ``"single"`` (``SIM_PAD_LAYOUT``; None: the simulator's default, nested);
    ``fc_params``: flight-controller parameters set (PARAM_SET) before the arming: :func:`deck_model_params`.
    """

    vehicle: str = "quad_x"
    path: str = "circle"
    speed_m_s: float = 1.0
    radius_m: float = 2.0
    windy: bool = False
    seed: int = 1
    ugv_start: Pose2 = Pose2(4.0, 0.0, math.pi / 2)
    meet_after_m: float = 3.0
    meet_offset_m: tuple[float, float] = (0.0, 0.0)
    mode: int = 2  # NAV_LAND param 2: 1 opportunistic, 2 required
    camera: str | None = None
    pad: str | None = None
    extra_sim_params: dict[str, float] = field(default_factory=dict)
    fc_params: dict[str, float] = field(default_factory=deck_model_params)
    video: bool = False  # the camera's RTP video (SIM_VID_EN): for a person watching (the demo), not for a campaign
    deterministic: bool = True  # start held and fly through holds: reproducible (see the module docstring)

    @property
    def stepped(self) -> bool:
        """Flown through holds: deterministic and the simulator starts held (``SIM_HOLD_MS`` 0 in
        ``extra_sim_params``, e.g. a campaign's ``[sim_params]``, turns both off)."""
        return self.sim_params().get("SIM_HOLD_MS", 0) > 0

    def sim_params(self) -> dict[str, float]:
        """The simulator's ``SIM_*`` parameters at start: the UGV parked at its start pose."""
        p = {
            "SIM_UGV_EN": 1,
            "SIM_UGV_X": self.ugv_start.north_m,
            "SIM_UGV_Y": self.ugv_start.east_m,
            "SIM_UGV_YAW": math.degrees(self.ugv_start.yaw_rad) % 360.0,
            "SIM_UGV_PATH": PATH_CODES[self.path],
            "SIM_UGV_RAD": self.radius_m,
            "SIM_UGV_SPD": 0.0,
            "SIM_VID_EN": int(self.video),  # (9 % of a landing's time; the landing the same either way)
        }
        if self.deterministic:
            p["SIM_HOLD_MS"] = START_HOLD_MS
        if self.camera is not None:
            p["SIM_CAM_MOUNT"] = CAMERA_MOUNT_CODES[self.camera]
        if self.pad is not None:
            p["SIM_PAD_LAYOUT"] = PAD_LAYOUT_CODES[self.pad]
        if self.windy:
            p.update(WINDY)
        p.update(self.extra_sim_params)
        return p

    def sim_args(self) -> list[str]:
        args: list[str] = []
        for name, value in self.sim_params().items():
            args += ["--param", f"{name}={value:g}"]
        return args

    def _path(self) -> UgvPath | None:
        start, v = self.ugv_start, max(self.speed_m_s, 0.1)
        if self.path in ("line", "random"):  # a random path's first leg is straight for at least 3 m
            return straight_line(start, v)
        if self.path == "circle":
            return circle(start, self.radius_m, v)
        if self.path == "figure8":
            return figure8(start, self.radius_m, v)
        return None

    def meeting_point(self) -> tuple[float, float]:
        """Where the multicopter waits (north, east m): over the UGV's path, ``meet_after_m`` ahead of it."""
        path = self._path()
        if path is None or self.speed_m_s <= 0.0:
            # A parked UGV: wait next to it (the UGV's body centre is behind the deck's marker by at most cm).
            base = (self.ugv_start.north_m, self.ugv_start.east_m)
        else:
            pose, _ = path.pose_at(self.meet_after_m)
            base = (pose.north_m, pose.east_m)
        return base[0] + self.meet_offset_m[0], base[1] + self.meet_offset_m[1]


@dataclass
class LandingResult:
    """What one landing gave (simulated seconds, metres from the truth)."""

    success: bool = False
    touchdown_error_m: float = math.nan
    time_to_land_s: float = math.nan  # from NAV_LAND to the disarm
    ugv_speed_at_touchdown_m_s: float = math.nan
    feet_on_deck: int = 0  # STAY_ON_DECK_S after the disarm (of the vehicle file's legs)
    deck_level_err_cm: float = math.nan  # then: height above the deck minus height above flat ground
    square_off_deg: float = math.nan  # then: its heading off square to the deck's edges (0-45 deg)
    reason: str = ""
    phases: list[str] = field(default_factory=list)
    # The flight's simulated and wall seconds, over one window: from the first simulated time the script knows (held
    # at its start, when stepped) to its end, the wait to be ready to arm included (the real-time factor's).
    sim_s: float = math.nan
    wall_s: float = math.nan

    @property
    def real_time_factor(self) -> float:
        return self.sim_s / self.wall_s if self.wall_s > 0 else math.nan


def _wait(cond: Callable[[], bool], client: VehicleClient, timeout_s: float, what: str) -> None:
    client.wait_until(cond, timeout_s, what)


def fly_landing(
    client: VehicleClient,
    truth: SimClient,
    setup: LandingSetup,
    say: Callable[[str], None] = lambda _t: None,
    timeout_s: float = 180.0,
    geom: UgvGeometry | None = None,
) -> LandingResult:
    """Fly one precision landing (see the module docstring) and score it."""
    result = LandingResult()
    spec = load_vehicle(setup.vehicle)
    judge = _Judge(truth, geom or UgvGeometry(), (spec.leg_positions_frd_m, spec.leg_size_m))
    client.add_listener(lambda m: _phase_listener(m, result))
    if setup.stepped:
        return _fly_stepped(SimStepper(client, truth, timeout_s=min(timeout_s, 60.0)), setup, say, judge, result)
    client.wait_until(lambda: client.sim_time_s() is not None, timeout_s, "the vehicle's time")
    wall0, sim0 = time.monotonic(), client.sim_time_s() or 0.0
    client.wait_until(client.prearm_ok, timeout_s, "the vehicle to be ready to arm")
    home = client.wait_home(timeout_s)
    judge.rest()
    configure(client, setup, say)
    client.arm(timeout_s=10).check()
    client.takeoff(home.alt_amsl_m + PREP_ALT_M, timeout_s=10).check()
    _wait(lambda: client.takeoff_done(PREP_ALT_M), client, timeout_s, f"takeoff to {PREP_ALT_M} m")
    meet_n, meet_e = setup.meeting_point()
    client.goto_ned(meet_n, meet_e, -PREP_ALT_M, timeout_s=10).check()
    say(f"flying to the meeting point N {meet_n:.2f} E {meet_e:.2f} at {PREP_ALT_M} m")
    _wait(lambda: client.arrived(meet_n, meet_e, ARRIVAL_RADIUS_M, 0.3), client, timeout_s, "the meeting point")
    if setup.speed_m_s > 0.0:
        truth.set("SIM_UGV_SPD", setup.speed_m_s)
        say(f"UGV driving: {setup.path} at {setup.speed_m_s:g} m/s")
    t_land = client.sim_time_s() or 0.0
    client.command_long(mavlink.MAV_CMD_NAV_LAND, 0, setup.mode, 0, math.nan, math.nan, math.nan, math.nan).check()
    say("precision landing")
    gave_up = lambda: any("Precision landing failed" in p for p in result.phases)  # noqa: E731
    try:
        _wait(lambda: not client.armed() or gave_up(), client, timeout_s, "the motors cut on the deck")
    except GcsTimeout:
        result.reason = "no touchdown in time"
        return _finish(result, client, sim0, wall0)
    if gave_up():
        result.reason = "target lost: " + " | ".join(result.phases[-2:])
        return _finish(result, client, sim0, wall0)
    t_touch = client.sim_time_s() or 0.0
    result.time_to_land_s = t_touch - t_land
    score = judge.score()
    if score is None:
        result.reason = "no truth at touchdown"
        return _finish(result, client, sim0, wall0)
    result.touchdown_error_m, result.ugv_speed_at_touchdown_m_s, first = score
    client.wait_sim_time(STAY_ON_DECK_S, timeout_s, f"{STAY_ON_DECK_S:g} s on the deck")
    _verdict(result, first, judge.score())
    return _finish(result, client, sim0, wall0)


def configure(client: VehicleClient, setup: LandingSetup, say: Callable[[str], None] = lambda _t: None) -> None:
    """Set ``setup.fc_params`` on the vehicle (each echoed; while held, between two steps: every run alike)."""
    for name, value in setup.fc_params.items():
        client.param_set(name, value, timeout_s=10)
    if setup.fc_params:
        say("set for this deck: " + ", ".join(f"{name} {value:g}" for name, value in setup.fc_params.items()))


def _fly_stepped(
    step: SimStepper, setup: LandingSetup, say: Callable[[str], None], judge: _Judge, result: LandingResult
) -> LandingResult:
    """:func:`fly_landing` driven through holds (reproducible; see the module docstring)."""
    client, truth = step.client, step.truth
    step.start()
    wall0, sim0_ms = time.monotonic(), step.time_ms
    try:
        ready = lambda: client.prearm_ok() and client.home() is not None  # noqa: E731
        step.run_until(ready, READY_SIM_S, "ready to arm", check_every_s=READY_CHECK_EVERY_S)
        home = client.home()
        judge.rest(step.time_ms)
        configure(client, setup, say)
        client.arm(timeout_s=10).check()
        client.takeoff(home.alt_amsl_m + PREP_ALT_M, timeout_s=10).check()
        step.run_until(lambda: client.takeoff_done(PREP_ALT_M), TAKEOFF_SIM_S, f"takeoff to {PREP_ALT_M} m")
        meet_n, meet_e = setup.meeting_point()
        client.goto_ned(meet_n, meet_e, -PREP_ALT_M, timeout_s=10).check()
        say(f"flying to the meeting point N {meet_n:.2f} E {meet_e:.2f} at {PREP_ALT_M} m")
        step.run_until(lambda: client.arrived(meet_n, meet_e, ARRIVAL_RADIUS_M, 0.3), MEET_SIM_S, "the meeting point")
        if setup.speed_m_s > 0.0:
            truth.set("SIM_UGV_SPD", setup.speed_m_s)
            say(f"UGV driving: {setup.path} at {setup.speed_m_s:g} m/s")
        t_land_ms = step.time_ms
        client.command_long(mavlink.MAV_CMD_NAV_LAND, 0, setup.mode, 0, math.nan, math.nan, math.nan, math.nan).check()
        say("precision landing")
        gave_up = lambda: any("Precision landing failed" in p for p in result.phases)  # noqa: E731
        try:
            step.run_until(lambda: not client.armed() or gave_up(), LAND_SIM_S, "the motors cut on the deck")
        except SimTimeout:
            result.reason = "no touchdown in time"
            return result
        if gave_up():
            result.reason = "target lost: " + " | ".join(result.phases[-2:])
            return result
        result.time_to_land_s = (step.time_ms - t_land_ms) / 1000.0
        score = judge.score(step.time_ms)
        if score is None:
            result.reason = "no truth at touchdown"
            return result
        result.touchdown_error_m, result.ugv_speed_at_touchdown_m_s, first = score
        step.advance(STAY_ON_DECK_S)
        _verdict(result, first, judge.score(step.time_ms))
        return result
    finally:
        result.sim_s, result.wall_s = (step.time_ms - sim0_ms) / 1000.0, time.monotonic() - wall0
        step.release(run_free=False)  # held until the stack stops: the camera's summary counts the same frames


def _finish(result: LandingResult, client: VehicleClient, sim0: float, wall0: float) -> LandingResult:
    result.sim_s = (client.sim_time_s() or sim0) - sim0
    result.wall_s = time.monotonic() - wall0
    return result


@dataclass
class _Judge:
    """Scores a landing from the simulator's truth (:mod:`.deck_stance`): ``legs`` are the vehicle file's leg
    positions (FRD m) and leg size (m); ``rest_dz_m`` the flat-ground reference, set by :meth:`rest`."""

    truth: SimClient
    geom: UgvGeometry
    legs: tuple
    rest_dz_m: float | None = None

    def _samples(self, at_ms: int | None):
        if at_ms is None:
            return self.truth.latest(), self.truth.ugv_latest()
        return self.truth.at(at_ms, within_ms=0), self.truth.ugv_at(at_ms, within_ms=0)

    def rest(self, at_ms: int | None = None) -> None:
        """Both vehicles stand on flat ground at ``at_ms`` (simulated ms; None: the latest truth): the reference
        of a level stance on the deck."""
        veh, ugv = self._samples(at_ms)
        if veh is not None and ugv is not None:
            self.rest_dz_m = veh.pos_ned_m[2] - ugv.pos_ned_m[2]

    def score(self, at_ms: int | None = None) -> tuple[float, float, Stance] | None:
        """Touchdown error (m), the UGV's speed (m/s) and the :class:`Stance` at ``at_ms`` (None: the latest)."""
        veh, ugv = self._samples(at_ms)
        if veh is None or ugv is None:
            return None
        state = self.truth.state_at(veh.time_ms, within_ms=10)
        q = None if state is None else state.attitude_quaternion
        v, u = veh.pos_ned_m, ugv.pos_ned_m
        err = float(math.hypot(v[0] - u[0], v[1] - u[1]))
        where = stance(v, q, u, ugv.yaw_rad, self.geom, self.legs, self.rest_dz_m)
        return err, float(math.hypot(*ugv.vel_ned_m_s[:2])), where


def _verdict(result: LandingResult, first: Stance, later: tuple[float, float, Stance] | None) -> None:
    """Success and its reason from the stance at the disarm (``first``) and STAY_ON_DECK_S later."""
    then = None if later is None else later[2]
    if then is not None:
        result.feet_on_deck, result.deck_level_err_cm = then.feet_on_deck, 100.0 * then.level_error_m
        result.square_off_deg = then.square_off_deg
    result.success = first.centre_on_deck and then is not None and then.standing
    if not first.centre_on_deck:
        result.reason = "touched down off the deck"
    elif then is None:
        result.reason = "no truth after the touchdown"
    elif not then.centre_on_deck:
        result.reason = "fell off the deck"
    elif not then.standing:
        result.reason = then.problem()


def _phase_listener(msg, result: LandingResult) -> None:
    if msg.get_type() == "STATUSTEXT" and msg.text.lower().startswith(("precland", "precision landing")):
        result.phases.append(msg.text)
