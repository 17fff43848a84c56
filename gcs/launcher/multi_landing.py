"""Several precision landings at once: each multicopter of one world (``sitl --count N`` with the UGV) on its own
moving ground vehicle, flown through MAVLink and each scored from its own truth.

The flight of each vehicle is :mod:`.landing_run`'s (arm, take off to ``PLD_PREP_ALT``, fly to the meeting point
over its UGV's path, start its UGV, MAV_CMD_NAV_LAND with precision landing required, wait for the motors to cut);
here the N vehicles fly it side by side, each phase given to every vehicle before the world moves on.  Each vehicle
has its own UGV (its own ``SIM_UGV_*`` settings on its own simulator component, NED from its own start point), its
own camera and companion that look for its own deck's marker ids only (sitl: :func:`vision.pad.vehicle_pad`).
Nothing here steers a multicopter towards its UGV.

Scoring, per vehicle, as :mod:`.landing_run` (its :class:`~.landing_run.LandingResult`): the touchdown error at its
disarm from its own truth (UDP 14740+I+k), success when it stands on its own deck ``STAY_ON_DECK_S`` after the last
vehicle's disarm.

Reproducible: the world starts held (``SIM_HOLD_MS``) and is moved on in slices by :class:`WorldStepper` (one world,
one clock, one hold; every vehicle's flight controller reports "held" before a condition is read), as one landing's
:class:`~.sim_stepper.SimStepper`; the phases' limits are simulated seconds.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Callable, Sequence

from pymavlink.dialects.v20 import common as mavlink

from params.vehicle import load_vehicle
from sitl.ugv import UgvGeometry

from ..client import VehicleClient
from ..sim_client import SimClient
from .deck_stance import STAY_ON_DECK_S, Stance
from .landing_run import (
    ARRIVAL_RADIUS_M,
    LAND_SIM_S,
    MEET_SIM_S,
    PREP_ALT_M,
    READY_CHECK_EVERY_S,
    READY_SIM_S,
    TAKEOFF_SIM_S,
    LandingResult,
    LandingSetup,
    _Judge,
    _phase_listener,
    _verdict,
    configure,
)
from .sim_stepper import HEARTBEAT_EVERY_MS, HOLD_PARAM, SimStepper, SimTimeout

GAVE_UP = "Precision landing failed"


class WorldStepper:
    """Hold-and-advance driver of one world of several vehicles: one :class:`SimStepper` per vehicle (its client,
    its truth), the hold set once (vehicle 0's component: one world, one hold), every vehicle's simulator component
    and flight controller waited for at each hold."""

    def __init__(self, steppers: Sequence[SimStepper]) -> None:
        self.steppers = list(steppers)

    @property
    def time_ms(self) -> int:
        return self.steppers[0].time_ms

    def start(self) -> None:
        """Wait until the world holds, and every vehicle with it (:meth:`SimStepper.start`)."""
        for s in self.steppers:
            s.start()

    def advance(self, sim_s: float) -> None:
        """Move the world's hold ``sim_s`` on (in holds at most a HEARTBEAT period apart, each vehicle's ground-station
        HEARTBEAT sent when due) and wait until every vehicle holds there."""
        first = self.steppers[0]
        end_ms = self.time_ms + max(1, round(sim_s * 1000))
        while self.time_ms < end_ms:
            hold_ms = min(end_ms, self.time_ms + HEARTBEAT_EVERY_MS)
            for s in self.steppers:
                s._heartbeat_if_due()
            first.truth.set(HOLD_PARAM, hold_ms, timeout_s=first.timeout_s)
            for s in self.steppers:
                s.slices += 1
                s.time_ms = s._wait_held(hold_ms)
            for s in self.steppers:
                t = s.time_ms
                s.client.wait_until(lambda s=s, t=t: s.vehicle_held_ms >= t, s.timeout_s, f"the vehicle held at {t} ms")

    def run_until(self, predicate: Callable[[], object], max_sim_s: float, what: str, check_every_s: float = 0.1):
        """Advance in slices of ``check_every_s`` until ``predicate()`` (read while held) holds; SimTimeout after
        ``max_sim_s`` simulated seconds."""
        end_ms = self.time_ms + round(max_sim_s * 1000)
        while not (value := predicate()):
            if self.time_ms >= end_ms:
                raise SimTimeout(f"{what}: not within {max_sim_s:g} s of simulated time")
            self.advance(min(check_every_s, (end_ms - self.time_ms) / 1000.0))
        return value

    def release(self) -> None:
        """Stop listening; the world stays held until the stack stops (the cameras count the same frames)."""
        for s in self.steppers:
            s.release(run_free=False)


@dataclass
class _Vehicle:
    """One vehicle of the flight: its client, truth, judge and result."""

    k: int
    client: VehicleClient
    truth: SimClient
    judge: _Judge
    result: LandingResult
    first: Stance | None = None  # its stance at the disarm
    t_land_ms: int = 0

    def gave_up(self) -> bool:
        return any(GAVE_UP in p for p in self.result.phases)

    def down(self) -> bool:
        """Disarmed, given up, or already scored."""
        return self.first is not None or bool(self.result.reason) or not self.client.armed() or self.gave_up()


def fly_multi_landing(
    clients: Sequence[VehicleClient],
    truths: Sequence[SimClient],
    setup: LandingSetup,
    say: Callable[[str], None] = lambda _t: None,
    timeout_s: float = 60.0,
    geom: UgvGeometry | None = None,
) -> list[LandingResult]:
    """Fly vehicle k (``clients[k]``, ``truths[k]``) onto its own UGV for every k at once (see the module docstring);
    each vehicle's result.  ``setup`` must be stepped (``deterministic``); its geometry is each vehicle's, from its
    own start point."""
    if not setup.stepped:
        raise ValueError("fly_multi_landing flies through holds: the setup must be deterministic")
    spec = load_vehicle(setup.vehicle)
    legs = (spec.leg_positions_frd_m, spec.leg_size_m)
    fleet = []
    for k, (client, truth) in enumerate(zip(clients, truths)):
        v = _Vehicle(k, client, truth, _Judge(truth, geom or UgvGeometry(), legs), LandingResult())
        client.add_listener(lambda m, r=v.result: _phase_listener(m, r))
        fleet.append(v)
    step = WorldStepper([SimStepper(v.client, v.truth, timeout_s=timeout_s) for v in fleet])
    step.start()
    wall0, sim0_ms = time.monotonic(), step.time_ms  # (the real-time factor's window: LandingResult.sim_s)
    try:
        _to_the_meeting_points(step, fleet, setup, say)
        _land_all(step, fleet, setup, say)
    finally:
        for v in fleet:
            v.result.sim_s, v.result.wall_s = (step.time_ms - sim0_ms) / 1000.0, time.monotonic() - wall0
        step.release()
    return [v.result for v in fleet]


def _to_the_meeting_points(step: WorldStepper, fleet: list[_Vehicle], setup: LandingSetup, say) -> None:
    """Every vehicle ready, armed, up at ``PREP_ALT_M`` and over its meeting point."""
    ready = lambda: all(v.client.prearm_ok() and v.client.home() is not None for v in fleet)  # noqa: E731
    step.run_until(ready, READY_SIM_S, "every vehicle ready to arm", check_every_s=READY_CHECK_EVERY_S)
    for v in fleet:
        v.judge.rest(step.time_ms)
        configure(v.client, setup, say)
        v.client.arm(timeout_s=10).check()
        v.client.takeoff(v.client.home().alt_amsl_m + PREP_ALT_M, timeout_s=10).check()
    step.run_until(lambda: all(v.client.takeoff_done(PREP_ALT_M) for v in fleet), TAKEOFF_SIM_S, "every take-off")
    meet_n, meet_e = setup.meeting_point()
    for v in fleet:
        v.client.goto_ned(meet_n, meet_e, -PREP_ALT_M, timeout_s=10).check()
    say(f"{len(fleet)} vehicles flying to their meeting points N {meet_n:.2f} E {meet_e:.2f} (each from its start)")
    arrived = lambda: all(v.client.arrived(meet_n, meet_e, ARRIVAL_RADIUS_M, 0.3) for v in fleet)  # noqa: E731
    step.run_until(arrived, MEET_SIM_S, "every meeting point")


def _land_all(step: WorldStepper, fleet: list[_Vehicle], setup: LandingSetup, say) -> None:
    """Each UGV started, each vehicle told to land on it; each scored at its disarm, all STAY_ON_DECK_S after the
    last one."""
    for v in fleet:
        if setup.speed_m_s > 0.0:
            v.truth.set("SIM_UGV_SPD", setup.speed_m_s)  # its own UGV (its own SIM_UGV_* settings)
        v.t_land_ms = step.time_ms
        v.client.command_long(mavlink.MAV_CMD_NAV_LAND, 0, setup.mode, 0, *[math.nan] * 4).check()
    say(f"UGVs driving ({setup.path} at {setup.speed_m_s:g} m/s); {len(fleet)} precision landings")

    def all_down() -> bool:
        for v in fleet:
            if v.first is None and not v.result.reason and v.down():
                _touchdown(v, step.time_ms)
        return all(v.down() for v in fleet)

    try:
        step.run_until(all_down, LAND_SIM_S, "every vehicle's motors cut on its deck")
    except SimTimeout:
        for v in fleet:
            if v.first is None and not v.result.reason:
                v.result.reason = "no touchdown in time"
    step.advance(STAY_ON_DECK_S)
    for v in fleet:
        if v.first is not None:
            _verdict(v.result, v.first, v.judge.score(step.time_ms))


def _touchdown(v: _Vehicle, at_ms: int) -> None:
    """Vehicle ``v`` just disarmed (or gave up) at the hold ``at_ms``: its score then."""
    r = v.result
    if v.gave_up():
        r.reason = "target lost: " + " | ".join(r.phases[-2:])
        return
    r.time_to_land_s = (at_ms - v.t_land_ms) / 1000.0
    score = v.judge.score(at_ms)
    if score is None:
        r.reason = "no truth at touchdown"
        return
    r.touchdown_error_m, r.ugv_speed_at_touchdown_m_s, v.first = score


def summary(results: Sequence[LandingResult], sysids: Sequence[int]) -> str:
    """Per vehicle: on its own deck or not, its touchdown error (truth); the flight's real-time factor."""
    lines = ["", f"=== {len(results)} precision landings, each vehicle on its own moving UGV ==="]
    for k, (r, sysid) in enumerate(zip(results, sysids)):
        where = "landed on its deck" if r.success else f"NOT on its deck ({r.reason or 'no verdict'})"
        lines.append(
            f"vehicle {k} (sysid {sysid}): {where}; touchdown error {r.touchdown_error_m:.3f} m (truth), "
            f"{r.time_to_land_s:.1f} s from NAV_LAND, UGV at {r.ugv_speed_at_touchdown_m_s:.2f} m/s"
        )
    if results:
        r = results[0]
        lines.append(f"real-time factor: {r.real_time_factor:.2f} ({r.sim_s:.1f} simulated s / {r.wall_s:.1f} wall s)")
    return "\n".join(lines)
