"""sitl.wind: steady wind, Dryden turbulence statistics, 1-cosine gusts, live settings, reproducibility.

Pure and deterministic: fixed seeds, simulated time only, no wall clock.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from sitl.sim_settings import WindSettings
from sitl.wind import FT_PER_M, WindModel

DT_S = 0.004


def run(
    model: WindModel, n: int, altitude_m: float = 10.0, airspeed_m_s: float = 3.0, dt_s: float = DT_S
) -> np.ndarray:
    step = model.step
    return np.array([step(dt_s, altitude_m, airspeed_m_s) for _ in range(n)])


def dryden_scales(altitude_m: float, sigma: float) -> tuple[float, float, float]:
    """(L_u, L_w, sigma_w) in metres and m/s from the MIL-F-8785C low-altitude formulas."""
    h_ft = altitude_m * FT_PER_M
    k = 0.177 + 0.000823 * h_ft
    return h_ft / k**1.2 / FT_PER_M, altitude_m, sigma * k**0.4


def autocorr(x: np.ndarray, lag: int) -> float:
    x = x - x.mean()
    return float(np.dot(x[:-lag], x[lag:]) / (len(x) - lag) / x.var())


# --- steady wind ---------------------------------------------------------------------------------


@pytest.mark.parametrize(
    "direction_deg, expected",
    [
        (270.0, (0.0, 5.0, 0.0)),  # from the West: the air moves East
        (0.0, (-5.0, 0.0, 0.0)),  # from the North: the air moves South
        (90.0, (0.0, -5.0, 0.0)),
        (180.0, (5.0, 0.0, 0.0)),
    ],
)
def test_steady_wind_direction_is_where_it_blows_from(direction_deg, expected):
    model = WindModel(WindSettings(speed_m_s=5.0, direction_deg=direction_deg), seed=1)
    for _ in range(3):
        vel = model.step(DT_S, 10.0, 0.0)
        assert vel == pytest.approx(expected, abs=1e-9)
    assert model.velocity_ned_m_s == vel


def test_calm_returns_exact_zero():
    model = WindModel(WindSettings(), seed=1)
    assert model.step(DT_S, 10.0, 3.0) == (0.0, 0.0, 0.0)
    assert model.velocity_ned_m_s == (0.0, 0.0, 0.0)


# --- turbulence ----------------------------------------------------------------------------------


def test_dryden_turbulence_statistics():
    sigma, altitude_m, airspeed_m_s, n = 2.0, 5.0, 20.0, 200_000
    model = WindModel(WindSettings(speed_m_s=5.0, direction_deg=270.0, turbulence_m_s=sigma), seed=7)
    wind = run(model, n, altitude_m, airspeed_m_s)
    l_u_m, l_w_m, sigma_w = dryden_scales(altitude_m, sigma)
    # Mean wind towards East: u is along East, v (to its right) along South, w Down.
    u = wind[:, 1] - 5.0
    v = -wind[:, 0]
    w = wind[:, 2]
    assert u.std() == pytest.approx(sigma, rel=0.10)
    assert v.std() == pytest.approx(sigma, rel=0.10)
    assert w.std() == pytest.approx(sigma_w, rel=0.15)
    for x in (u, v, w):
        assert abs(x.mean()) < 0.2 * sigma
    # Correlation at a lag of one correlation length, L / V: u is first order (e^-1);
    # v and w follow the second-order Dryden correlation (1 - xi / 2L) e^(-xi/L) = e^-1 / 2.
    lag_u = round(l_u_m / airspeed_m_s / DT_S)
    lag_w = round(l_w_m / airspeed_m_s / DT_S)
    assert autocorr(u, lag_u) == pytest.approx(math.exp(-1.0), abs=0.1)
    assert autocorr(v, lag_u) == pytest.approx(0.5 * math.exp(-1.0), abs=0.1)
    assert autocorr(w, lag_w) == pytest.approx(0.5 * math.exp(-1.0), abs=0.1)


def test_turbulence_variance_is_exact_for_long_steps():
    # The discretisation is exact in distribution, so a coarse step keeps sigma.
    sigma, altitude_m, airspeed_m_s = 1.5, 20.0, 10.0
    model = WindModel(WindSettings(turbulence_m_s=sigma), seed=3)
    wind = run(model, 20_000, altitude_m, airspeed_m_s, dt_s=0.5)
    _, _, sigma_w = dryden_scales(altitude_m, sigma)
    assert wind[:, 0].std() == pytest.approx(sigma, rel=0.10)  # no mean wind: u along North
    assert wind[:, 1].std() == pytest.approx(sigma, rel=0.10)
    assert wind[:, 2].std() == pytest.approx(sigma_w, rel=0.15)


def test_turbulence_defined_in_hover_and_with_bad_inputs():
    model = WindModel(WindSettings(turbulence_m_s=2.0), seed=4)
    wind = np.array([model.step(DT_S, alt, 0.0) for alt in (0.0, -5.0, math.nan, 1e6, math.inf) * 200])
    assert np.all(np.isfinite(wind))
    assert np.any(wind != 0.0)
    with pytest.raises(ValueError):
        model.step(-DT_S, 10.0, 0.0)


# --- gusts ---------------------------------------------------------------------------------------


def test_random_gusts_peak_along_the_wind():
    settings = WindSettings(
        speed_m_s=5.0, direction_deg=270.0, gust_speed_m_s=3.0, gust_duration_s=2.0, gust_interval_s=10.0
    )
    model = WindModel(settings, seed=11)
    wind = run(model, 125_000)  # 500 s
    assert np.abs(wind[:, 0]).max() < 1e-9  # horizontal and along the wind only
    assert np.abs(wind[:, 2]).max() == 0.0
    east = wind[:, 1]
    assert east.min() == pytest.approx(5.0, abs=1e-9)
    assert east.max() == pytest.approx(8.0, abs=0.01)
    in_gust = east > 5.0 + 1e-9
    starts = int(np.count_nonzero(in_gust[1:] & ~in_gust[:-1]))
    assert 25 <= starts <= 80  # ~500 s / (10 s + a little) = ~49


def test_trigger_gust_gives_one_minus_cosine_profile():
    amplitude, duration = 3.0, 2.0
    settings = WindSettings(
        speed_m_s=5.0, direction_deg=0.0, gust_speed_m_s=amplitude, gust_duration_s=duration, gust_interval_s=600.0
    )
    model = WindModel(settings, seed=5)
    model.step(DT_S, 10.0, 0.0)
    model.trigger_gust()
    steps = round(duration / DT_S)
    wind = run(model, steps + 10)
    t = DT_S * np.arange(1, steps + 1)
    expected = 5.0 + 0.5 * amplitude * (1.0 - np.cos(2.0 * np.pi * t / duration))
    assert -wind[:steps, 0] == pytest.approx(expected, abs=1e-9)  # wind from the North moves South
    assert -wind[steps // 2 - 1, 0] == pytest.approx(5.0 + amplitude, abs=1e-9)  # t = T/2: peak A
    assert wind[steps:, 0] == pytest.approx(-5.0, abs=1e-9)  # over after T
    assert np.abs(wind[:, 1]).max() < 1e-9


def test_gust_direction_is_horizontal_and_random_without_steady_wind():
    settings = WindSettings(gust_speed_m_s=2.0, gust_duration_s=1.0, gust_interval_s=600.0)
    model = WindModel(settings, seed=9)
    headings = []
    for _ in range(5):
        model.trigger_gust()
        wind = run(model, round(0.5 / DT_S))
        assert math.hypot(wind[-1, 0], wind[-1, 1]) == pytest.approx(2.0, abs=1e-9)
        assert wind[-1, 2] == 0.0
        headings.append(math.atan2(wind[-1, 1], wind[-1, 0]))
        run(model, round(0.6 / DT_S))
    assert len({round(h, 6) for h in headings}) == 5


def test_gust_speed_zero_stops_gusts():
    settings = WindSettings(
        speed_m_s=5.0, direction_deg=270.0, gust_speed_m_s=3.0, gust_duration_s=2.0, gust_interval_s=2.0
    )
    model = WindModel(settings, seed=12)
    wind = run(model, 5_000)  # 20 s: several gusts
    assert wind[:, 1].max() > 7.0
    model.trigger_gust()
    run(model, 100)  # inside a gust
    settings.gust_speed_m_s = 0.0
    wind = run(model, 25_000)  # 100 s
    assert wind == pytest.approx(np.tile([0.0, 5.0, 0.0], (25_000, 1)), abs=1e-9)


# --- live settings -------------------------------------------------------------------------------


def test_settings_changes_act_on_the_next_step():
    settings = WindSettings(speed_m_s=5.0, direction_deg=270.0)
    model = WindModel(settings, seed=2)
    assert model.step(DT_S, 10.0, 0.0) == pytest.approx((0.0, 5.0, 0.0), abs=1e-9)
    settings.speed_m_s = 8.0
    assert model.step(DT_S, 10.0, 0.0) == pytest.approx((0.0, 8.0, 0.0), abs=1e-9)
    settings.direction_deg = 0.0
    assert model.step(DT_S, 10.0, 0.0) == pytest.approx((-8.0, 0.0, 0.0), abs=1e-9)

    settings.turbulence_m_s = 2.0  # switched on: fully developed at once
    first = model.step(DT_S, 10.0, 0.0)
    assert first != pytest.approx((-8.0, 0.0, 0.0), abs=1e-6)
    wind = run(model, 20_000, 10.0, 0.0)
    assert np.all(wind.std(axis=0) > 0.1)
    settings.turbulence_m_s = 0.0  # switched off
    assert model.step(DT_S, 10.0, 0.0) == pytest.approx((-8.0, 0.0, 0.0), abs=1e-9)

    settings.speed_m_s = 0.0  # calm
    assert model.step(DT_S, 10.0, 0.0) == (0.0, 0.0, 0.0)

    settings.gust_speed_m_s = 4.0  # gusts switched on: a triggered gust blows
    settings.gust_duration_s = 1.0
    settings.gust_interval_s = 600.0
    model.trigger_gust()
    wind = run(model, round(0.5 / DT_S))
    assert math.hypot(wind[-1, 0], wind[-1, 1]) == pytest.approx(4.0, abs=1e-9)


# --- reproducibility -----------------------------------------------------------------------------


def _gusty_turbulent_run(seed: int) -> np.ndarray:
    settings = WindSettings(
        speed_m_s=4.0,
        direction_deg=45.0,
        turbulence_m_s=1.5,
        gust_speed_m_s=3.0,
        gust_duration_s=1.0,
        gust_interval_s=3.0,
    )
    model = WindModel(settings, seed=seed)
    wind = run(model, 3_000, 15.0, 6.0)
    settings.direction_deg = 200.0
    settings.speed_m_s = 0.0
    return np.vstack([wind, run(model, 3_000, 15.0, 6.0)])


def test_same_seed_same_sequence():
    a = _gusty_turbulent_run(42)
    b = _gusty_turbulent_run(42)
    c = _gusty_turbulent_run(43)
    assert np.array_equal(a, b)
    assert not np.array_equal(a, c)
