"""Flight tasks and the land detector with nothing running: synthetic estimates in, setpoints out.

Each test drives a task through its interface (activate, update -> setpoint, done, shift)
at the commander's 50 Hz with VehicleEstimate records of a vehicle that flies the
setpoint (its position is the setpoint's where that is controlled, else it moves at the
setpoint's velocity).  Frames NED, metres, seconds.
"""

from __future__ import annotations

import ast
import dataclasses
from pathlib import Path

import numpy as np
import pytest

from autopilot.control.gains_from_params import position_gains
from autopilot.control.position_control import PositionControl
from autopilot.navigation.flight_task import FlightTask, PositionSetpoint, started
from autopilot.navigation.goto import ARRIVE_RADIUS_M, DEFAULT_JERK_M_S3, GotoTask
from autopilot.navigation.land import LandTask
from autopilot.navigation.land_detector import LandDetector, Landed
from autopilot.navigation.loiter import LoiterTask
from autopilot.navigation.rtl import ReturnTask, RtlPhase
from autopilot.navigation.takeoff import TakeoffTask
from autopilot.param_catalogue import default_store
from autopilot.parameters import ParameterStore
from autopilot.topics import VehicleEstimate
from mavsim_core.constants import GRAVITY_M_S2

STEP_US = 20_000  # the commander's outer loop, 50 Hz
DT_S = STEP_US * 1e-6
T0_US = 7_000_000


def estimate(t_us: int, pos, vel=(0.0, 0.0, 0.0), yaw_rad: float = 0.4, position_valid: bool = True) -> VehicleEstimate:
    return VehicleEstimate(
        timestamp_us=t_us,
        q_wxyz=np.array([1.0, 0.0, 0.0, 0.0]),
        rate_frd_rad_s=np.zeros(3),
        accel_ned_m_s2=np.zeros(3),
        pos_ned_m=np.array(pos, dtype=float),
        vel_ned_m_s=np.array(vel, dtype=float),
        attitude_valid=True,
        position_valid=position_valid,
        origin_lat_deg=47.4,
        origin_lon_deg=8.5,
        origin_alt_amsl_m=500.0,
        yaw_rad=yaw_rad,
    )


class Flight:
    """A vehicle that flies a task's setpoints exactly, and the record of what it was told."""

    def __init__(self, task: FlightTask, pos, vel=(0.0, 0.0, 0.0), yaw_rad: float = 0.4) -> None:
        self.t_us = T0_US
        self.pos = np.array(pos, dtype=float)
        self.vel = np.array(vel, dtype=float)
        self.yaw_rad = yaw_rad
        self.task = started(task, self.est(), self.t_us)
        self.log: list[tuple[float, PositionSetpoint, bool]] = []  # (s since start, setpoint, done)
        self.downs: list[float] = []  # the vehicle's down position (m) when each setpoint was made

    def est(self) -> VehicleEstimate:
        return estimate(self.t_us, self.pos, self.vel, self.yaw_rad)

    def run(self, seconds: float, until=None) -> PositionSetpoint:
        sp = None
        for _ in range(round(seconds / DT_S)):
            self.t_us += STEP_US
            sp = self.task.update(self.est(), self.t_us)
            self.log.append(((self.t_us - T0_US) * 1e-6, sp, self.task.done))
            self.downs.append(float(self.pos[2]))
            new = np.where(np.isfinite(sp.pos_ned_m), sp.pos_ned_m, self.pos + sp.vel_ned_m_s * DT_S)
            self.vel = (new - self.pos) / DT_S
            self.pos = new
            if until is not None and until(self):
                break
        return sp

    def first_done_s(self) -> float:
        return next(t for t, _, done in self.log if done)


@pytest.fixture
def params() -> ParameterStore:
    return default_store()


def test_every_task_has_the_interface(params):
    for task in (
        TakeoffTask(-5.0, params),
        LoiterTask(),
        GotoTask(np.ones(3), 0.0, 1.0, 1.0),
        LandTask(0.0, params),
        ReturnTask(np.zeros(3), params),
    ):
        assert isinstance(task, FlightTask)


# --------------------------------------------------------------------------- take-off


