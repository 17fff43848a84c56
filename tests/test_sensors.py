"""The sensor error models of sitl.sensors and sitl.gps: noise, bias, drift, latency, glitches and failures.

Statistical checks use fixed seeds, so each is deterministic; the tolerances are
several standard errors of the estimate wide.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from mavsim_core.geodesy import geodetic_to_ned
from sitl.scenario import load_scenario
from sitl.sensors import SensorSuite, pressure_hpa_at
from sitl.sim_settings import SensorSettings

from sim_params_helpers import make_params  # tests/sim_params_helpers.py

HOME = (47.397742, 8.545594, 488.0)
G = 9.80665
DT = 0.004
STEP_US = 4000
LEVEL_NORTH = np.eye(3)


def suite(seed: int = 1, **settings) -> SensorSuite:
    return SensorSuite(*HOME, seed=seed, settings=SensorSettings(**settings))


def quiet_gps(**extra) -> dict:
    """GPS settings without random errors."""
    return {"gps_noise_m": 0.0, "gps_vnoise_m": 0.0, "gps_vel_noise_m_s": 0.0, "gps_drift_m": 0.0, **extra}


def fix_ned(fix) -> np.ndarray:
    return geodetic_to_ned(fix.lat_deg, fix.lon_deg, fix.alt_amsl_m, *HOME)


def altitude_from_pressure(p_hpa: float) -> float:
    return (1.0 - (p_hpa / 1013.25) ** (1.0 / 5.25588)) / 2.25577e-5


def yaw_matrix(yaw: float) -> np.ndarray:
    c, s = math.cos(yaw), math.sin(yaw)
    return np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])


# -- accelerometer and gyro ---------------------------------------------------------------
def test_imu_at_rest_mean_is_truth_plus_bias_and_noise_matches_density():
    s = suite(seed=3)
    f_true = np.array([0.0, 0.0, -G])
    acc, gyr, acc_bias, gyr_bias = [], [], [], []
    for _ in range(2500):
        r = s.imu(f_true, np.zeros(3), LEVEL_NORTH, np.zeros(3), DT)
        acc.append(r.accel_frd_m_s2)
        gyr.append(r.gyro_frd_rad_s)
        acc_bias.append(s.accel_bias_frd)
        gyr_bias.append(s.gyro_bias_frd)
    acc, gyr, acc_bias, gyr_bias = map(np.array, (acc, gyr, acc_bias, gyr_bias))
    cfg = s.settings
    for reading, bias, truth, density in (
        (acc, acc_bias, f_true, cfg.accel_noise_density),
        (gyr, gyr_bias, np.zeros(3), cfg.gyro_noise_density),
    ):
        sigma = density * math.sqrt(1.0 / DT)
        noise = reading - truth - bias
        assert np.allclose(noise.std(axis=0), sigma, rtol=0.10)
        assert np.allclose(reading.mean(axis=0), truth + bias.mean(axis=0), atol=4 * sigma / math.sqrt(len(reading)))
    # the turn-on bias is there and of the expected size
    assert np.all(np.abs(acc_bias[0]) > 1e-4) and np.all(np.abs(gyr_bias[0]) > 1e-6)


def test_turn_on_bias_spread_over_seeds():
    first_acc, first_gyr = [], []
    for seed in range(300):
        s = suite(seed=seed)
        first_acc.append(s.accel_bias_frd)
        first_gyr.append(s.gyro_bias_frd)
    cfg = SensorSettings()
    assert np.std(first_acc) == pytest.approx(cfg.accel_bias_sd, rel=0.10)
    assert np.std(first_gyr) == pytest.approx(cfg.gyro_bias_sd, rel=0.10)


def test_bias_random_walk_variance_grows_as_walk_squared_times_t():
    s = suite(seed=5)
    window = 250  # 1 s
    a_prev, g_prev = np.array(s.accel_bias_frd), np.array(s.gyro_bias_frd)
    da, dg = [], []
    z3 = np.zeros(3)
    for _ in range(300):
        for _ in range(window):
            s.imu(z3, z3, LEVEL_NORTH, z3, DT)
        a, g = np.array(s.accel_bias_frd), np.array(s.gyro_bias_frd)
        da.append(a - a_prev)
        dg.append(g - g_prev)
        a_prev, g_prev = a, g
    t = window * DT
    assert np.mean(np.square(da)) == pytest.approx(s.settings.accel_bias_walk**2 * t, rel=0.2)
    assert np.mean(np.square(dg)) == pytest.approx(s.settings.gyro_bias_walk**2 * t, rel=0.2)


def test_imu_noise_setting_acts_at_once():
    s = suite(
        seed=2,
        accel_noise_density=0.0,
        gyro_noise_density=0.0,
        accel_bias_walk=0.0,
        gyro_bias_walk=0.0,
        accel_bias_sd=0.0,
        gyro_bias_sd=0.0,
    )
    f = np.array([0.5, -0.25, -G])
    w = np.array([0.1, 0.2, -0.3])
    r = s.imu(f, w, LEVEL_NORTH, np.zeros(3), DT)
    assert np.allclose(r.accel_frd_m_s2, f, atol=1e-12) and np.allclose(r.gyro_frd_rad_s, w, atol=1e-12)
    s.settings.accel_bias_sd = 0.05  # the turn-on draw, scaled by the new setting
    r = s.imu(f, w, LEVEL_NORTH, np.zeros(3), DT)
    assert np.allclose(np.array(r.accel_frd_m_s2) - f, s.accel_bias_frd, atol=1e-12)
    assert np.any(np.abs(s.accel_bias_frd) > 1e-4)


# -- magnetometer ----------------------------------------------------------------------------
def test_magnetometer_field_offsets_and_current_interference_add_exactly():
    s = suite(mag_noise_gauss=0.0)
    field = s.field_ned_gauss
    r = yaw_matrix(math.radians(90.0))
    z3 = np.zeros(3)
    clean = np.array(s.imu(z3, z3, r, z3, DT).mag_frd_gauss)
    assert np.allclose(clean, r.T @ field, atol=1e-12)
    assert clean[1] == pytest.approx(-field[0])  # facing East, North is to the left
    cfg = s.settings
    cfg.mag_offset_x_gauss, cfg.mag_offset_y_gauss, cfg.mag_offset_z_gauss = 0.1, -0.2, 0.05
    cfg.mag_motor_x_gauss_a, cfg.mag_motor_y_gauss_a, cfg.mag_motor_z_gauss_a = 0.001, 0.002, -0.003
    m = np.array(s.imu(z3, z3, r, z3, DT, current_a=20.0).mag_frd_gauss)
    assert np.allclose(m - clean, [0.1 + 0.02, -0.2 + 0.04, 0.05 - 0.06], atol=1e-12)


def test_magnetometer_noise_std():
    s = suite(seed=4, mag_noise_gauss=0.01)
    z3 = np.zeros(3)
    m = np.array([s.imu(z3, z3, LEVEL_NORTH, z3, DT).mag_frd_gauss for _ in range(2000)])
    assert np.allclose(m.std(axis=0), 0.01, rtol=0.1)
    assert np.allclose(m.mean(axis=0), s.field_ned_gauss, atol=0.001)


def test_magnetometer_stuck_repeats_the_value_it_had_then():
    s = suite(seed=6)
    z3 = np.zeros(3)
    last = s.imu(z3, z3, LEVEL_NORTH, z3, DT).mag_frd_gauss
    s.settings.mag_stuck = 1
    for k in range(20):
        m = s.imu(z3, z3, yaw_matrix(0.1 * k), z3, DT, current_a=30.0).mag_frd_gauss
        assert m == last
    s.settings.mag_stuck = 0
    assert s.imu(z3, z3, yaw_matrix(1.0), z3, DT).mag_frd_gauss != last


# -- barometer -------------------------------------------------------------------------------
def test_baro_drift_looks_like_a_climb_at_the_drift_rate():
    drifting = suite(seed=7, baro_noise_m=0.0, baro_drift_m_s=0.1)
    climbing = suite(seed=7, baro_noise_m=0.0)
    z3 = np.zeros(3)
    alts = []
    for k in range(1, 2501):  # 10 s
        t = k * DT
        p_drift = drifting.imu(z3, z3, LEVEL_NORTH, z3, DT).pressure_hpa
        p_climb = climbing.imu(z3, z3, LEVEL_NORTH, np.array([0.0, 0.0, -0.1 * t]), DT).pressure_hpa
        assert p_drift == pytest.approx(p_climb, abs=1e-9)
        alts.append(altitude_from_pressure(p_drift))
    slope = np.polyfit(np.arange(1, 2501) * DT, alts, 1)[0]
    assert slope == pytest.approx(0.1, rel=1e-3)
    assert alts[-1] == pytest.approx(HOME[2] + 1.0, abs=1e-3)


def test_baro_noise_in_metres_and_stuck():
    s = suite(seed=8, baro_noise_m=0.5)
    z3 = np.zeros(3)
    alts = [altitude_from_pressure(s.imu(z3, z3, LEVEL_NORTH, z3, DT).pressure_hpa) for _ in range(2000)]
    assert np.std(alts) == pytest.approx(0.5, rel=0.1)
    assert np.mean(alts) == pytest.approx(HOME[2], abs=0.05)
    before = s.imu(z3, z3, LEVEL_NORTH, z3, DT)
    s.settings.baro_stuck = 1
    for k in range(10):
        r = s.imu(z3, z3, LEVEL_NORTH, np.array([0.0, 0.0, -10.0 * k]), DT)
        assert (r.pressure_hpa, r.temperature_c) == (before.pressure_hpa, before.temperature_c)
    s.settings.baro_stuck = 0
    assert s.imu(z3, z3, LEVEL_NORTH, np.array([0.0, 0.0, -100.0]), DT).pressure_hpa < pressure_hpa_at(HOME[2] + 90)


# -- GPS ---------------------------------------------------------------------------------------
def run_gps(s: SensorSuite, seconds: float, vel=(0.0, 0.0, 0.0), t0_us: int = 0, on_step=None):
    """Call gps() every 4 ms with a vehicle moving at ``vel`` from the origin; [(time_us, fix)]."""
    fixes = []
    v = np.array(vel, dtype=float)
    for k in range(round(seconds * 1e6 / STEP_US)):
        t_us = t0_us + k * STEP_US
        if on_step:
            on_step(t_us, s)
        fix = s.gps(t_us, v * t_us * 1e-6, v)
        if fix is not None:
            fixes.append((t_us, fix))
    return fixes


def test_gps_fixes_at_5_hz_on_multiples_of_the_period():
    fixes = run_gps(suite(), 10.0)
    times = [t for t, _ in fixes]
    assert times == list(range(0, 10_000_000, 200_000))
    assert all(f.fix_type == 3 and 12 <= f.satellites <= 14 for _, f in fixes)


def test_gps_rtk_scenario_reports_an_rtk_fix_with_centimetre_errors():
    """sitl --scenario rtk_gps: fix type 6 (RTK fixed), eph and the spread of the fixes about 2 cm."""
    scenario = load_scenario("rtk_gps").parameters
    params, _, sensors, _ = make_params()
    params.set_many(scenario)
    fixes = run_gps(SensorSuite(*HOME, seed=1, settings=sensors), 20.0)
    assert all(f.fix_type == 6 for _, f in fixes)
    assert fixes[0][1].eph_m == pytest.approx(math.hypot(scenario["SIM_GPS_NOISE"], scenario["SIM_GPS_DRIFT"]))
    north = np.array([fix_ned(f)[0] for _, f in fixes])
    assert 0.01 < north.std() < 0.04


def test_gps_odd_rate_rounds_to_the_nearest_step_and_rate_change_acts():
    s = suite(gps_rate_hz=3.0)
    times = [t for t, _ in run_gps(s, 2.0)]
    expected = [round(k * 1e6 / 3 / STEP_US) * STEP_US for k in range(6)]
    assert times == expected
    s.settings.gps_rate_hz = 10.0
    times = [t for t, _ in run_gps(s, 1.0, t0_us=2_000_000)]
    assert times == list(range(2_000_000, 3_000_000, 100_000))


def test_gps_position_lags_truth_by_latency_times_speed():
    s = suite(**quiet_gps())
    fixes = run_gps(s, 5.0, vel=(10.0, 0.0, 0.0))
    lag_s = s.settings.gps_lag_ms / 1000.0
    for t_us, fix in fixes[2:]:  # once the history covers the latency
        true_north = 10.0 * t_us * 1e-6
        assert fix_ned(fix)[0] == pytest.approx(true_north - 10.0 * lag_s, abs=1e-6)
        assert fix.vel_ned_m_s[0] == pytest.approx(10.0)
    # a latency that is not a multiple of the 4 ms step is interpolated
    s.settings.gps_lag_ms = 10
    t_us, fix = run_gps(s, 0.2, vel=(10.0, 0.0, 0.0), t0_us=5_000_000)[0]
    assert fix_ned(fix)[0] == pytest.approx(10.0 * (t_us * 1e-6 - 0.010), abs=1e-6)


def test_gps_eph_epv_match_the_error_spread():
    settings = dict(gps_noise_m=0.3, gps_vnoise_m=0.5, gps_drift_m=0.4)
    errors = []
    for seed in range(400):
        s = suite(seed=seed, **settings)
        fix = s.gps(0, np.zeros(3), np.zeros(3))
        errors.append(fix_ned(fix))
    errors = np.array(errors)
    assert fix.eph_m == pytest.approx(0.5)
    assert fix.epv_m == pytest.approx(math.hypot(0.5, 1.5 * 0.4))
    assert errors[:, :2].std() == pytest.approx(fix.eph_m, rel=0.2)
    assert errors[:, 2].std() == pytest.approx(fix.epv_m, rel=0.2)
    assert np.abs(errors.mean(axis=0)).max() < 0.1


def test_gps_eph_floor_and_drift_is_slow():
    s = suite(seed=9, **quiet_gps())
    assert s.gps(0, np.zeros(3), np.zeros(3)).eph_m == pytest.approx(0.01)
    s = suite(seed=9, **quiet_gps(gps_drift_m=1.0))
    fixes = run_gps(s, 200.0)
    north = np.array([fix_ned(f)[0] for _, f in fixes])
    step_sd = np.diff(north).std()
    a = math.exp(-0.2 / 60.0)
    assert step_sd == pytest.approx(math.sqrt(2 * (1 - a)), rel=0.2)  # Gauss-Markov, 60 s correlation


def test_gps_glitch_appears_in_the_next_fix():
    def glitch(t_us, s):
        if t_us == 1_004_000:
            s.settings.gps_glitch_n_m, s.settings.gps_glitch_e_m, s.settings.gps_glitch_d_m = 50.0, -20.0, 3.0

    clean = run_gps(suite(seed=11), 2.0)
    glitched = run_gps(suite(seed=11), 2.0, on_step=glitch)
    for (t_us, a), (_, b) in zip(clean, glitched):
        offset = fix_ned(b) - fix_ned(a)
        expected = [50.0, -20.0, 3.0] if t_us > 1_004_000 else [0.0, 0.0, 0.0]
        assert offset == pytest.approx(expected, abs=1e-6)
        assert (a.eph_m, a.epv_m) == (b.eph_m, b.epv_m)


def test_gps_disable_silences_the_receiver():
    s = suite()
    assert len(run_gps(s, 1.0)) == 5
    s.settings.gps_disable = 1
    assert run_gps(s, 2.0, t0_us=1_000_000) == []
    s.settings.gps_disable = 0
    assert [t for t, _ in run_gps(s, 1.0, t0_us=3_000_000)] == list(range(3_000_000, 4_000_000, 200_000))


def test_gps_dropouts_send_no_fix_messages_in_the_expected_proportion():
    s = suite(seed=12, gps_dropout_per_min=60.0, gps_dropout_s=0.5)
    fixes = run_gps(s, 600.0)
    assert len(fixes) == 3000  # still sent at the normal rate
    lost = [f for _, f in fixes if f.fix_type != 3]
    assert all(f.fix_type == 1 and f.satellites == 0 and f.eph_m == f.epv_m == 99.99 for f in lost)
    rd = 60.0 * 0.5
    assert len(lost) / len(fixes) == pytest.approx(rd / (60.0 + rd), rel=0.2)
    # outages come as runs of 2-3 fixes (0.5 s at 5 Hz)
    flags = [f.fix_type == 1 for _, f in fixes]
    runs = sum(1 for a, b in zip([False] + flags, flags) if b and not a)
    assert 2.0 <= len(lost) / runs <= 3.0


def test_reproducible_for_a_seed_and_gps_settings_do_not_disturb_the_imu():
    def record(s):
        z3 = np.zeros(3)
        out = []
        for k in range(500):
            out.append(s.imu(np.array([0.0, 0.0, -G]), z3, LEVEL_NORTH, z3, DT))
            fix = s.gps(k * STEP_US, z3, z3)
            if fix:
                out.append(fix)
        return out

    assert record(suite(seed=21)) == record(suite(seed=21))
    imu_a = [r for r in record(suite(seed=21)) if hasattr(r, "accel_frd_m_s2")]
    imu_b = [
        r for r in record(suite(seed=21, gps_dropout_per_min=30.0, gps_noise_m=2.0)) if hasattr(r, "accel_frd_m_s2")
    ]
    assert imu_a == imu_b
    assert record(suite(seed=21)) != record(suite(seed=22))
