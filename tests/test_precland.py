"""The cubic spline of [F eq. 3.1] and the precision-landing task, with nothing running.

A synthetic vehicle follows the task's setpoint with a first-order lag (time constant TAU_S)
plus the setpoint's velocity; the landing target is a point on the ground (down 0) that may
move at a constant velocity.  Frames NED, metres, seconds; the commander's 50 Hz step.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from autopilot.navigation.cubic_spline import MIN_DURATION_S, CubicSpline, duration_s
from autopilot.navigation.flight_task import FlightTask, PositionSetpoint
from autopilot.navigation.precland import (
    CHASE_INT_BAND_M_S,
    COAST_MAX_S,
    DOCK_DONE_M,
    DOCK_HOVER_M,
    DOCK_INTO_DECK_M,
    DOCK_TOUCH_M,
    PARAMS,
    LandingTargetInput,
    PrecLandConfig,
    PrecLandMode,
    PrecLandPhase,
    PrecLandTask,
)
from autopilot.param_catalogue import default_store
from autopilot.topics import AttitudeSetpoint, VehicleEstimate
from mavsim_core import quaternion as quat

STEP_US = 20_000
DT_S = STEP_US * 1e-6
TAU_S = 0.3
T0_US = 3_000_000


def estimate(t_us: int, pos: np.ndarray, vel: np.ndarray, yaw_rad: float = 0.0) -> VehicleEstimate:
    return VehicleEstimate(
        timestamp_us=t_us,
        q_wxyz=np.asarray(quat.from_euler(0.0, 0.0, yaw_rad), dtype=float),
        yaw_rad=yaw_rad,
        rate_frd_rad_s=np.zeros(3),
        accel_ned_m_s2=np.zeros(3),
        pos_ned_m=pos.copy(),
        vel_ned_m_s=vel.copy(),
        attitude_valid=True,
        position_valid=True,
        origin_lat_deg=47.0,
        origin_lon_deg=8.0,
        origin_alt_amsl_m=400.0,
    )


class Sim:
    """The task, a lagging vehicle (its heading too) and a ground target moving at ``target_vel`` (m/s NED)."""

    def __init__(self, target0, target_vel=(0.0, 0.0, 0.0), mode=PrecLandMode.OPPORTUNISTIC, start=(0.0, 0.0, -2.8)):
        self.t_us = T0_US
        self.pos = np.array(start, dtype=float)
        self.vel = np.zeros(3)
        self.yaw = 0.0
        self.target = np.array(target0, dtype=float)
        self.target_vel = np.array(target_vel, dtype=float)
        self.visible = lambda sim: True
        self.task = PrecLandTask(0.0, default_store(), mode=mode)
        self.task.activate(estimate(self.t_us, self.pos, self.vel), self.t_us)
        self.phases = [self.task.phase]

    def step(self) -> None:
        est = estimate(self.t_us, self.pos, self.vel, self.yaw)
        tgt = None
        if self.visible(self):
            tgt = LandingTargetInput(self.t_us, self.target - self.pos, self.target_vel.copy())
        sp = self.task.update(est, self.t_us, tgt)
        if isinstance(sp, AttitudeSetpoint):  # a touchdown's: level on the legs, carried by the deck
            self.vel = self.target_vel.copy()
            self.pos = self.pos + self.vel * DT_S
            self.target = self.target + self.target_vel * DT_S
            self.t_us += STEP_US
            if self.task.phase is not self.phases[-1]:
                self.phases.append(self.task.phase)
            return
        sp_vel = np.nan_to_num(sp.vel_ned_m_s)
        err = np.where(np.isfinite(sp.pos_ned_m), sp.pos_ned_m - self.pos, 0.0)
        self.vel = err / TAU_S + sp_vel
        self.pos = self.pos + self.vel * DT_S
        self.yaw = quat.wrap_pi(self.yaw + quat.wrap_pi(sp.yaw_rad - self.yaw) * DT_S / TAU_S)
        self.target = self.target + self.target_vel * DT_S
        self.t_us += STEP_US
        if self.task.phase is not self.phases[-1]:
            self.phases.append(self.task.phase)

    def run_until(self, cond, max_s: float) -> bool:
        for _ in range(int(max_s / DT_S)):
            if cond(self):
                return True
            self.step()
        return cond(self)

    def horizontal_error(self) -> float:
        return float(np.linalg.norm(self.pos[:2] - self.target[:2]))


# ---- the spline ------------------------------------------------------------------------------


def test_spline_meets_eq_3_1_and_its_boundary_conditions():
    p0, pd, td = np.array([1.0, -2.0, -3.0]), np.array([4.0, 2.0, -1.0]), 2.5
    s = CubicSpline(p0, pd, td)
    for t in (0.0, 0.7, 1.3, 2.1):
        eq = p0 + 3 * (pd - p0) * t**2 / td**2 - 2 * (pd - p0) * t**3 / td**3
        np.testing.assert_allclose(s.at(t).pos, eq, atol=1e-12)
    np.testing.assert_allclose(s.at(0.0).pos, p0)
    np.testing.assert_allclose(s.at(td).pos, pd)
    np.testing.assert_allclose(s.at(0.0).vel, 0.0, atol=1e-12)
    np.testing.assert_allclose(s.at(td - 1e-9).vel, 0.0, atol=1e-6)
    np.testing.assert_allclose(s.at(td / 2).acc, 0.0, atol=1e-12)  # the inflection at half time
    # numerical derivative of position is the velocity, of velocity the acceleration
    h = 1e-6
    np.testing.assert_allclose((s.at(1.0 + h).pos - s.at(1.0 - h).pos) / (2 * h), s.at(1.0).vel, atol=1e-5)
    np.testing.assert_allclose((s.at(1.0 + h).vel - s.at(1.0 - h).vel) / (2 * h), s.at(1.0).acc, atol=1e-4)


def test_spline_with_end_velocities_meets_them():
    s = CubicSpline(np.zeros(2), np.array([3.0, 0.0]), 2.0, v0=np.array([0.5, 1.0]), vd=np.array([1.0, -1.0]))
    np.testing.assert_allclose(s.at(0.0).vel, [0.5, 1.0], atol=1e-12)
    np.testing.assert_allclose(s.at(2.0 - 1e-9).vel, [1.0, -1.0], atol=1e-6)
    np.testing.assert_allclose(s.at(2.0).pos, [3.0, 0.0])


def test_td_gives_a_mean_speed_of_1_m_s_with_a_floor():
    assert duration_s(4.0) == pytest.approx(4.0)
    assert duration_s(0.01) == MIN_DURATION_S
    assert duration_s(math.nan) == MIN_DURATION_S
    s = CubicSpline(np.zeros(3), np.array([3.0, 4.0, 0.0]), duration_s(5.0))
    n = 1000
    ts = np.linspace(0.0, s.td_s, n + 1)
    path = sum(np.linalg.norm(s.at(b).pos - s.at(a).pos) for a, b in zip(ts[:-1], ts[1:], strict=True))
    assert path / s.td_s == pytest.approx(1.0, rel=1e-6)


# ---- the task --------------------------------------------------------------------------------


def test_parameters_have_px4_defaults_and_the_document_numbers():
    d = {p.name: p.default for p in PARAMS}
    assert d["PLD_BTOUT"] == 5.0 and d["PLD_HACC_RAD"] == 0.2 and d["PLD_FAPPR_ALT"] == 0.1
    assert d["PLD_SRCH_ALT"] == 10.0 and d["PLD_SRCH_TOUT"] == 10.0 and d["PLD_MAX_SRCH"] == 3
    assert d["PLD_PREP_ALT"] == 2.8 and d["PLD_TRK_ALT"] == 1.0 and d["PLD_APPR_RAD"] == 0.05
    cfg = PrecLandConfig()
    assert (cfg.btout_s, cfg.prep_alt_m, cfg.trk_alt_m, cfg.appr_rad_m) == (5.0, 2.8, 1.0, 0.05)


def test_preparation_hovers_at_2_8_m_until_the_target_appears_then_each_phase_to_docking():
    sim = Sim(target0=(3.0, -1.0, 0.0), start=(0.0, 0.0, -1.5))
    assert isinstance(sim.task, FlightTask)
    sim.visible = lambda s: s.t_us >= T0_US + 3_000_000
    assert sim.run_until(lambda s: s.t_us >= T0_US + 2_900_000, 5.0)
    assert sim.task.phase is PrecLandPhase.PREPARATION
    assert sim.pos[2] == pytest.approx(-2.8, abs=0.02) and np.linalg.norm(sim.pos[:2]) < 0.01
    assert sim.run_until(lambda s: s.task.phase is PrecLandPhase.TRACKING, 1.0)
    t_track = sim.t_us
    assert sim.run_until(lambda s: s.task.phase is PrecLandPhase.APPROACHING, 10.0)
    # td = horizontal error / 1 m/s (sqrt(10) m), then approaching
    assert (sim.t_us - t_track) * 1e-6 == pytest.approx(math.sqrt(10.0), abs=0.05)
    assert sim.run_until(lambda s: s.task.phase is PrecLandPhase.DOCKING, 5.0)
    assert sim.horizontal_error() < 0.05
    assert sim.pos[2] == pytest.approx(-1.0, abs=0.05)  # 1 m above the target
    assert sim.run_until(lambda s: s.task.done, 5.0)
    assert sim.task.motors_cut and not sim.task.failed
    assert sim.pos[2] > -0.1 and sim.horizontal_error() < 0.05
    assert sim.phases == [
        PrecLandPhase.PREPARATION,
        PrecLandPhase.TRACKING,
        PrecLandPhase.APPROACHING,
        PrecLandPhase.DOCKING,
        PrecLandPhase.DONE,
    ]
    texts = [text for _, text in sim.task.events]
    assert len(texts) == 5 and all(t.startswith("Precland: ") for t in texts)
    assert [t for t, _ in sim.task.events] == sorted(t for t, _ in sim.task.events)


def test_target_lost_searches_at_the_search_height_and_reacquires():
    sim = Sim(target0=(2.0, 0.0, 0.0))
    assert sim.run_until(lambda s: s.task.phase is PrecLandPhase.TRACKING, 1.0)
    lost_us = sim.t_us + 1_000_000  # half way along the spline
    assert sim.run_until(lambda s: s.t_us >= lost_us, 2.0)
    sim.visible = lambda s: s.t_us < lost_us or s.t_us > lost_us + 9_000_000
    assert sim.run_until(lambda s: s.task.phase is PrecLandPhase.SEARCH, 7.0)
    assert (sim.t_us - lost_us) * 1e-6 == pytest.approx(5.0, abs=0.1)  # PLD_BTOUT
    assert sim.run_until(lambda s: s.t_us > lost_us + 8_900_000, 5.0)
    assert sim.pos[2] == pytest.approx(-10.0, abs=0.1)  # PLD_SRCH_ALT
    assert sim.run_until(lambda s: s.task.phase is PrecLandPhase.TRACKING, 1.0)
    assert sim.task.searches == 1
    assert sim.run_until(lambda s: s.task.done, 30.0)
    assert sim.horizontal_error() < 0.05


def test_a_deck_that_drove_on_is_searched_for_where_it_should_be_now():
    """Lost at 3 m/s on a straight line: the search (PLD_SRCH_ALT up) follows the deck's predicted track, not the
    place where the marker went out of view, and finds it again."""
    sim = Sim(target0=(1.0, 0.0, 0.0), target_vel=(3.0, 0.0, 0.0))
    assert sim.run_until(lambda s: s.task.phase is PrecLandPhase.TRACKING, 1.0)
    lost_us = sim.t_us + 1_000_000
    sim.visible = lambda s: s.t_us < lost_us or s.t_us > lost_us + 9_000_000
    assert sim.run_until(lambda s: s.task.phase is PrecLandPhase.SEARCH, 7.0)
    assert sim.run_until(lambda s: s.t_us > lost_us + 8_900_000, 5.0)
    assert abs(sim.pos[0] - sim.target[0]) < 1.0 and sim.pos[2] == pytest.approx(-10.0, abs=0.5)
    assert sim.run_until(lambda s: s.task.done, 30.0) and sim.horizontal_error() < 0.1


@pytest.mark.parametrize("mode", [PrecLandMode.OPPORTUNISTIC, PrecLandMode.REQUIRED])
def test_target_never_found_again_falls_back_after_pld_max_srch_searches(mode):
    sim = Sim(target0=(1.0, 0.0, 0.0), mode=mode)
    assert sim.run_until(lambda s: s.task.phase is PrecLandPhase.TRACKING, 1.0)
    seen_until = sim.t_us + 200_000
    sim.visible = lambda s: s.t_us < seen_until
    # PLD_BTOUT, then PLD_MAX_SRCH searches of PLD_SRCH_TOUT each
    assert sim.run_until(lambda s: s.task.phase is PrecLandPhase.FALLBACK, 40.0)
    assert sim.task.searches == 3
    assert (sim.t_us - seen_until) * 1e-6 == pytest.approx(5.0 + 10.0 + 10.0 + 10.0, abs=0.2)
    assert PrecLandPhase.SEARCH in sim.phases
    start_down = sim.pos[2]
    sim.run_until(lambda s: False, 5.0)
    if mode is PrecLandMode.OPPORTUNISTIC:
        assert not sim.task.failed and sim.pos[2] > start_down + 2.0  # descending: an ordinary landing
    else:
        assert sim.task.failed and sim.pos[2] == pytest.approx(start_down, abs=0.05)  # holding
    assert not sim.task.done
    assert "fallback" in sim.task.events[-1][1]


def test_lands_on_a_target_moving_at_1_m_s_in_a_straight_line():
    sim = Sim(target0=(2.0, 1.0, 0.0), target_vel=(0.6, 0.8, 0.0))
    assert sim.run_until(lambda s: s.task.done, 30.0)
    assert sim.horizontal_error() < 0.1
    assert PrecLandPhase.DOCKING in sim.phases


def test_shift_moves_the_points_not_the_vehicle():
    sim = Sim(target0=(1.0, 0.0, 0.0))
    sim.visible = lambda s: False
    sim.step()
    before = sim.task.update(estimate(sim.t_us, sim.pos, sim.vel), sim.t_us).pos_ned_m
    sim.task.shift(np.array([1.0, -2.0, 0.5]))
    after = sim.task.update(estimate(sim.t_us, sim.pos, sim.vel), sim.t_us).pos_ned_m
    np.testing.assert_allclose(after - before, [1.0, -2.0, 0.5])


def test_docking_returns_to_approaching_when_the_target_jumps_beyond_pld_hacc_rad():
    sim = Sim(target0=(1.0, 0.0, 0.0))
    assert sim.run_until(lambda s: s.task.phase is PrecLandPhase.DOCKING, 10.0)
    sim.step()
    sim.target = sim.target + np.array([0.0, 0.5, 0.0])  # farther than PLD_HACC_RAD (0.2 m)
    sim.step()
    assert sim.task.phase is PrecLandPhase.APPROACHING and "above 0.20 m" in sim.task.events[-1][1]
    assert sim.run_until(lambda s: s.task.done, 15.0)
    assert sim.horizontal_error() < 0.05


@pytest.mark.parametrize("acc_down_max", [3.0, 6.0])
def test_docking_descends_within_mpc_acc_down_max_with_the_spline_acceleration_fed_forward(acc_down_max):
    sim = Sim(target0=(0.5, 0.0, 0.0), start=(0.0, 0.0, -1.5))
    sim.task.params.set("MPC_ACC_DOWN_MAX", acc_down_max)
    assert sim.run_until(lambda s: s.task.phase is PrecLandPhase.DOCKING, 10.0)
    h = -sim.pos[2] - 0.03  # from about 1 m above the deck down to the docking point
    spline = sim.task._spline
    # [F 3]'s td would be h / 1 m/s; the cubic's peak acceleration 6 h / td^2 stays within the limit
    assert spline.td_s == pytest.approx(max(h, math.sqrt(6.0 * h / acc_down_max)), rel=0.05)
    peak = max(abs(float(spline.at(t).acc[0])) for t in np.linspace(0.0, spline.td_s, 101))
    assert peak == pytest.approx(min(acc_down_max, 6.0 * h / h**2), rel=0.05)
    # the setpoint carries the spline's downward acceleration (the limit at the start of the descent)
    sim.step()
    sp = sim.task.update(estimate(sim.t_us, sim.pos, sim.vel), sim.t_us)
    in_phase_s = (sim.t_us - sim.task._phase_us) * 1e-6
    assert float(sp.acc_ned_m_s2[2]) == pytest.approx(float(spline.at(in_phase_s).acc[0]), abs=1e-9)
    assert float(sp.acc_ned_m_s2[2]) > 0.8 * peak
    assert sim.run_until(lambda s: s.task.done, 5.0)
    assert sim.horizontal_error() < 0.05


@pytest.mark.parametrize(("deck_speed", "share"), [(0.0, 0.0), (0.05, 0.0), (0.2, 0.5), (1.0, 1.0)])
def test_the_targets_acceleration_is_fed_forward_over_a_moving_deck_only(deck_speed, share):
    sim = Sim(target0=(0.0, 0.0, 0.0), target_vel=(deck_speed, 0.0, 0.0), start=(0.0, 0.0, -1.0))
    acc = np.array([0.4, -0.3, 0.0])  # over a still deck: the differenced velocity's noise
    target = LandingTargetInput(sim.t_us, sim.target - sim.pos, sim.target_vel.copy(), True, acc)
    sp = sim.task.update(estimate(sim.t_us, sim.pos, sim.vel), sim.t_us, target)
    assert sim.task.phase is PrecLandPhase.TRACKING
    np.testing.assert_allclose(sp.acc_ned_m_s2 - sim.task._spline.at(0.0).acc, share * acc, atol=1e-9)


def test_the_chase_keeps_the_velocity_integrator_to_a_band_from_tracking_on():
    """From TRACKING to DONE the setpoints carry CHASE_INT_BAND_M_S (the integrator does not store the
    catch-up); while searching, the position hold leaves it to learn freely."""
    sim = Sim(target0=(3.0, 0.0, 0.0), target_vel=(3.0, 0.0, 0.0))
    hold = sim.task.update(estimate(sim.t_us, sim.pos, sim.vel), sim.t_us, None)
    assert sim.task.phase is not PrecLandPhase.TRACKING and hold.int_band_m_s == math.inf
    bands = set()
    for _ in range(int(60.0 / DT_S)):
        if sim.task.done:
            break
        sim.step()
        if sim.task.phase in (PrecLandPhase.TRACKING, PrecLandPhase.APPROACHING, PrecLandPhase.DOCKING):
            sp = sim.task.update(estimate(sim.t_us, sim.pos, sim.vel), sim.t_us, None)
            if isinstance(sp, PositionSetpoint):  # (not the touchdown's level attitude on the deck)
                bands.add(sp.int_band_m_s)
    assert PrecLandPhase.DOCKING in sim.phases and bands == {CHASE_INT_BAND_M_S}


def test_a_circling_deck_unseen_is_predicted_on_its_circle():
    """Docking is blind: the deck's point moves on turning as it was (target_coast), not straight."""
    r, v = 2.0, 1.0
    w = v / r
    centre = np.array([0.0, 2.0, 0.0])

    def deck(t_s: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        a = w * t_s
        pos = centre + r * np.array([math.sin(a), -math.cos(a), 0.0])
        return pos, v * np.array([math.cos(a), math.sin(a), 0.0]), v * w * np.array([-math.sin(a), math.cos(a), 0.0])

    task = PrecLandTask(0.0, default_store())
    here = np.array([0.0, 0.0, -2.8])
    t_us = T0_US
    task.activate(estimate(t_us, here, np.zeros(3)), t_us)
    for k in range(150):  # 3 s seen, 50 Hz
        pos, vel, acc = deck(k * DT_S)
        task.update(estimate(t_us, here, np.zeros(3)), t_us, LandingTargetInput(t_us, pos - here, vel, True, acc))
        t_us += STEP_US
    for _ in range(50):  # then 1 s unseen
        task.update(estimate(t_us, here, np.zeros(3)), t_us, None)
        t_us += STEP_US
    truth = deck(199 * DT_S)[0]
    assert np.linalg.norm(task._tgt_pos[:2] - truth[:2]) < 0.02  # (straight on it would be ~0.25 m off)


def test_legs_felt_on_the_deck_end_the_docking_but_not_from_higher_up():
    """Ground contact (the commander's ``on_deck``) with the feet estimated within DOCK_TOUCH_M: motors off at
    once, over a still deck whatever the error (sliding on it in wind only made it grow); higher up: ignored."""
    sim = Sim(target0=(0.3, 0.2, 0.0), start=(0.0, 0.0, -2.8))
    assert sim.run_until(lambda s: s.task.phase is PrecLandPhase.DOCKING, 20.0)
    sim.task.on_deck = True  # a spurious contact 1 m above the deck changes nothing
    sim.step()
    assert sim.task.phase is PrecLandPhase.DOCKING and not sim.task.done
    sim.task.on_deck = False

    def feet(s: Sim) -> float:
        return s.task._feet_above_target(estimate(s.t_us, s.pos, s.vel))

    assert sim.run_until(lambda s: feet(s) < DOCK_TOUCH_M, 10.0)
    assert feet(sim) > 0.05 and not sim.task.done  # not yet at the docking point
    sim.task.on_deck = True
    sim.step()
    assert sim.task.done and sim.task.phase is PrecLandPhase.DONE
    assert "legs on the deck" in sim.task.events[-1][1]


@pytest.mark.parametrize(("deck_speed", "level_s"), [(0.0, 0.6), (1.0, 0.0)])
def test_over_a_moving_deck_the_docking_aims_into_it_so_the_legs_meet_it_descending(deck_speed, level_s):
    """A moving deck: the docking spline ends DOCK_INTO_DECK_M below its top, so the feet reach the docking
    point still descending and (PLD_TD_LEVEL 0) the motors are cut at once (no blind stop just above a deck driving
    on); a still deck: the spline ends DOCK_HOVER_M above it, at rest."""
    sim = Sim(target0=(0.5, 0.0, 0.0), target_vel=(deck_speed, 0.0, 0.0), start=(0.0, 0.0, -1.5))
    sim.task.params.set("PLD_TD_LEVEL", level_s)
    assert sim.run_until(lambda s: s.task.phase is PrecLandPhase.DOCKING, 15.0)

    def feet(s: Sim) -> float:
        return s.task._feet_above_target(estimate(s.t_us, s.pos, s.vel))

    spline = sim.task._spline
    end_feet_m = feet(sim) + float(spline.p0[0])  # the spline runs from -h to 0, h = feet now - feet at its end
    assert end_feet_m == pytest.approx(-DOCK_INTO_DECK_M if deck_speed else DOCK_HOVER_M, abs=0.01)
    assert sim.run_until(lambda s: feet(s) <= DOCK_HOVER_M + DOCK_DONE_M, 5.0)
    descent_m_s = float(spline.at((sim.t_us - sim.task._phase_us) * 1e-6).vel[0])
    if deck_speed:
        assert descent_m_s > 0.5  # (aiming at the docking point at rest: 0.30 m/s here)
        sim.step()
        assert sim.task.done and "docking point reached" in sim.task.events[-1][1]
    else:
        assert descent_m_s < 0.35 and float(spline.at(spline.td_s).vel[0]) == 0.0


def test_on_a_moving_deck_the_legs_touch_then_the_vehicle_is_held_level_on_them_before_the_cut():
    """PLD_TD_LEVEL > 0 (the default): over a moving deck the docking flies on past the docking point until the
    legs are felt on the deck, then TOUCHDOWN flies a level attitude at half the hover thrust, turning with the
    deck, and the motors cut once the vehicle is level (navigation.touchdown)."""
    sim = Sim(target0=(0.5, 0.0, 0.0), target_vel=(1.0, 0.0, 0.0), start=(0.0, 0.0, -1.5))
    sim.task.hover_thrust_frac = 0.4

    def feet(s: Sim) -> float:
        return s.task._feet_above_target(estimate(s.t_us, s.pos, s.vel))

    assert sim.run_until(lambda s: s.task.phase is PrecLandPhase.DOCKING, 15.0)
    assert sim.run_until(lambda s: feet(s) <= 0.0, 5.0)  # past the docking point: still docking, motors on
    assert sim.task.phase is PrecLandPhase.DOCKING and not sim.task.done
    sim.task.on_deck = True
    sim.step()
    assert sim.task.phase is PrecLandPhase.TOUCHDOWN and "legs on the deck" in sim.task.events[-1][1]
    sp = sim.task.update(estimate(sim.t_us, sim.pos, sim.vel, 0.3), sim.t_us, None)
    assert isinstance(sp, AttitudeSetpoint) and sp.thrust_frac == pytest.approx(0.5 * 0.4)
    np.testing.assert_allclose(sp.q_wxyz, quat.from_euler(0.0, 0.0, 0.3), atol=1e-12)  # level, the heading held
    assert sim.run_until(lambda s: s.task.done, 1.0)
    assert sim.task.phase is PrecLandPhase.DONE and "level on the deck" in sim.task.events[-1][1]


@pytest.mark.parametrize("deck_yaw", [1, 0])
def test_the_vehicle_comes_down_square_to_a_deck_driving_diagonally(deck_yaw):
    sim = Sim(target0=(2.0, 1.0, 0.0), target_vel=(0.7, 0.7, 0.0))  # heading 45 deg: the worst for a held heading
    sim.task.params.set("PLD_DECK_YAW", deck_yaw)
    sim.task.activate(estimate(sim.t_us, sim.pos, sim.vel), sim.t_us)
    assert sim.run_until(lambda s: s.task.done, 30.0)
    off_square = abs(math.remainder(sim.yaw - math.pi / 4, math.pi / 2))
    assert off_square < math.radians(2.0) if deck_yaw else off_square == pytest.approx(math.pi / 4)


def test_a_target_unseen_longer_than_coast_max_s_stays_where_it_was():
    sim = Sim(target0=(1.0, 0.0, 0.0), target_vel=(2.0, 0.0, 0.0))
    assert sim.run_until(lambda s: s.task.phase is PrecLandPhase.APPROACHING, 10.0)
    sim.visible = lambda s: False
    sim.run_until(lambda s: False, COAST_MAX_S / 2)
    moving = sim.task.target_pos_ned_m
    sim.run_until(lambda s: False, COAST_MAX_S)
    held = sim.task.target_pos_ned_m
    sim.run_until(lambda s: False, 1.0)
    assert held[0] > moving[0] + 0.5  # moved on while fresh enough ...
    np.testing.assert_allclose(sim.task.target_pos_ned_m, held)  # ... then held (not 2 m further on)
    assert np.all(sim.task.target_velocity_ned_m_s == 0.0)
