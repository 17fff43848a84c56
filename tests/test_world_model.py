"""Several multicopters in one MuJoCo world (sitl.simulation.World), in-process: no sockets, no clocks.

A world of one vehicle is the single-vehicle simulator, step for step; in a world of two, each vehicle
has its own body, rotors, sensors (its own seed) and truth from its own start point, and the world
steps both with the commands of both.
"""

from __future__ import annotations

import numpy as np
import pytest

from sitl.model import Placement, build_world_mjcf, part_name
from sitl.multicopter import vehicle_seed
from sitl.simulation import LOCKSTEP_DT_S, Simulation, VehicleView, World, spread

HOME = (47.397742, 8.545594, 488.0)
SECONDS = 1.5


def commands(spec, n_steps: int, seed: int = 0) -> list[np.ndarray]:
    """Motor commands that lift a vehicle off and wobble it: 10 % above hover with noise."""
    hover = spec.hover_speed_rad_s / spec.max_speed_rad_s
    rng = np.random.default_rng(seed)
    return [np.clip(1.1 * hover + 0.05 * rng.standard_normal(len(spec.rotors)), 0, 1) for _ in range(n_steps)]


def same_truth(a, b) -> bool:
    fields = ("pos_ned_m", "vel_ned_m_s", "q_ned_frd", "rate_frd_rad_s", "specific_force_frd_m_s2", "wind_ned_m_s")
    return a.time_us == b.time_us and all(np.array_equal(getattr(a, f), getattr(b, f)) for f in fields)


def test_a_one_vehicle_world_is_the_single_vehicle_simulator_step_for_step(quad):
    lone = Simulation(quad, HOME, seed=5)
    world = World(spread(quad, 1), HOME, seed=5)
    v0 = VehicleView(world, 0)
    for cmd in commands(quad, round(SECONDS / LOCKSTEP_DT_S)):
        lone.step(cmd)
        world.step([cmd])
        assert same_truth(lone.truth(), v0.truth())
        assert lone.sensor_truth() == v0.sensor_truth()
    assert -lone.truth().pos_ned_m[2] > 0.5  # it flew


def test_two_vehicles_build_into_one_model_side_by_side(quad):
    xml = build_world_mjcf(spread(quad, 2))
    assert 'name="vehicle"' in xml and f'name="{part_name(1, "vehicle")}"' in xml
    world = World(spread(quad, 2), HOME, seed=5)
    gimbal = 3 if quad.camera.gimballed else 0  # each vehicle's gimbal servos follow its rotors
    assert world.model.nu == 2 * (len(quad.rotors) + gimbal) and world.model.nsensor == 4
    v0, v1 = world.vehicles
    assert (v0.ctrl0, v0.ctrl1, v1.ctrl0) == (0, 4, 4 + gimbal)
    east_m = v1.start_xy_enu[0] - v0.start_xy_enu[0]
    assert east_m == pytest.approx(3.0, abs=1e-3)  # 3 m East, on their legs
    for k in (0, 1):  # each vehicle's truth from its own start point
        assert VehicleView(world, k).truth().pos_ned_m[:2] == pytest.approx([0.0, 0.0], abs=1e-6)
    lat0, lon0, _ = v0.sensors.home
    lat1, lon1, _ = v1.sensors.home
    assert lat1 == lat0 and lon1 > lon0  # vehicle 1's home is its own spot, East of vehicle 0's


def test_two_vehicles_step_together_each_with_its_own_commands_and_seed(quad):
    world = World(spread(quad, 2), HOME, seed=5)
    lone = Simulation(quad, HOME, seed=5)
    idle = np.zeros(len(quad.rotors))
    for cmd in commands(quad, round(SECONDS / LOCKSTEP_DT_S)):
        world.step([cmd, idle])  # vehicle 0 flies, vehicle 1 stays on the ground
        lone.step(cmd)
    v0, v1 = VehicleView(world, 0), VehicleView(world, 1)
    assert world.time_us == lone.time_us == round(SECONDS / LOCKSTEP_DT_S) * round(LOCKSTEP_DT_S * 1e6)
    # vehicle 0 flies as it would alone (the other one is far from it: separate contact islands)
    assert v0.truth().pos_ned_m == pytest.approx(lone.truth().pos_ned_m, abs=1e-6)
    assert -v0.truth().pos_ned_m[2] > 0.5
    assert -v1.truth().pos_ned_m[2] == pytest.approx(0.2, abs=0.01)  # still on its legs
    assert v1.rotors.speeds == [0.0] * len(quad.rotors) and v0.battery.consumed_mah > v1.battery.consumed_mah
    assert vehicle_seed(5, 0) == 5 and vehicle_seed(5, 1) not in (5, vehicle_seed(5, 2))
    t0, t1 = v0.sensor_truth(), v1.sensor_truth()
    r0 = v0.sensors.imu(t1.specific_force_frd_m_s2, t1.rate_frd_rad_s, t1.r_ned_frd, t1.pos_ned_m, dt_s=LOCKSTEP_DT_S)
    r1 = v1.sensors.imu(t1.specific_force_frd_m_s2, t1.rate_frd_rad_s, t1.r_ned_frd, t1.pos_ned_m, dt_s=LOCKSTEP_DT_S)
    assert r0.accel_frd_m_s2 != r1.accel_frd_m_s2  # own noise draws: the same input reads differently
    assert t0 != t1


def test_vehicles_of_a_world_can_touch(quad):
    """Two vehicles placed 0.3 m apart collide (MuJoCo contacts between their frames and legs)."""
    world = World([Placement(quad), Placement(quad, (0.3, 0.0))], HOME, seed=1)
    world.step([np.zeros(4), np.zeros(4)])
    b0, b1 = (world.model.body(part_name(k, "vehicle")).id for k in (0, 1))
    touching = {
        frozenset((world.model.geom_bodyid[c.geom1], world.model.geom_bodyid[c.geom2]))
        for c in world.data.contact[: world.data.ncon]
    }
    assert frozenset((b0, b1)) in touching


def test_sitl_count_must_keep_every_instance_within_0_99(capsys):
    from sitl.__main__ import main

    assert main(["--count", "3", "-i", "98"]) == 2
    assert "instance 100" in capsys.readouterr().err