def test_takeoff_climbs_to_its_height_and_reports_done(params):
    f = Flight(TakeoffTask(-5.0, params), pos=(3.0, -2.0, 0.1), yaw_rad=1.2)
    f.run(10.0)
    speed = params.get("MPC_TKO_SPEED")
    climb = np.array([-sp.vel_ned_m_s[2] for _, sp, _ in f.log])
    assert climb.max() == pytest.approx(speed)  # climbs at MPC_TKO_SPEED, never faster
    assert np.all(climb >= 0)
    for _, sp, _ in f.log:  # straight up, heading kept
        assert sp.pos_ned_m[:2] == pytest.approx([3.0, -2.0])
        assert sp.yaw_rad == 1.2
    final = f.log[-1][1]
    assert final.pos_ned_m == pytest.approx([3.0, -2.0, -5.0])
    assert np.all(final.vel_ned_m_s == 0)
    # 5.1 m at 1.5 m/s with 1 m/s^2 ramps, jerk-limited: 5.1/1.5 + 1.5/1 + 1/jerk = 5.0 s
    assert f.first_done_s() == pytest.approx(5.1 / speed + speed / 1.0 + 1.0 / DEFAULT_JERK_M_S3, abs=DT_S)
    assert all(done for t, _, done in f.log if t >= f.first_done_s())


def test_takeoff_is_not_done_while_the_vehicle_is_still_below(params):
    task = started(TakeoffTask(-5.0, params), estimate(T0_US, (0, 0, 0)), T0_US)
    t = T0_US + 30_000_000  # long after the profile ended, but the vehicle has not left the ground
    task.update(estimate(t, (0, 0, 0)), t)
    assert not task.done
    task.update(estimate(t, (0, 0, -5.0 + 0.5 * ARRIVE_RADIUS_M)), t)
    assert task.done


# --------------------------------------------------------------------------- loiter


def test_loiter_holds_where_it_was_activated(params):
    task = started(LoiterTask(), estimate(T0_US, (4.0, 5.0, -6.0), yaw_rad=-0.7), T0_US)
    for k in range(1, 200):  # the vehicle drifts; the setpoint does not
        t = T0_US + k * STEP_US
        sp = task.update(estimate(t, (4.0 + 0.01 * k, 5.0, -6.0 + 0.005 * k), vel=(0.5, 0, 0.25)), t)
        assert np.array_equal(sp.pos_ned_m, [4.0, 5.0, -6.0])
        assert np.array_equal(sp.vel_ned_m_s, np.zeros(3)) and np.array_equal(sp.acc_ned_m_s2, np.zeros(3))
        assert sp.yaw_rad == -0.7
        assert not task.done and not task.failed


def test_loiter_at_a_given_point_and_follows_an_estimator_reset():
    task = started(LoiterTask(np.array([1.0, 2.0, -3.0]), 0.5), estimate(T0_US, (0, 0, 0), yaw_rad=2.0), T0_US)
    assert np.array_equal(task.update(estimate(T0_US, (0, 0, 0)), T0_US).pos_ned_m, [1.0, 2.0, -3.0])
    task.shift(np.array([0.5, -1.0, 0.2]))
    sp = task.update(estimate(T0_US, (0, 0, 0)), T0_US)
    assert sp.pos_ned_m == pytest.approx([1.5, 1.0, -2.8])
    assert sp.yaw_rad == 0.5


# --------------------------------------------------------------------------- go-to


