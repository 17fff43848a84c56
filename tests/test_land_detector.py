"""The land detector (autopilot.navigation.land_detector): trigger time, hysteresis, disarmed.

No sockets, no processes, no clocks.  (From tests/test_units.py, split by subject.)
"""

from __future__ import annotations

import numpy as np
import pytest

from autopilot.navigation.land_detector import LandDetector, Landed
from autopilot.param_catalogue import default_store


class LandRun:
    def __init__(self, trig_time_s: float = 1.0) -> None:
        self.params = default_store()
        self.params.set("LNDMC_TRIG_TIME", trig_time_s)
        self.ld = LandDetector(self.params)
        self.ld.on_arm(0.0)
        self.t_us = 0
        self.log: list[tuple[float, Landed, bool]] = []

    def run(self, seconds: float, vel=(0.0, 0.0, 0.0), down: float = 0.0, thrust: float = 0.5) -> Landed:
        end = self.t_us + round(seconds * 1e6)
        while self.t_us < end:
            self.t_us += 20_000
            state = self.ld.update(self.t_us, True, np.array(vel), down, thrust)
            self.log.append((self.t_us / 1e6, state, self.ld.ground_contact))
        return self.ld.state

    def first(self, since_s: float, pred) -> float:
        return next(t for t, s, c in self.log if t > since_s and pred(s, c))


def take_off(r: LandRun) -> None:
    assert r.run(1.0, thrust=0.5) is Landed.ON_GROUND  # armed, idle
    assert r.run(1.0, thrust=1.0) is Landed.ON_GROUND  # thrust, but not off the ground
    assert r.run(1.0, vel=(0, 0, -1.0), down=-2.0, thrust=1.0) is Landed.IN_AIR
    assert r.run(2.0, vel=(1.0, 0, 0), down=-2.0, thrust=1.0) is Landed.IN_AIR


def test_land_detector_declares_landing_after_trigger_time():
    r = LandRun()
    take_off(r)
    t0 = r.t_us / 1e6
    assert r.run(5.0) is Landed.ON_GROUND  # quiet: low speeds, low thrust
    contact = r.first(t0, lambda s, c: c)
    landed = r.first(t0, lambda s, c: s is Landed.ON_GROUND)
    assert landed - contact == pytest.approx(1.0, abs=0.021)  # LNDMC_TRIG_TIME of hysteresis
    assert r.ld.landed_since_us == round(landed * 1e6)


def test_land_detector_trigger_time_is_the_parameter():
    r = LandRun(trig_time_s=2.5)
    take_off(r)
    t0 = r.t_us / 1e6
    assert r.run(6.0) is Landed.ON_GROUND
    contact = r.first(t0, lambda s, c: c)
    landed = r.first(t0, lambda s, c: s is Landed.ON_GROUND)
    assert landed - contact == pytest.approx(2.5, abs=0.021)


def test_land_detector_hysteresis_restarts_on_disturbance():
    r = LandRun()
    take_off(r)
    t0 = r.t_us / 1e6
    r.run(1.0)  # quiet long enough to start counting, not to land
    assert r.ld.state is Landed.IN_AIR and r.ld.ground_contact
    r.run(0.3, vel=(0, 0, 2.0))  # a gust: sinking fast again
    assert r.ld.state is Landed.IN_AIR and not r.ld.ground_contact
    t_quiet = r.t_us / 1e6
    assert r.run(4.0) is Landed.ON_GROUND
    assert r.first(t0, lambda s, c: s is Landed.ON_GROUND) >= t_quiet + 1.0
    assert all(s is Landed.IN_AIR for t, s, c in r.log if t0 < t <= t_quiet)


def test_land_detector_on_ground_when_disarmed():
    ld = LandDetector()
    ld.on_arm(0.0)
    ld.state = Landed.IN_AIR
    assert ld.update(1_000_000, False, np.zeros(3), -3.0, 1.0) is Landed.ON_GROUND
    assert ld.landed_since_us == 1_000_000
