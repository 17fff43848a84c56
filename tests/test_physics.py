"""The simulated physics checked against [F]'s equations, for both vehicles.

Everything runs through :class:`sitl.simulation.Simulation` (MuJoCo, rotor lag,
aerodynamics, wind) with nothing else in the loop; frames are NED/FRD as the
simulator reports its truth.
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from autopilot.control.mixer import Mixer
from mavsim_core import quaternion as quat
from mavsim_core.constants import GRAVITY_M_S2 as G
from params.vehicle import load_vehicle
from sitl.simulation import LOCKSTEP_DT_S, Simulation

HOME = (47.397742, 8.545594, 488.0)
VEHICLES = ["quad_x", "firefly"]


def airborne(spec, altitude_m: float = 20.0, seed: int = 1) -> Simulation:
    """A simulation with the vehicle at rest in the air, rotors at hover speed (lag settled)."""
    sim = Simulation(spec, HOME, seed=seed)
    sim.data.qpos[2] = altitude_m
    sim.data.qvel[:] = 0.0
    sim.rotors.speeds = [spec.hover_speed_rad_s] * len(spec.rotors)
    return sim


def commands_for(spec, thrusts_n) -> np.ndarray:
    """Motor commands 0..1 whose steady rotor speeds give these thrusts (T = k_T w^2)."""
    return np.sqrt(np.asarray(thrusts_n) / spec.k_thrust) / spec.max_speed_rad_s


def hold_speeds(sim: Simulation, thrusts_n) -> np.ndarray:
    """Put the rotors at the speeds of these thrusts (no lag transient) and return the commands."""
    sim.rotors.speeds = [math.sqrt(t / sim.spec.k_thrust) for t in thrusts_n]
    return commands_for(sim.spec, thrusts_n)


@pytest.mark.parametrize("name", VEHICLES)
def test_hover_rotor_speed_is_sqrt_mg_over_n_kt(name):
    """Closed-loop altitude hold in the simulator alone: the rotor speed it settles at is eq (4.8)'s."""
    spec = load_vehicle(name)
    sim = airborne(spec, 10.0)
    n = len(spec.rotors)
    trim = spec.hover_speed_rad_s / spec.max_speed_rad_s * 0.9  # start 10 % low: the integrator must find hover
    gain = 26.0  # about d(accel)/d(command) near hover: 2 g / command
    speeds = []
    for k in range(round(12.0 / LOCKSTEP_DT_S)):
        t = sim.truth()
        err_m, climb_m_s = t.pos_ned_m[2] + 10.0, -t.vel_ned_m_s[2]  # below 10 m is positive error
        trim += 1.0 * err_m / gain * LOCKSTEP_DT_S  # PID on truth, no feed-forward of m g
        sim.step(np.full(n, trim + (4.0 * err_m - 4.0 * climb_m_s) / gain))
        if k * LOCKSTEP_DT_S > 8.0:
            speeds.append(np.mean(sim.rotors.speed_rad_s))
    expected = math.sqrt(spec.mass_kg * G / (n * spec.k_thrust))
    assert abs(sim.truth().vel_ned_m_s[2]) < 0.05
    assert np.mean(speeds) == pytest.approx(expected, rel=0.01)
    assert tilt_deg(sim.truth().q_ned_frd) < 0.5  # equal thrusts: no torque on either frame


def tilt_deg(q) -> float:
    roll, pitch, _ = quat.to_euler(q)
    return math.degrees(max(abs(roll), abs(pitch)))


@pytest.mark.parametrize("name", VEHICLES)
@pytest.mark.parametrize("axis", [0, 1])
def test_roll_and_pitch_torque_step_gives_tau_over_inertia(name, axis):
    spec = load_vehicle(name)
    sim = airborne(spec)
    mixer = Mixer(spec)
    torque = np.zeros(3)
    torque[axis] = 0.2  # N m about FRD x (roll) or y (pitch)
    hover_n = spec.mass_kg * G
    thrusts = mixer.b_pinv @ np.array([*torque, hover_n])
    assert mixer.wrench(thrusts) == pytest.approx([*torque, hover_n])
    cmds = hold_speeds(sim, thrusts)
    steps = 5
    for _ in range(steps):
        sim.step(cmds)
    rate = sim.truth().rate_frd_rad_s
    alpha = rate / (steps * LOCKSTEP_DT_S)
    expected = torque[axis] / spec.inertia_kg_m2[axis]
    assert alpha[axis] == pytest.approx(expected, rel=0.02)
    assert abs(alpha[1 - axis]) < 0.02 * expected and abs(alpha[2]) < 0.02 * expected