def test_goto_keeps_to_cruise_speed_and_horizontal_acceleration_and_arrives(params):
    cruise, acc = params.get("MPC_XY_CRUISE"), params.get("MPC_ACC_HOR")
    start, goal = np.array([1.0, 1.0, -5.0]), np.array([25.0, -17.0, -5.0])  # 30 m
    f = Flight(GotoTask(goal, 0.2, cruise, acc), pos=start)
    f.run(20.0)
    sps = [sp for _, sp, _ in f.log]
    speed = np.array([np.linalg.norm(sp.vel_ned_m_s) for sp in sps])
    accel = np.array([np.linalg.norm(sp.acc_ned_m_s2) for sp in sps])
    assert speed.max() == pytest.approx(cruise) and np.all(speed <= cruise + 1e-9)
    assert accel.max() == pytest.approx(acc) and np.all(accel <= acc + 1e-9)
    # The setpoint moves as its velocity says (no jumps), and its velocity as its acceleration says.
    pos = np.array([sp.pos_ned_m for sp in sps])
    vel = np.array([sp.vel_ned_m_s for sp in sps])
    assert np.max(np.linalg.norm(np.diff(pos, axis=0), axis=1)) <= cruise * DT_S + 1e-9
    assert np.max(np.linalg.norm(np.diff(vel, axis=0), axis=1)) <= acc * DT_S + 1e-9
    for sp in sps:  # along the line from start to goal
        along = (sp.pos_ned_m - start) / np.linalg.norm(goal - start)
        assert np.cross(along, (goal - start) / 30.0) == pytest.approx(np.zeros(3), abs=1e-9)
    assert sps[-1].pos_ned_m == pytest.approx(goal)
    # S-curve: L/v + v/a + a/j (the acceleration ramps at the jerk limit)
    assert f.first_done_s() == pytest.approx(30.0 / cruise + cruise / acc + acc / DEFAULT_JERK_M_S3, abs=DT_S)


def test_goto_too_short_for_cruise_peaks_lower_and_ends_at_rest(params):
    cruise, acc = params.get("MPC_XY_CRUISE"), params.get("MPC_ACC_HOR")
    task = GotoTask(np.array([2.0, 0.0, -5.0]), 0.0, cruise, acc)
    f = Flight(task, pos=(0.0, 0.0, -5.0))
    f.run(5.0)
    peak = max(np.linalg.norm(sp.vel_ned_m_s) for _, sp, _ in f.log)
    assert 0.5 < peak < cruise
    assert f.first_done_s() == pytest.approx(task.duration_s, abs=DT_S)
    final = f.log[-1][1]
    assert final.pos_ned_m == pytest.approx([2.0, 0.0, -5.0]) and not final.vel_ned_m_s.any()


def test_goto_moves_its_path_with_an_estimator_reset(params):
    f = Flight(GotoTask(np.array([10.0, 0.0, -5.0]), 0.0, 3.0, 2.0), pos=(0.0, 0.0, -5.0))
    before = f.run(1.0)
    f.task.shift(np.array([0.0, 2.0, -1.0]))
    f.pos += [0.0, 2.0, -1.0]  # the estimate jumps by the same amount
    after = f.task.update(estimate(f.t_us, f.pos), f.t_us)
    assert after.pos_ned_m - before.pos_ned_m == pytest.approx([0.0, 2.0, -1.0])
    f.run(10.0)
    assert f.task.done and f.log[-1][1].pos_ned_m == pytest.approx([10.0, 2.0, -6.0])


# --------------------------------------------------------------------------- land


def descent(f: Flight) -> np.ndarray:
    return np.array([sp.vel_ned_m_s[2] for _, sp, _ in f.log])


def test_land_descends_at_land_speed_below_alt1_and_slews_at_acc_down_max(params):
    home_down = 0.0
    f = Flight(LandTask(home_down, params), pos=(2.0, 3.0, -12.0), yaw_rad=0.9)
    f.run(60.0, until=lambda f: f.pos[2] >= home_down)
    slow, fast = params.get("MPC_LAND_SPEED"), params.get("MPC_Z_VEL_MAX_DN")
    alt1, acc = params.get("MPC_LAND_ALT1"), params.get("MPC_ACC_DOWN_MAX")
    v = descent(f)
    assert v[0] == 0.0  # starts from the vehicle's own (hovering) speed
    assert np.max(np.abs(np.diff(v))) <= acc * DT_S + 1e-12  # never steps
    assert all(np.isnan(sp.pos_ned_m[2]) for _, sp, _ in f.log)  # down is velocity-controlled
    assert v.max() == pytest.approx(fast)  # above MPC_LAND_ALT1: MPC_Z_VEL_MAX_DN
    # Below MPC_LAND_ALT1 (plus the distance the slew needs) it descends at MPC_LAND_SPEED.
    h = home_down - np.array(f.downs)
    low = h < alt1 - (fast**2 - slow**2) / (2 * acc) - 0.1
    assert low.any() and np.allclose(v[low], slow)
    for _, sp, _ in f.log:
        assert sp.pos_ned_m[:2] == pytest.approx([2.0, 3.0]) and sp.yaw_rad == 0.9
        assert not f.task.done


