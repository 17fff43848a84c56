"""Autotune, pure parts: the identification recovers a known plant, the excitation is bounded, the state
machine refuses on the ground, aborts on a mode change and applies only what is accepted.

The plant is simulated here as the flight controller sees it: the rate PID (the project's own
:class:`RateControl`) drives rate/alpha_sp = b e^{-s d} / (s (tau s + 1)), integrated with 10 sub-steps
per 4 ms control period, with white gyro noise on the measured rate and a constant disturbance torque;
the PRBS is added to the rate setpoint as the flight controller adds it.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from autopilot.control.rate_control import RateControl, RateGains
from autopilot.param_catalogue import default_store
from autopilot.tuning.autotune import EXCITE_S, SETTLE_S, Autotune, Phase, Reply
from autopilot.tuning.excitation import ANGLE_BOUND_RAD, Prbs
from autopilot.tuning.identify import identify_rate_plant
from mavsim_core.autotune_report import AxisReport, axis_line, parse_axis_line
from mavsim_core.px4_modes import Mode

DT = 0.004


def closed_loop(b: float, tau: float, delay: int, noise: float, n: int = 1000, seed: int = 1):
    """(alpha_sp, measured rate) of one axis under the PID and a PRBS, as logged by the autotune."""
    rng = np.random.default_rng(seed)
    rc = RateControl(RateGains((12.0,) * 3, (6.0,) * 3, (0.15,) * 3, (5.0,) * 3, 100.0))
    prbs = Prbs(0.7, DT)
    rate = acc = 0.0
    queue = [0.0] * delay
    us, ys = [], []
    for _ in range(n):
        meas = rate + noise * rng.standard_normal()
        alpha = rc.update(np.array([meas, 0, 0]), np.array([prbs.next(), 0, 0]), DT)[0]
        us.append(alpha)
        ys.append(meas)
        queue.append(alpha)
        u = queue.pop(0)
        for _ in range(10):
            acc += (b * u + 0.3 - acc) / tau * DT / 10
            rate += acc * DT / 10
    return np.array(us), np.array(ys)


@pytest.mark.parametrize(
    "b, tau, delay, noise",
    [(1.0, 0.0125, 0, 0.003), (0.8, 0.025, 1, 0.003), (1.3, 0.05, 1, 0.01)],
)
def test_identification_recovers_effectiveness_motor_lag_and_delay(b, tau, delay, noise):
    u, y = closed_loop(b, tau, delay, noise)
    p = identify_rate_plant(u, y, DT)
    assert p.effectiveness == pytest.approx(b, rel=0.03)
    assert p.motor_tau_s == pytest.approx(tau, rel=0.06)
    assert p.delay_samples == delay and p.delay_s == pytest.approx(delay * DT)
    assert p.effectiveness_spread < 0.05 and p.fit > 0.5


def test_identification_refuses_samples_without_excitation():
    with pytest.raises(ValueError):
        identify_rate_plant(np.zeros(500), np.zeros(500), DT)
    with pytest.raises(ValueError):
        identify_rate_plant(np.ones(10), np.ones(10), DT)


@pytest.mark.parametrize("amp, bits", [(0.7, 3), (6.0, 3), (0.05, 25)])
def test_excitation_is_bounded_in_amplitude_and_in_the_attitude_it_commands(amp, bits):
    prbs = Prbs(amp, DT, bits)
    r = np.array([prbs.next() for _ in range(5000)])
    angle = np.cumsum(r) * DT
    assert np.max(np.abs(r)) == pytest.approx(amp)
    assert np.max(np.abs(angle)) <= ANGLE_BOUND_RAD + 1e-12
    assert np.mean(r > 0) == pytest.approx(0.5, abs=0.1)  # both signs: an excitation, not a bias
    assert len(np.nonzero(np.diff(r))[0]) > 5000 / bits / 4  # it switches often


def test_report_line_round_trips():
    r = AxisReport("roll", 0.9, 0.0137, 0.004, 0.86, (50.7, 316.0, 0.955), (50.89, 337.1, 0.6743),
                   (9.02, 7.54), (56.1, 55.0), (6.1, math.inf))  # fmt: skip
    line = axis_line(r)
    back = parse_axis_line(line)
    assert back is not None and back.axis == "roll" and back.gains_new == (50.89, 337.1, 0.6743)
    assert back.gain_margin_db[1] == math.inf and back.motor_tau_s == pytest.approx(0.0137)
    assert parse_axis_line("Autotune: roll 40 %") is None


class Flight:
    """An Autotune on the catalogue's parameters, stepped like the flight controller steps it, with the plant
    of :func:`closed_loop` on every axis."""

    def __init__(self) -> None:
        self.params = default_store()
        self.said: list[tuple[str, str]] = []
        self.tune = Autotune(self.params, DT, lambda sev, text: self.said.append((sev, text)))
        self.now_us = 10_000_000
        self.rc = RateControl(RateGains((12.0,) * 3, (6.0,) * 3, (0.15,) * 3, (5.0,) * 3, 100.0))
        self.rate = np.zeros(3)
        self.acc = np.zeros(3)
        self.peak_rate_sp = np.zeros(3)

    def steps(self, n: int, mode: Mode = Mode.AUTO_LOITER, armed: bool = True) -> None:
        for _ in range(n):
            self.now_us += int(DT * 1e6)
            if not self.tune.busy:
                continue
            excite = self.tune.update(self.now_us, mode, armed, armed)
            if excite is None:
                continue
            self.peak_rate_sp = np.maximum(self.peak_rate_sp, np.abs(excite))
            alpha = self.rc.update(self.rate, excite, DT)
            self.tune.record(alpha, self.rate, self.now_us)
            for _ in range(4):
                self.acc += (alpha - self.acc) / 0.02 * DT / 4
                self.rate = self.rate + self.acc * DT / 4

    def texts(self) -> list[str]:
        return [t for _, t in self.said]


def test_refused_on_the_ground_and_outside_hold_or_position():
    f = Flight()
    assert f.tune.command(1, Mode.AUTO_LOITER, False, False, f.now_us) is Reply.DENIED
    assert "not flying" in f.texts()[-1]
    assert f.tune.command(1, Mode.AUTO_MISSION, True, True, f.now_us) is Reply.DENIED
    assert "Hold or Position" in f.texts()[-1]
    f.params.set("MC_AT_EN", 0)
    assert f.tune.command(1, Mode.POSCTL, True, True, f.now_us) is Reply.DENIED
    assert f.tune.phase is Phase.IDLE


def test_a_mode_change_aborts_at_once_and_leaves_the_gains():
    f = Flight()
    before = f.params.values()
    assert f.tune.command(1, Mode.AUTO_LOITER, True, True, f.now_us) is Reply.IN_PROGRESS
    f.steps(int((SETTLE_S + 1.0) / DT))
    assert (
        f.tune.phase is Phase.EXCITE and f.tune.command(1, Mode.AUTO_LOITER, True, True, f.now_us).name == "IN_PROGRESS"
    )
    assert 20 < f.tune.progress < 40
    assert f.tune.update(f.now_us, Mode.POSCTL, True, True) is None  # the step of the change: no excitation
    assert f.tune.phase is Phase.FAILED and not f.tune.busy
    assert "Autotune aborted: mode changed to POSCTL" in f.texts()[-1]
    assert f.tune.command(1, Mode.POSCTL, True, True, f.now_us) is Reply.FAILED  # a poll just after: FAILED
    assert "start again after" in f.texts()[-1]
    said = len(f.texts())
    assert f.tune.command(1, Mode.POSCTL, True, True, f.now_us) is Reply.FAILED and len(f.texts()) == said  # once
    assert f.params.values() == before


def test_a_full_run_proposes_and_applies_only_when_accepted():
    f = Flight()
    before = f.params.values()
    f.tune.command(1, Mode.POSCTL, True, True, f.now_us)
    f.steps(int(3 * (SETTLE_S + EXCITE_S) / DT) + 10, Mode.POSCTL)
    assert f.tune.phase is Phase.READY and f.tune.progress == 95, f.texts()
    reports = [parse_axis_line(t) for t in f.texts() if parse_axis_line(t) is not None]
    assert [r.axis for r in reports] == ["roll", "pitch", "yaw"]
    for r in reports:  # the simulated plant: b = 1, tau = 20 ms
        assert r.effectiveness == pytest.approx(1.0, rel=0.05) and r.motor_tau_s == pytest.approx(0.02, rel=0.1)
        assert r.phase_margin_deg[1] >= 44.9 and r.gain_margin_db[1] >= 6.0  # (the design: 45 deg, 6 dB)
    assert np.all(f.peak_rate_sp <= f.params.get("MC_AT_SYSID_AMP") + 1e-12)
    assert f.params.values() == before  # nothing applied yet
    assert f.tune.command(2, Mode.POSCTL, True, True, f.now_us) is Reply.ACCEPTED
    roll = reports[0]
    assert f.params.get("MC_ROLLRATE_P") == pytest.approx(roll.gains_new[0], rel=1e-3)
    assert f.params.get("MC_YAWRATE_I") == pytest.approx(reports[2].gains_new[1], rel=1e-3)
    assert f.tune.phase is Phase.IDLE and f.tune.progress == 100


def one_axis_run(axes: int, apply: int = 0) -> tuple[Flight, dict]:
    """A flight that has run the autotune over one axis (MC_AT_AXES ``axes``, MC_AT_APPLY ``apply``) in Hold,
    and the parameter values from before the run."""
    f = Flight()
    f.params.set("MC_AT_AXES", axes)
    f.params.set("MC_AT_APPLY", apply)
    before = f.params.values()
    f.tune.command(1, Mode.AUTO_LOITER, True, True, f.now_us)
    f.steps(int((SETTLE_S + EXCITE_S) / DT) + 10)
    return f, before


def test_reject_drops_the_proposal_and_accept_then_has_nothing_to_apply():
    f, before = one_axis_run(1)  # roll only
    assert f.tune.phase is Phase.READY
    assert f.tune.command(0, Mode.AUTO_LOITER, True, True, f.now_us) is Reply.ACCEPTED
    assert f.tune.command(2, Mode.AUTO_LOITER, True, True, f.now_us) is Reply.DENIED
    assert f.params.values() == before


def test_mc_at_apply_2_applies_the_proposal_at_once_in_the_air_as_px4():
    f, _ = one_axis_run(4, apply=2)  # yaw only
    (report,) = [r for r in map(parse_axis_line, f.texts()) if r is not None]
    assert report.axis == "yaw" and f.tune.phase is Phase.IDLE
    assert f.params.get("MC_YAWRATE_P") == pytest.approx(report.gains_new[0], rel=1e-3)
    assert f.params.get("MC_YAWRATE_I") == pytest.approx(report.gains_new[1], rel=1e-3)
    assert f.params.get("MC_ROLLRATE_P") == f.params.default("MC_ROLLRATE_P")
    assert f.texts()[-1].startswith("Autotune: new gains applied")


def test_mc_at_apply_1_applies_the_proposal_at_the_next_disarm_as_px4():
    f, _ = one_axis_run(2, apply=1)  # pitch only
    assert f.tune.phase is Phase.READY and "next disarm" in f.texts()[-1]
    proposal = f.tune.proposals[0].gains_new
    f.steps(10)  # still armed: nothing applied
    assert f.params.get("MC_PITCHRATE_P") == f.params.default("MC_PITCHRATE_P")
    f.steps(1, armed=False)
    assert f.params.get("MC_PITCHRATE_P") == pytest.approx(proposal.p, rel=1e-6)
    assert f.params.get("MC_ROLLRATE_P") == f.params.default("MC_ROLLRATE_P")