@pytest.mark.parametrize("name", VEHICLES)
def test_yaw_command_turns_the_right_way_for_the_spin_directions(name):
    """A positive yaw torque from the flight controller's mixer (FRD z, down: clockwise seen from
    above) turns the simulated vehicle clockwise: heading increases, at tau / I_zz."""
    spec = load_vehicle(name)
    sim = airborne(spec)
    mixer = Mixer(spec)
    out = mixer.mix(np.array([0.0, 0.0, 0.05]), spec.mass_kg * G)
    cmds = hold_speeds(sim, out.thrusts_n)
    yaw0 = quat.to_euler(sim.truth().q_ned_frd)[2]
    for _ in range(50):
        sim.step(cmds)
    t = sim.truth()
    assert t.rate_frd_rad_s[2] > 0
    assert quat.to_euler(t.q_ned_frd)[2] > yaw0
    alpha = t.rate_frd_rad_s[2] / (50 * LOCKSTEP_DT_S)
    assert alpha == pytest.approx(0.05 / spec.inertia_kg_m2[2], rel=0.02)


@pytest.mark.parametrize("name", VEHICLES)
def test_steady_wind_drag_force_matches_eq_4_12(name):
    """Hovering vehicle held level in a steady 5 m/s wind from the West: the horizontal force is
    F_d = sum_i w_i k_d V_a_perp (eqs 4.11-4.14), pointing downwind (East)."""
    spec = dataclasses.replace(load_vehicle(name), body_drag_cd_area_m2=(0.0, 0.0, 0.0))  # rotor drag alone
    sim = airborne(spec)
    sim.wind_settings.speed_m_s = 5.0
    sim.wind_settings.direction_deg = 270.0  # from the West: the air moves East
    n = len(spec.rotors)
    cmds = hold_speeds(sim, [spec.mass_kg * G / n] * n)
    sim.step(cmds)
    t = sim.truth()
    assert t.wind_ned_m_s == pytest.approx([0.0, 5.0, 0.0], abs=1e-9)
    v_a = t.wind_ned_m_s - t.vel_ned_m_s  # relative wind (4.11); the disc is level, so all of it is in-plane
    expected = sum(sim.rotors.speeds) * spec.rotor_drag_k_d * v_a[:2]
    force = spec.mass_kg * t.accel_ned_m_s2[:2]
    assert force == pytest.approx(expected, rel=0.01, abs=1e-4)
    assert force[1] > 0.2  # a real push East, not a rounding error


@pytest.mark.parametrize("name", VEHICLES)
def test_rolling_moment_matches_eq_4_13(name):
    """In a steady side wind the body feels M_r = sum_i w_i k_r V_a_perp (4.13, 4.15) about the wind axis
    (plus the moment of the rotor drag forces about the centre of mass: the rotors sit above it)."""
    spec = dataclasses.replace(load_vehicle(name), body_drag_cd_area_m2=(0.0, 0.0, 0.0))
    sim = airborne(spec)
    sim.wind_settings.speed_m_s = 5.0
    sim.wind_settings.direction_deg = 180.0  # from the South: the air moves North, along body x
    n = len(spec.rotors)
    cmds = hold_speeds(sim, [spec.mass_kg * G / n] * n)
    sim.step(cmds)
    t = sim.truth()
    w_sum = sum(sim.rotors.speeds)
    v_a = 5.0  # along body x (facing North), FRD and FLU agree on x
    m_roll = w_sum * spec.rolling_moment_k_r * v_a  # about +x, eq (4.13)
    z_rotor_up = -spec.rotors[0].position_frd_m[2]  # rotors above the CoM
    # r x F_d: drag at the rotors pitches the nose... (FLU y)
    m_pitch_flu = z_rotor_up * w_sum * spec.rotor_drag_k_d * v_a
    alpha = t.rate_frd_rad_s / LOCKSTEP_DT_S
    assert alpha[0] == pytest.approx(m_roll / spec.inertia_kg_m2[0], rel=0.05)
    assert alpha[1] == pytest.approx(-m_pitch_flu / spec.inertia_kg_m2[1], rel=0.05)  # FRD y = -FLU y