def test_land_starts_from_the_vehicles_own_descent_speed(params):
    own = 1.8  # m/s down, faster than MPC_LAND_SPEED
    f = Flight(LandTask(0.0, params), pos=(0.0, 0.0, -3.0), vel=(0.0, 0.0, own))
    f.run(2.0)
    v = descent(f)
    acc = params.get("MPC_ACC_DOWN_MAX")
    assert v[0] == own
    assert v[1] == pytest.approx(own - acc * DT_S)  # slows at MPC_ACC_DOWN_MAX
    assert v[-1] == pytest.approx(params.get("MPC_LAND_SPEED"))
    t_slow = next(t for t, sp, _ in f.log if sp.vel_ned_m_s[2] == pytest.approx(params.get("MPC_LAND_SPEED")))
    assert t_slow == pytest.approx((own - params.get("MPC_LAND_SPEED")) / acc + DT_S, abs=DT_S)


def test_land_without_position_flies_level_whatever_the_inertial_velocity_says(params):
    """GPS lost: the horizontal velocity estimate is dead reckoning, soon wrong (PX4's Descend flies level).
    Holding it at zero tilted a vehicle on its legs to stop a motion it did not have: it skipped along
    the ground (seed 8 of tests/test_e2e_estimation.py, 23 m from where GPS was lost)."""
    task = started(LandTask(0.0, params), estimate(T0_US, (1.0, 1.0, -3.0)), T0_US)
    drifting = estimate(T0_US, (1.0, 1.0, -3.0), position_valid=False)
    drifting = dataclasses.replace(drifting, vel_ned_m_s=np.array([0.8, -0.5, 0.7]))  # m/s NED, believed
    sp = task.update(drifting, T0_US)
    assert np.all(np.isnan(sp.pos_ned_m)) and np.all(np.isnan(sp.vel_ned_m_s[:2]))
    pc = PositionControl(position_gains(params.get), 1.5, 4 * 1.5 * GRAVITY_M_S2)
    thrust = pc.control(drifting.pos_ned_m, drifting.vel_ned_m_s, sp, 0.02).thrust_ned_n
    assert thrust[:2] == pytest.approx([0.0, 0.0]) and thrust[2] < 0  # level, carrying the weight


# --------------------------------------------------------------------------- return to launch


class RtlFlight(Flight):
    """A flight that also records when the return's phase changes."""

    def __init__(self, *a, **k) -> None:
        super().__init__(*a, **k)
        self.phase_log: list[tuple[float, RtlPhase]] = []

    def run(self, seconds: float, until=None) -> PositionSetpoint:
        def record(f: RtlFlight) -> bool:
            if not f.phase_log or f.phase_log[-1][1] is not f.task.phase:
                f.phase_log.append(((f.t_us - T0_US) * 1e-6, f.task.phase))
            return until is not None and until(f)

        return super().run(seconds, until=record)


def test_rtl_climbs_returns_waits_and_lands(params):
    params.set("RTL_RETURN_ALT", 12.0)
    params.set("RTL_LAND_DELAY", 3.0)
    home = np.array([0.0, 0.0, 0.5])
    f = RtlFlight(ReturnTask(home, params), pos=(30.0, -40.0, -2.0), yaw_rad=0.3)
    f.run(120.0, until=lambda f: f.pos[2] >= home[2])
    order = [p for _, p in f.phase_log]
    assert order == [RtlPhase.CLIMB, RtlPhase.RETURN, RtlPhase.LOITER, RtlPhase.LAND]
    t = dict((p, s) for s, p in f.phase_log)
    climb = [sp for s, sp, _ in f.log if s < t[RtlPhase.RETURN]]
    assert all(sp.pos_ned_m[:2] == pytest.approx([30.0, -40.0]) for sp in climb)  # straight up first
    ret = [sp for s, sp, _ in f.log if t[RtlPhase.RETURN] <= s < t[RtlPhase.LOITER]]
    assert all(sp.pos_ned_m[2] == pytest.approx(home[2] - 12.0) for sp in ret)  # at RTL_RETURN_ALT over home
    assert max(np.linalg.norm(sp.vel_ned_m_s[:2]) for sp in ret) == pytest.approx(params.get("MPC_XY_CRUISE"))
    hold = [sp for s, sp, _ in f.log if t[RtlPhase.LOITER] <= s < t[RtlPhase.LAND]]
    assert all(sp.pos_ned_m == pytest.approx([0.0, 0.0, home[2] - 12.0]) for sp in hold)  # waits over home
    assert t[RtlPhase.LAND] - t[RtlPhase.LOITER] == pytest.approx(3.0, abs=DT_S)  # RTL_LAND_DELAY
    land = [sp for s, sp, _ in f.log if s >= t[RtlPhase.LAND]]
    assert all(sp.pos_ned_m[:2] == pytest.approx([0.0, 0.0]) for sp in land)
    assert land[-1].vel_ned_m_s[2] == pytest.approx(params.get("MPC_LAND_SPEED"))
    assert f.pos[2] >= home[2] and not f.task.done


