"""The several-vehicle landing's driver (gcs/launcher/multi_landing.py) without a stack: one world, one hold set on
vehicle 0's simulator component, every vehicle waited for at each hold; and its summary."""

from __future__ import annotations

import math

import pytest

from gcs.launcher.landing_run import LandingResult, LandingSetup
from gcs.launcher.multi_landing import WorldStepper, fly_multi_landing, summary
from gcs.launcher.sim_stepper import SimTimeout


class FakeTruth:
    def __init__(self) -> None:
        self.sets: list[tuple[str, int]] = []

    def set(self, name: str, value: int, timeout_s: float = 0.0) -> None:
        self.sets.append((name, value))


class FakeClient:
    def wait_until(self, cond, timeout_s: float, what: str) -> None:
        assert cond(), what  # the vehicle's "held at" report has come by then


class FakeStepper:
    """A SimStepper's part the world stepper uses: a vehicle that holds wherever the world holds."""

    def __init__(self, world: list[int]) -> None:
        self.world, self.truth, self.client = world, FakeTruth(), FakeClient()
        self.time_ms, self.slices, self.timeout_s, self.heartbeats = 100, 0, 1.0, 0
        self.vehicle_held_ms = 100

    def _heartbeat_if_due(self) -> None:
        self.heartbeats += 1

    def _wait_held(self, hold_ms: int) -> int:
        assert self.world[-1] == hold_ms  # the world's hold, set once on vehicle 0's component
        self.vehicle_held_ms = hold_ms
        return hold_ms


def world_of(n: int) -> tuple[WorldStepper, list[FakeStepper]]:
    holds: list[int] = []
    steppers = [FakeStepper(holds) for _ in range(n)]
    steppers[0].truth.set = lambda name, v, timeout_s=0.0: holds.append(v)  # type: ignore[method-assign]
    return WorldStepper(steppers), steppers


def test_one_hold_for_the_world_and_every_vehicle_waited_for():
    world, steppers = world_of(3)
    world.advance(2.5)  # in holds at most a second apart (a ground-station HEARTBEAT may be due at each)
    assert steppers[0].world == [1100, 2100, 2600]
    assert all(s.time_ms == 2600 and s.slices == 3 and s.heartbeats == 3 for s in steppers)
    assert all(s.truth.sets == [] for s in steppers[1:])  # the others' components are not asked to hold


def test_run_until_reads_the_condition_at_each_hold_and_gives_up_in_simulated_time():
    world, steppers = world_of(2)
    seen = []
    world.run_until(lambda: seen.append(world.time_ms) or len(seen) == 3, 5.0, "three looks")
    assert seen == [100, 200, 300]
    with pytest.raises(SimTimeout, match="never"):
        world.run_until(lambda: False, 0.5, "never")
    assert world.time_ms == 800


def test_a_free_running_setup_is_refused():
    with pytest.raises(ValueError, match="deterministic"):
        fly_multi_landing([], [], LandingSetup(deterministic=False))


def test_the_summary_says_per_vehicle_on_its_deck_and_the_error():
    ok = LandingResult(success=True, touchdown_error_m=0.034, time_to_land_s=7.2, ugv_speed_at_touchdown_m_s=1.09,
                       sim_s=18.7, wall_s=13.0)  # fmt: skip
    off = LandingResult(touchdown_error_m=0.71, reason="touched down off the deck", sim_s=18.7, wall_s=13.0)
    text = summary([ok, off], [62, 63])
    assert "vehicle 0 (sysid 62): landed on its deck; touchdown error 0.034 m (truth)" in text
    assert "vehicle 1 (sysid 63): NOT on its deck (touched down off the deck); touchdown error 0.710 m" in text
    assert "real-time factor: 1.44 (18.7 simulated s / 13.0 wall s)" in text
    assert math.isnan(LandingResult().touchdown_error_m)