@pytest.mark.parametrize("name", VEHICLES)
def test_free_fall_is_g(name):
    spec = dataclasses.replace(load_vehicle(name), body_drag_cd_area_m2=(0.0, 0.0, 0.0))
    sim = airborne(spec, 30.0)
    sim.rotors.speeds = [0.0] * len(spec.rotors)
    z0 = sim.truth().pos_ned_m[2]
    steps = round(1.0 / LOCKSTEP_DT_S)
    for _ in range(steps):
        sim.step(np.zeros(len(spec.rotors)))
    t = sim.truth()
    assert t.accel_ned_m_s2 == pytest.approx([0.0, 0.0, G], abs=1e-3)
    assert t.vel_ned_m_s[2] == pytest.approx(G, rel=1e-3)
    assert t.pos_ned_m[2] - z0 == pytest.approx(0.5 * G, rel=0.01)
    assert t.specific_force_frd_m_s2 == pytest.approx([0.0, 0.0, 0.0], abs=1e-3)


def test_body_drag_slows_a_fall():
    """With the body drag of the vehicle file a falling quadcopter accelerates at g at first and
    tends to its terminal speed sqrt(2 m g / (rho Cd A))."""
    spec = load_vehicle("quad_x")
    sim = airborne(spec, 200.0)
    sim.rotors.speeds = [0.0] * 4
    sim.step(np.zeros(4))
    assert sim.truth().accel_ned_m_s2[2] == pytest.approx(G, rel=0.01)
    for _ in range(round(6.0 / LOCKSTEP_DT_S)):
        sim.step(np.zeros(4))
    v_term = math.sqrt(2 * spec.mass_kg * G / (1.225 * spec.body_drag_cd_area_m2[2]))
    assert sim.truth().vel_ned_m_s[2] == pytest.approx(v_term, rel=0.03)


def test_failed_motor_gives_no_thrust_and_the_right_torque():
    spec = load_vehicle("firefly")
    sim = airborne(spec)
    sim.motor_settings.fail_motor = 1
    sim.motor_settings.fail_efficiency = 0.0
    n = len(spec.rotors)
    cmd = spec.hover_speed_rad_s / spec.max_speed_rad_s
    for _ in range(round(0.5 / LOCKSTEP_DT_S)):
        sim.step(np.full(n, cmd))
    assert sim.rotors.speeds[0] < 1.0
    assert sim.rotors.speeds[1] == pytest.approx(spec.hover_speed_rad_s, rel=1e-3)
    # Rotor 1 is front right: without it the vehicle rolls right... no: loses lift on the right, so it
    # rolls right-side down (positive roll in FRD) and pitches nose down (negative pitch).
    roll, pitch, _ = quat.to_euler(sim.truth().q_ned_frd)
    assert roll > 0.05 and pitch < -0.05


@pytest.mark.parametrize("name", VEHICLES)
def test_sensor_truth_fast_path_equals_truth(name):
    """The float fast path the lockstep loop feeds the sensors from agrees with the full truth."""
    spec = load_vehicle(name)
    sim = airborne(spec)
    sim.wind_settings.speed_m_s = 4.0
    sim.wind_settings.turbulence_m_s = 1.0
    out = Mixer(spec).mix(np.array([0.05, -0.03, 0.02]), spec.mass_kg * G)
    for _ in range(100):  # tumble a little and drift
        sim.step(out.commands)
    full, fast = sim.truth(), sim.sensor_truth()
    assert np.array(fast.r_ned_frd) == pytest.approx(full.r_ned_frd, abs=1e-12)
    for field in ("specific_force_frd_m_s2", "rate_frd_rad_s", "pos_ned_m", "vel_ned_m_s"):
        assert np.array(getattr(fast, field)) == pytest.approx(getattr(full, field), abs=1e-12), field
    assert quat.to_euler(full.q_ned_frd)[0] > 0.01  # it did roll: the check covers a non-trivial attitude
