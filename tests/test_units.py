"""Fast tests of the pure parts: no sockets, no processes, no clocks.

Mixer, rate and position control, frame conversions, rotor model, vehicle file
loader, battery, parameter store, geodesy, Mahony filter, land detector, and a
physics sanity check of the MuJoCo model through sitl.simulation.Simulation.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import autopilot.flight_controller  # noqa: F401  (declares every parameter of the flight controller)
from mavsim_core import quaternion as quat
from mavsim_core.constants import GRAVITY_M_S2
from autopilot.control.gains_from_params import position_control_from_params as PositionControl
from autopilot.control.position_control import PositionSetpoint, attitude_from_thrust
from autopilot.control.gains_from_params import rate_control_from_params as RateControl
from autopilot.estimation.mahony import MahonyFilter
from mavsim_core.geodesy import geodetic_to_ned, ned_to_geodetic
from autopilot.navigation.land_detector import LandDetector, Landed
from autopilot.control.mixer import Mixer
from autopilot.parameters import ParamDef, ParamError, ParameterStore, ParamType
from params.vehicle import VEHICLE_DIR, VehicleFileError, load_vehicle
from mavsim_core import frames
from sitl.battery import Battery
from sitl.rotors import RotorModel
from sitl.simulation import LOCKSTEP_DT_S, Simulation
from autopilot.param_catalogue import default_store

HOME = (47.397742, 8.545594, 488.0)
QUAD_TOML = (VEHICLE_DIR / "quad_x.toml").read_text()


@pytest.fixture(scope="module")
def quad():
    return load_vehicle("quad_x")


@pytest.fixture
def params():
    # autopilot.flight_controller imports every module that declares parameters: the registry is complete.
    return default_store()


def tilt_deg(q: np.ndarray) -> float:
    """Angle between the body z axis and the world z axis."""
    return math.degrees(math.acos(max(-1.0, min(1.0, quat.to_matrix(q)[2, 2]))))


# --------------------------------------------------------------------------- mixer

# Seed 000 section 2.9: Motor = Thrust +- Yaw +- Pitch +- Roll, rows (front right, front left, back right, back left).
SEED_TABLE = {  # motor: (yaw, pitch, roll) sign
    "FR": (+1, +1, +1),
    "FL": (-1, +1, -1),
    "BR": (-1, -1, +1),
    "BL": (+1, -1, -1),
}
# quad_x.toml lists its rotors in PX4's order: front right, rear left, front left, rear right.
QUAD_ORDER = ("FR", "BL", "FL", "BR")


def test_quad_x_allocation_reproduces_seed_000_mixing_table(quad):
    b = Mixer(quad).b  # rows roll, pitch, yaw torque (N m, FRD), thrust (N); one column per rotor
    assert b.shape == (4, 4)
    seed = np.array([SEED_TABLE[m] for m in QUAD_ORDER]).T  # rows yaw, pitch, roll
    # Same pattern as the seed's table on every axis (each axis' overall sign is a convention):
    for row, seed_row in ((b[2], seed[0]), (b[1], seed[1]), (b[0], seed[2])):
        signs = np.sign(row)
        assert np.array_equal(signs, seed_row) or np.array_equal(signs, -seed_row)
    yaw = dict(zip(QUAD_ORDER, np.sign(b[2])))
    assert yaw["FR"] == yaw["BL"] != yaw["FL"] == yaw["BR"]  # diagonal pairs share a spin direction
    # In FRD, with the physics fixed: more thrust on the right rolls left (negative roll torque),
    # more thrust in front pitches up, a CCW rotor (FR, BL) yaws the body clockwise = positive FRD yaw.
    roll, pitch = dict(zip(QUAD_ORDER, b[0])), dict(zip(QUAD_ORDER, b[1]))
    assert roll["FR"] < 0 and roll["BR"] < 0 and roll["FL"] > 0 and roll["BL"] > 0
    assert pitch["FR"] > 0 and pitch["FL"] > 0 and pitch["BR"] < 0 and pitch["BL"] < 0
    assert yaw["FR"] > 0
    assert np.all(b[3] == 1.0)
    arm = 0.46
    assert np.allclose(np.abs(b[0:2]), arm) and np.allclose(np.abs(b[2]), quad.k_moment)


def test_mix_reproduces_requested_wrench_when_not_saturated(quad):
    mixer = Mixer(quad)
    hover_n = quad.mass_kg * 9.80665
    for torque in ([0.0, 0.0, 0.0], [0.5, -0.3, 0.04], [-0.8, 0.6, -0.05]):
        out = mixer.mix(np.array(torque), hover_n)
        assert mixer.wrench(out.thrusts_n) == pytest.approx([*torque, hover_n], abs=1e-9)
        assert not out.sat_pos.any() and not out.sat_neg.any() and not out.thrust_saturated
        # Commands map linearly to rotor speed: T = T_max u^2.
        assert out.commands ** 2 * quad.max_thrust_per_rotor_n == pytest.approx(out.thrusts_n)
        assert np.all((out.commands >= 0) & (out.commands <= 1))
    hover = mixer.mix(np.zeros(3), hover_n).commands
    assert hover == pytest.approx(np.full(4, quad.hover_speed_rad_s / quad.max_speed_rad_s))


@pytest.mark.parametrize("roll_nm", [50.0, -50.0])
def test_huge_roll_keeps_its_sign_shifts_thrust_and_flags_saturation(quad, roll_nm):
    mixer = Mixer(quad)
    hover_n = quad.mass_kg * 9.80665
    out = mixer.mix(np.array([roll_nm, 0.0, 0.0]), hover_n)
    roll, pitch, yaw, thrust = mixer.wrench(out.thrusts_n)
    assert np.sign(roll) == np.sign(roll_nm) and abs(roll) < abs(roll_nm)
    assert abs(roll) == pytest.approx(2 * 0.46 * quad.max_thrust_per_rotor_n)  # the most a quad can give
    assert pitch == pytest.approx(0.0, abs=1e-9) and yaw == pytest.approx(0.0, abs=1e-9)
    assert out.thrust_saturated and thrust != pytest.approx(hover_n)
    assert np.all((out.thrusts_n >= 0) & (out.thrusts_n <= quad.max_thrust_per_rotor_n + 1e-12))
    assert out.sat_pos[0] == (roll_nm > 0) and out.sat_neg[0] == (roll_nm < 0)
    assert not out.sat_pos[1] and not out.sat_neg[1]


def test_yaw_is_cut_first(quad):
    mixer = Mixer(quad)
    hover_n = quad.mass_kg * 9.80665
    for yaw_nm in (0.5, -0.5):
        out = mixer.mix(np.array([0.6, -0.4, yaw_nm]), hover_n)
        roll, pitch, yaw, thrust = mixer.wrench(out.thrusts_n)
        assert (roll, pitch, thrust) == pytest.approx((0.6, -0.4, hover_n))  # fully delivered
        assert 0 < yaw / yaw_nm < 1  # same sign, less of it
        assert out.sat_pos[2] == (yaw_nm > 0) and out.sat_neg[2] == (yaw_nm < 0)
        assert not out.sat_pos[:2].any() and not out.sat_neg[:2].any() and not out.thrust_saturated


def test_full_thrust_request_is_limited(quad):
    mixer = Mixer(quad)
    out = mixer.mix(np.zeros(3), 1000.0)
    assert out.thrust_saturated
    assert out.commands == pytest.approx(np.ones(4))


# --------------------------------------------------------------------------- rate control


def test_rate_integrator_stops_growing_toward_saturated_side(params):
    rc = RateControl(params)
    err = np.array([1.0, -1.0, 0.5])  # rate setpoint minus rate
    sat_pos = np.array([True, False, True])
    sat_neg = np.array([False, True, False])
    for _ in range(50):
        rc.update(np.zeros(3), err, 0.004, sat_pos, sat_neg)
    assert np.asarray(rc.integral) == pytest.approx(np.zeros(3))
    # The other way out of saturation still integrates.
    for _ in range(50):
        rc.update(np.zeros(3), -err, 0.004, sat_pos, sat_neg)
    i = np.asarray(rc.integral)
    assert i[0] < 0 and i[1] > 0 and i[2] < 0
    # And without saturation it integrates I * e * dt.
    rc.reset()
    rc.update(np.zeros(3), err, 0.004)
    assert np.asarray(rc.integral) == pytest.approx(err * 0.004 * np.array([6.0, 6.0, 2.0]))


def test_rate_integrator_clamped_at_int_lim(params):
    rc = RateControl(params)
    for _ in range(5000):
        rc.update(np.zeros(3), np.array([5.0, -5.0, 5.0]), 0.004)
    assert np.asarray(rc.integral) == pytest.approx([params.get("MC_RR_INT_LIM"), -params.get("MC_PR_INT_LIM"),
                                                    params.get("MC_YR_INT_LIM")])
    params.set("MC_RR_INT_LIM", 1.5)  # a changed limit applies at once
    rc.update(np.zeros(3), np.array([5.0, -5.0, 5.0]), 0.004)
    assert rc.integral[0] == pytest.approx(1.5)


def test_nan_input_does_not_poison_the_integrator(params):
    rc = RateControl(params)
    for _ in range(10):
        rc.update(np.zeros(3), np.array([1.0, 1.0, 1.0]), 0.004)
    before = np.asarray(rc.integral).copy()
    out = rc.update(np.array([math.nan, 0.0, 0.0]), np.zeros(3), 0.004)
    assert np.all(np.isfinite(out))
    out = rc.update(np.zeros(3), np.array([0.0, math.inf, 0.0]), 0.004)
    assert np.all(np.isfinite(out))
    assert np.asarray(rc.integral) == pytest.approx(before)
    out = rc.update(np.zeros(3), np.array([1.0, 1.0, 1.0]), 0.004)
    assert np.all(np.isfinite(out)) and np.all(np.isfinite(rc.integral))


# --------------------------------------------------------------------------- position control


def make_position_control(params, quad) -> PositionControl:
    return PositionControl(params, quad.mass_kg, len(quad.rotors) * quad.max_thrust_per_rotor_n)


def test_position_control_hover_feed_forward_at_zero_error(params, quad):
    pc = make_position_control(params, quad)
    here = np.array([3.0, -2.0, -5.0])
    sp = PositionSetpoint(here.copy(), np.zeros(3), 0.3)
    for _ in range(20):
        thrust = pc.update(here, np.zeros(3), sp, 0.02)
        assert thrust == pytest.approx([0.0, 0.0, -quad.mass_kg * GRAVITY_M_S2])


def test_position_control_thrust_is_mass_times_acceleration_minus_gravity(params, quad):
    pc = make_position_control(params, quad)
    sp = PositionSetpoint(np.array([1.0, 0.5, -5.3]), np.zeros(3), 0.0)
    thrust = pc.update(np.array([0.0, 0.0, -5.0]), np.zeros(3), sp, 0.02)
    assert thrust == pytest.approx(quad.mass_kg * (pc.acc_sp - np.array([0.0, 0.0, GRAVITY_M_S2])))
    assert thrust[0] > 0 and thrust[1] > 0 and -thrust[2] > quad.mass_kg * GRAVITY_M_S2  # toward the goal, climbing


def test_position_control_respects_tilt_limit(params, quad):
    pc = make_position_control(params, quad)
    for tilt_max in (35.0, 20.0):
        params.set("MPC_TILTMAX_AIR", tilt_max)
        pc.reset()
        sp = PositionSetpoint(np.array([200.0, -100.0, -5.0]), np.zeros(3), 0.0)
        for _ in range(100):
            thrust = pc.update(np.array([0.0, 0.0, -5.0]), np.zeros(3), sp, 0.02)
            tilt = math.degrees(math.atan2(math.hypot(thrust[0], thrust[1]), -thrust[2]))
            assert tilt <= tilt_max + 1e-6
        assert tilt == pytest.approx(tilt_max)
        assert math.atan2(thrust[1], thrust[0]) == pytest.approx(math.atan2(-100.0, 200.0))  # toward the goal
        assert np.linalg.norm(thrust) <= len(quad.rotors) * quad.max_thrust_per_rotor_n + 1e-9


def test_attitude_from_thrust_points_body_down_against_thrust():
    thrust = np.array([2.0, -1.0, -13.0])
    for yaw in (0.0, 1.0, -2.5):
        r = attitude_from_thrust(thrust, yaw)
        assert r.T @ r == pytest.approx(np.eye(3), abs=1e-12)
        assert -r[:, 2] == pytest.approx(thrust / np.linalg.norm(thrust))
        level_yaw = quat.to_euler(quat.from_matrix(attitude_from_thrust(np.array([0.0, 0.0, -10.0]), yaw)))
        assert level_yaw == pytest.approx((0.0, 0.0, yaw))


# --------------------------------------------------------------------------- frames


def random_quats(n: int, seed: int = 0) -> list[np.ndarray]:
    rng = np.random.default_rng(seed)
    out = []
    for _ in range(n):
        q = rng.standard_normal(4)
        out.append(q / np.linalg.norm(q))
    return out


def test_enu_ned_and_flu_frd_vectors():
    assert frames.enu_to_ned(np.array([1.0, 2.0, 3.0])) == pytest.approx([2.0, 1.0, -3.0])  # east 1, north 2, up 3
    assert frames.ned_to_enu(np.array([2.0, 1.0, -3.0])) == pytest.approx([1.0, 2.0, 3.0])
    assert frames.flu_to_frd(np.array([1.0, 2.0, 3.0])) == pytest.approx([1.0, -2.0, -3.0])
    assert frames.frd_to_flu(np.array([1.0, -2.0, -3.0])) == pytest.approx([1.0, 2.0, 3.0])
    v = np.array([0.3, -1.7, 4.2])
    assert frames.ned_to_enu(frames.enu_to_ned(v)) == pytest.approx(v)
    assert frames.frd_to_flu(frames.flu_to_frd(v)) == pytest.approx(v)


def test_mujoco_yawed_90_deg_from_east_faces_north():
    c = math.sqrt(0.5)
    q_enu_flu = np.array([c, 0.0, 0.0, c])  # +90 deg about ENU up: body x from East to North
    q_ned = frames.quat_enu_flu_to_ned_frd(q_enu_flu)
    assert q_ned == pytest.approx([1.0, 0.0, 0.0, 0.0], abs=1e-12)
    assert quat.to_euler(q_ned) == pytest.approx((0.0, 0.0, 0.0), abs=1e-12)
    # MuJoCo's identity faces East: NED yaw +90 deg.
    assert quat.to_euler(frames.quat_enu_flu_to_ned_frd(np.array([1.0, 0.0, 0.0, 0.0]))) == pytest.approx(
        (0.0, 0.0, math.pi / 2))
    # Nose up 10 deg in MuJoCo (negative rotation about FLU y, the left axis) is pitch +10 deg in FRD.
    pitch = math.radians(10)
    q_up = quat.mul(q_enu_flu, np.array([math.cos(-pitch / 2), 0.0, math.sin(-pitch / 2), 0.0]))
    assert quat.to_euler(frames.quat_enu_flu_to_ned_frd(q_up)) == pytest.approx((0.0, pitch, 0.0))


def test_quaternion_conversion_round_trip_and_rotates_vectors_consistently():
    rng = np.random.default_rng(1)
    for q_enu in random_quats(50):
        q_ned = frames.quat_enu_flu_to_ned_frd(q_enu)
        assert np.linalg.norm(q_ned) == pytest.approx(1.0) and q_ned[0] >= 0
        back = frames.quat_ned_frd_to_enu_flu(q_ned)
        assert abs(float(np.dot(back, q_enu))) == pytest.approx(1.0)  # same rotation (q and -q)
        v_flu = rng.standard_normal(3)
        v_enu = quat.to_matrix(q_enu) @ v_flu
        assert quat.to_matrix(q_ned) @ frames.flu_to_frd(v_flu) == pytest.approx(frames.enu_to_ned(v_enu))


def test_wxyz_xyzw_helpers_against_scipy():
    for q in random_quats(20, seed=2):
        xyzw = frames.wxyz_to_xyzw(q)
        assert xyzw == pytest.approx([q[1], q[2], q[3], q[0]])
        assert frames.xyzw_to_wxyz(xyzw) == pytest.approx(q)
        assert Rotation.from_quat(xyzw).as_matrix() == pytest.approx(quat.to_matrix(q))
        assert Rotation.from_quat(xyzw).as_matrix() == pytest.approx(
            Rotation.from_quat(q, scalar_first=True).as_matrix())
    yaw90 = frames.xyzw_to_wxyz(Rotation.from_euler("z", 90, degrees=True).as_quat())
    assert yaw90 == pytest.approx([math.sqrt(0.5), 0.0, 0.0, math.sqrt(0.5)])


# --------------------------------------------------------------------------- rotors


def test_rotor_thrust_is_k_t_omega_squared(quad):
    rotors = RotorModel(quad)
    u = 0.6
    for _ in range(2000):  # 2 s: long past the lag
        thrusts = rotors.step(np.full(4, u), 0.001)
    w = u * quad.max_speed_rad_s
    assert rotors.speed_rad_s == pytest.approx(np.full(4, w))
    assert thrusts == pytest.approx(np.full(4, quad.k_thrust * w * w))
    assert rotors.drag_torque_nm() == pytest.approx(quad.k_moment * np.array(thrusts))


def test_motor_lag_63_percent_in_one_time_constant_slower_down(quad):
    rotors = RotorModel(quad)
    w_max = quad.max_speed_rad_s
    dt = quad.time_constant_up_s / 50
    for _ in range(50):
        rotors.step(np.ones(4), dt)
    assert rotors.speed_rad_s / w_max == pytest.approx(np.full(4, 1 - math.exp(-1)), abs=1e-9)
    for _ in range(5000):
        rotors.step(np.ones(4), dt)
    assert rotors.speed_rad_s == pytest.approx(np.full(4, w_max))
    for _ in range(50):  # one *up* time constant of slowing down: less than 63 % of the way
        rotors.step(np.zeros(4), dt)
    fallen = 1 - rotors.speed_rad_s / w_max
    assert np.all(fallen < 1 - math.exp(-1))
    assert fallen == pytest.approx(np.full(4, 1 - math.exp(-quad.time_constant_up_s / quad.time_constant_down_s)))
    assert quad.time_constant_down_s > quad.time_constant_up_s
    assert rotors.commanded_speed([1.5, -0.2, 0.5, 1.0]) == pytest.approx([w_max, 0.0, w_max / 2, w_max])


# --------------------------------------------------------------------------- vehicle file


def test_vehicle_file_hover_speed(quad):
    n, g = len(quad.rotors), 9.80665
    assert quad.mass_kg == pytest.approx(1.0 + 4 * 0.1)
    assert quad.hover_speed_rad_s == pytest.approx(math.sqrt(quad.mass_kg * g / (n * quad.k_thrust)))
    assert quad.hover_speed_rad_s == pytest.approx(633.6, abs=0.1)  # as the file's comment says
    assert 0 < quad.hover_thrust_fraction < 0.9
    assert [r.spin_ccw for r in quad.rotors] == [1, 1, -1, -1]


def write_vehicle(tmp_path, text: str):
    path = tmp_path / "broken.toml"
    path.write_text(text)
    return str(path)


@pytest.mark.parametrize(("edit", "message"), [
    (lambda t: t.replace("k_thrust = 8.54858e-6", ""), "missing 'k_thrust'"),
    (lambda t: t.replace('spin = ["ccw", "ccw", "cw", "cw"]', 'spin = ["ccw", "cww", "cw", "cw"]'),
     "rotor 2 spin must be 'ccw' or 'cw', is 'cww'"),
    (lambda t: t.replace(
        "positions_frd_m = [[0.46, 0.46, -0.06], [-0.46, -0.46, -0.06], [0.46, -0.46, -0.06], [-0.46, 0.46, -0.06]]",
        "positions_frd_m = [[0.46, 0.46, -0.06], [-0.46, -0.46, -0.06], [0.46, -0.46, -0.06]]").replace(
        'spin = ["ccw", "ccw", "cw", "cw"]', 'spin = ["ccw", "ccw", "cw"]'),
     "a multirotor needs at least 4 rotors, has 3"),
    (lambda t: t.replace("mass_kg = 1.0", "mass_kg = -1.0"), "'mass_kg' must be > 0, is -1.0"),
    (lambda t: t.replace("[legs]", "[lags]"), "missing section [legs]"),
    (lambda t: t.replace("max_speed_rad_s = 838.0", "max_speed_rad_s = 500.0"), "cannot hover with margin"),
])
def test_broken_vehicle_files_are_refused_clearly(tmp_path, edit, message):
    text = edit(QUAD_TOML)
    assert text != QUAD_TOML
    path = write_vehicle(tmp_path, text)
    with pytest.raises(VehicleFileError) as exc:
        load_vehicle(path)
    assert message in str(exc.value)
    assert path in str(exc.value)  # says which file


def test_unknown_vehicle_name_lists_known_ones():
    with pytest.raises(VehicleFileError, match=r"unknown vehicle 'nope' \(known: .*quad_x"):
        load_vehicle("nope")


# --------------------------------------------------------------------------- battery


def test_battery_sags_with_load_and_falls_with_discharge():
    light, heavy = Battery(), Battery()
    light.step(50.0, 0.004)
    heavy.step(400.0, 0.004)
    assert heavy.current_a > light.current_a
    assert heavy.voltage_v < light.voltage_v < light.open_circuit_v() + 1e-9
    full_v = Battery().voltage_v
    assert full_v == pytest.approx(4 * 4.2)  # 4 cells, full, no load yet
    assert full_v - heavy.voltage_v == pytest.approx(heavy.current_a * heavy.r_ohm)  # sag = I R
    b = Battery()
    voltages = []
    for _ in range(10):
        for _ in range(60):  # one simulated minute at hover-like power per outer step
            b.step(200.0, 1.0)
        voltages.append(b.open_circuit_v())
    assert all(a > c for a, c in zip(voltages, voltages[1:]))  # strictly falling
    assert b.remaining_frac < 0.5
    assert b.consumed_mah == pytest.approx(b.used_as / 3.6)


# --------------------------------------------------------------------------- parameters


def test_parameter_store_refuses_bad_sets_and_changes_nothing():
    store = ParameterStore({
        "TEST_GAIN": ParamDef("TEST_GAIN", ParamType.REAL32, 1.0, 0.0, 5.0, "1/s", "a gain"),
        "TEST_COUNT": ParamDef("TEST_COUNT", ParamType.INT32, 3, 1, 10, "", "a count"),
    })
    seen = []
    store.subscribe(lambda name, value: seen.append((name, value)))
    refused = [
        (("TEST_GAIN", 5.5), "outside range"),
        (("TEST_GAIN", -0.1), "outside range"),
        (("TEST_GAIN", math.nan), "finite"),
        (("TEST_COUNT", 2.5), "integer"),
        (("TEST_COUNT", 0), "outside range"),
        (("TEST_GAIN", 2.0, ParamType.INT32), "is REAL32, not INT32"),
        (("NO_SUCH", 1.0), "unknown parameter NO_SUCH"),
    ]
    for args, why in refused:
        with pytest.raises(ParamError, match=why):
            store.set(*args)
    assert store.get("TEST_GAIN") == 1.0 and store.get("TEST_COUNT") == 3 and seen == []
    with pytest.raises(ParamError, match="unknown parameter NOPE"):
        store.get("NOPE")
    assert store.set("TEST_GAIN", 5.0) == 5.0 and store.set("TEST_COUNT", 7.0, ParamType.INT32) == 7
    assert seen == [("TEST_GAIN", 5.0), ("TEST_COUNT", 7.0)]
    assert store.names() == ["TEST_COUNT", "TEST_GAIN"] and store.name_at(1) == "TEST_GAIN"


def test_declared_parameters_use_px4_names_and_valid_defaults(params):
    for name in ("MC_ROLLRATE_P", "MPC_XY_P", "MIS_TAKEOFF_ALT", "RTL_RETURN_ALT", "COM_DISARM_LAND", "SYS_AUTOSTART"):
        assert name in params
    assert params.definition("SYS_AUTOSTART").ptype == ParamType.INT32 and params.get("SYS_AUTOSTART") != 0
    for name in params.names():
        d = params.definition(name)
        assert d.min <= params.get(name) <= d.max and len(name) <= 16


# --------------------------------------------------------------------------- geodesy


def test_geodesy_round_trip():
    rng = np.random.default_rng(5)
    for lat0, lon0 in ((47.397742, 8.545594), (-33.9, 151.2), (0.0, 179.9999), (70.0, -179.9999)):
        for _ in range(30):
            ned = rng.uniform(-800, 800, 3)
            lat, lon, alt = ned_to_geodetic(ned, lat0, lon0, 488.0)
            assert -180 <= lon < 180
            assert geodetic_to_ned(lat, lon, alt, lat0, lon0, 488.0) == pytest.approx(ned, abs=1e-6)
    lat, lon, alt = ned_to_geodetic(np.array([111.0, 0.0, -5.0]), 47.0, 8.0, 500.0)
    assert (lat - 47.0) * math.pi / 180 * 6378137.0 == pytest.approx(111.0) and alt == 505.0


# --------------------------------------------------------------------------- Mahony filter

G = 9.80665
FIELD_NED_GAUSS = np.array([0.21, 0.016, 0.43])  # Zurich-like, about 4.4 deg east declination
GYRO_BIAS = np.array([0.01, -0.008, 0.004])


def imu_sample(rng, q_true: np.ndarray, rate_true: np.ndarray):
    r = quat.to_matrix(q_true)
    accel = r.T @ np.array([0.0, 0.0, -G]) + 0.03 * rng.standard_normal(3)  # at rest / constant rate: f = -g
    mag = r.T @ FIELD_NED_GAUSS + 0.003 * rng.standard_normal(3)
    gyro = rate_true + GYRO_BIAS + 0.003 * rng.standard_normal(3)
    return gyro, accel, mag


def yaw_err_deg(q_est: np.ndarray, q_true: np.ndarray) -> float:
    return abs(math.degrees(quat.wrap_pi(quat.to_euler(q_est)[2] - quat.to_euler(q_true)[2])))


def test_mahony_at_rest_converges_to_level_and_true_heading():
    rng = np.random.default_rng(3)
    f = MahonyFilter()
    f.declination_rad = math.atan2(FIELD_NED_GAUSS[1], FIELD_NED_GAUSS[0])
    q_true = quat.from_euler(0.0, 0.0, math.radians(60))
    dt = 0.004
    f.update(*imu_sample(rng, q_true, np.zeros(3)), dt)
    assert f.initialised
    f.q = quat.from_euler(math.radians(20), math.radians(-15), math.radians(100))  # badly off
    for _ in range(int(30 / dt)):  # ATT_MAHONY_KP 0.5: a few time constants of the bias learning
        f.update(*imu_sample(rng, q_true, np.zeros(3)), dt)
    assert tilt_deg(f.q) < 1.0
    assert yaw_err_deg(f.q, q_true) < 2.0
    assert f.gyro_bias[:2] == pytest.approx(GYRO_BIAS[:2], abs=0.003)  # roll/pitch gyro bias learned


def test_mahony_tracks_constant_yaw_rate():
    rng = np.random.default_rng(4)
    f = MahonyFilter()
    f.declination_rad = math.atan2(FIELD_NED_GAUSS[1], FIELD_NED_GAUSS[0])
    w = np.array([0.0, 0.0, 0.5])
    q = np.array([1.0, 0.0, 0.0, 0.0])
    dt = 0.004
    worst = 0.0
    for i in range(int(20 / dt)):
        rate = f.update(*imu_sample(rng, q, w), dt)
        q = quat.integrate(q, w, dt)
        if i * dt > 5.0:
            worst = max(worst, yaw_err_deg(f.q, q))
    assert worst < 3.0  # several full turns, heading error stays small
    assert tilt_deg(f.q) < 1.0
    assert rate[2] == pytest.approx(0.5, abs=0.02)


# --------------------------------------------------------------------------- land detector


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


# --------------------------------------------------------------------------- physics (MuJoCo)


@pytest.fixture
def sim(quad):
    return Simulation(quad, HOME, seed=1)


def test_vehicle_starts_level_on_its_legs_facing_north(sim):
    t = sim.truth()
    assert t.pos_ned_m[:2] == pytest.approx([0.0, 0.0], abs=1e-6)
    assert -t.pos_ned_m[2] == pytest.approx(0.2, abs=0.01)  # centre of mass above the feet
    assert quat.to_euler(t.q_ned_frd) == pytest.approx((0.0, 0.0, 0.0), abs=1e-6)
    assert t.specific_force_frd_m_s2 == pytest.approx([0.0, 0.0, -G], abs=1e-3)  # the accelerometer feels the ground


def test_hover_command_holds_it_level_and_balances_weight(sim, quad):
    sim.data.qpos[2] = 5.0  # start in the air
    hover = np.full(4, quad.hover_speed_rad_s / quad.max_speed_rad_s)
    for _ in range(round(0.5 / LOCKSTEP_DT_S)):  # spin-up
        sim.step(hover)
    v_start = sim.truth().vel_ned_m_s
    for _ in range(round(2.0 / LOCKSTEP_DT_S)):
        sim.step(hover)
    t = sim.truth()
    assert tilt_deg(t.q_ned_frd) < 0.5
    assert np.abs(t.rate_frd_rad_s).max() < 0.01
    assert t.specific_force_frd_m_s2 == pytest.approx([0.0, 0.0, -G], abs=0.01)  # thrust = weight
    assert t.vel_ned_m_s == pytest.approx(v_start, abs=0.02)  # no acceleration
    assert abs(t.vel_ned_m_s[2]) < 0.3 and -t.pos_ned_m[2] > 4.0