def test_rtl_does_not_land_with_delay_minus_one(params):
    params.set("RTL_LAND_DELAY", -1.0)
    home = np.zeros(3)
    f = RtlFlight(ReturnTask(home, params), pos=(10.0, 0.0, -4.0))
    f.run(120.0)
    assert [p for _, p in f.phase_log] == [RtlPhase.CLIMB, RtlPhase.RETURN, RtlPhase.LOITER]
    assert f.task.done
    assert f.log[-1][1].pos_ned_m == pytest.approx([0.0, 0.0, -params.get("RTL_RETURN_ALT")])


def test_rtl_above_return_altitude_keeps_its_height(params):
    home = np.zeros(3)
    f = RtlFlight(ReturnTask(home, params), pos=(10.0, 10.0, -25.0))
    f.run(30.0)
    # The climb has zero length: it is over at the first update.
    assert [p for _, p in f.phase_log] == [RtlPhase.RETURN, RtlPhase.LOITER, RtlPhase.LAND]
    t_land = f.phase_log[-1][0]
    assert all(sp.pos_ned_m[2] == pytest.approx(-25.0) for s, sp, _ in f.log if s < t_land)  # no climb, no dip


# --------------------------------------------------------------------------- land detector


def test_land_detector_hysteresis_is_lndmc_trig_time(params):
    for trig in (1.0, 2.5):
        params.set("LNDMC_TRIG_TIME", trig)
        ld = LandDetector(params)
        ld.on_arm(0.0)
        t, log = T0_US, []

        def run(seconds, pos, vel, thrust):
            nonlocal t
            for _ in range(round(seconds / DT_S)):
                t += STEP_US
                e = estimate(t, pos, vel)
                log.append((t, ld.update(t, True, e.vel_ned_m_s, float(e.pos_ned_m[2]), thrust), ld.ground_contact))

        run(1.0, (0, 0, 0), (0, 0, 0), 1.0)
        assert ld.state is Landed.ON_GROUND  # thrust alone is no take-off
        run(1.0, (0, 0, -2.0), (0, 0, -1.0), 1.0)
        assert ld.state is Landed.IN_AIR
        quiet_from = t
        run(trig + 2.0, (0, 0, 0), (0, 0, 0), 0.5)  # on the ground: no speed, low thrust
        contact = next(s for s, _, c in log if s > quiet_from and c)
        landed = next(s for s, st, _ in log if s > quiet_from and st is Landed.ON_GROUND)
        assert (landed - contact) * 1e-6 == pytest.approx(trig, abs=DT_S + 1e-9)
        assert ld.landed_since_us == landed


# --------------------------------------------------------------------------- import rule


def test_navigation_imports_no_socket_clock_or_mavlink():
    folder = Path(__file__).resolve().parents[1] / "autopilot" / "navigation"
    banned = {"socket", "time", "pymavlink", "datetime", "selectors"}
    for path in sorted(folder.glob("*.py")):
        for node in ast.walk(ast.parse(path.read_text())):
            names = (
                [a.name for a in node.names]
                if isinstance(node, ast.Import)
                else [node.module or ""]
                if isinstance(node, ast.ImportFrom)
                else []
            )
            for n in names:
                assert n.split(".")[0] not in banned, f"{path.name} imports {n}"
