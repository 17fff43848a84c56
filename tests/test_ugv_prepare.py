"""The simulator works out the ground vehicle's next command while it waits for the flight controller
(``World.prepare_step``, issue 38): the world steps exactly as without it, and a setting changed in between wins."""

from __future__ import annotations

import numpy as np
import pytest

from params.vehicle import load_vehicle
from sitl.sim_settings import PATH_CIRCLE, PATH_FIGURE8, PATH_LINE, UgvSettings
from sitl.simulation import Simulation

HOME = (47.397742, 8.545594, 488.0)


def _sim(path: int) -> Simulation:
    return Simulation(
        load_vehicle("quad_x"), HOME, seed=3, ugv=UgvSettings(enabled=1, north_m=3.0, path=path, speed_m_s=2.0)
    )


def _state(sim: Simulation) -> bytes:
    d = sim.data
    return np.concatenate([d.qpos, d.qvel, d.ctrl]).tobytes()


def _fly(sim: Simulation, steps: int, prepare: bool, change_at: int | None = None) -> list[bytes]:
    hover = np.full(sim.rotors.n, 0.3)
    out = []
    for k in range(steps):
        if prepare:
            sim.world.prepare_step()
        if k == change_at:  # (as a SIM_UGV_* set between the prepare and the step would)
            sim.ugv_settings.speed_m_s = 1.0
        sim.step(hover)
        out.append(_state(sim))
    return out


@pytest.mark.parametrize("path", [PATH_LINE, PATH_CIRCLE, PATH_FIGURE8])
def test_a_prepared_step_is_the_step(path):
    plain = _fly(_sim(path), 400, prepare=False)
    prepared = _fly(_sim(path), 400, prepare=True)
    assert plain == prepared
    assert plain[0] != plain[-1]  # (the UGV moved)


def test_a_setting_changed_after_the_prepare_acts_on_that_step():
    plain = _fly(_sim(PATH_CIRCLE), 200, prepare=False, change_at=120)
    prepared = _fly(_sim(PATH_CIRCLE), 200, prepare=True, change_at=120)
    assert plain == prepared
    unchanged = _fly(_sim(PATH_CIRCLE), 200, prepare=True)
    assert unchanged[120] != prepared[120]  # (the change did act, from that very step)
