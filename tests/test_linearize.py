"""The hover linearisation of [F 4.4] (sitl.linearize).

The numerical A, B (central differences through the simulator's MuJoCo model) must
equal the corrected analytic matrices of eq (4.19), for both vehicle files and at two
yaw angles; rotor drag and rolling moment (4.12)-(4.15) must add exactly the entries
they should; the no-drag A is nilpotent (integrator chains) and (A, B) controllable.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from mavsim_core.constants import GRAVITY_M_S2
from params.vehicle import load_vehicle
from sitl.linearize import (
    INPUT_LABELS,
    STATE_LABELS,
    HoverDynamics,
    LinearModel,
    linearize_hover,
    seed_hover_model,
)
from sitl.model import build_model

VEHICLES = ["quad_x", "firefly"]
YAWS_RAD = [0.0, math.radians(30.0)]
ATOL = 1e-4
RTOL = 1e-5
S = {name: i for i, name in enumerate(STATE_LABELS)}


_CACHE: dict[tuple[str, bool, float], LinearModel] = {}


def numeric(name: str, include_aero: bool = False, yaw_rad: float = 0.0) -> LinearModel:
    key = (name, include_aero, yaw_rad)
    if key not in _CACHE:
        spec = load_vehicle(name)
        _CACHE[key] = linearize_hover(
            spec, include_aero=include_aero, yaw_rad=yaw_rad, model=build_model(spec.with_camera_mount("fixed"))
        )
    return _CACHE[key]


@pytest.mark.parametrize("name", VEHICLES)
def test_simulator_model_has_the_files_mass_and_inertia(name):
    """Even [F]'s firefly J (Izz > Ixx + Iyy, refused by MuJoCo's compiler) reaches the model exactly."""
    spec = load_vehicle(name)
    model = build_model(spec)
    body = model.body("vehicle").id
    assert model.body_mass[body] == pytest.approx(spec.mass_kg)
    assert model.body_inertia[body] == pytest.approx(spec.inertia_kg_m2)


@pytest.mark.parametrize("name", VEHICLES)
def test_shapes_labels_and_output_matrix(name):
    lm = numeric(name)
    assert lm.A.shape == (12, 12) and lm.B.shape == (12, 4) and lm.C.shape == (6, 12)
    assert lm.state_labels == STATE_LABELS and lm.input_labels == INPUT_LABELS
    x = np.arange(1.0, 13.0)
    assert np.array_equal(lm.C @ x, x[[0, 1, 2, 6, 7, 8]])  # y = (x_n, y_n, z_n, phi, theta, psi)


@pytest.mark.parametrize("name", VEHICLES)
def test_hover_is_an_equilibrium(name):
    spec = load_vehicle(name)
    lm = numeric(name)
    assert lm.equilibrium_residual < 1e-9
    n = len(spec.rotors)
    assert np.allclose(lm.hover_thrusts_n, spec.mass_kg * GRAVITY_M_S2 / n, rtol=1e-12)


@pytest.mark.parametrize("yaw_rad", YAWS_RAD)
@pytest.mark.parametrize("name", VEHICLES)
def test_numeric_matches_seed_analytic(name, yaw_rad):
    spec = load_vehicle(name)
    num, ana = numeric(name, yaw_rad=yaw_rad), seed_hover_model(spec, yaw_rad=yaw_rad)
    np.testing.assert_allclose(num.A, ana.A, rtol=RTOL, atol=ATOL)
    np.testing.assert_allclose(num.B, ana.B, rtol=RTOL, atol=ATOL)
    np.testing.assert_array_equal(num.C, ana.C)


@pytest.mark.parametrize("name", VEHICLES)
def test_analytic_entries_from_first_principles(name):
    """Spot-check the [F] model's signs independently of its code (NED/FRD)."""
    spec = load_vehicle(name)
    yaw = math.radians(30.0)
    a, b = seed_hover_model(spec, yaw_rad=yaw).A, seed_hover_model(spec, yaw_rad=yaw).B
    g, m = GRAVITY_M_S2, spec.mass_kg
    assert a[S["x_n"], S["u"]] == pytest.approx(math.cos(yaw)) and a[S["x_n"], S["v"]] == pytest.approx(-math.sin(yaw))
    assert a[S["y_n"], S["u"]] == pytest.approx(math.sin(yaw)) and a[S["y_n"], S["v"]] == pytest.approx(math.cos(yaw))
    assert a[S["z_n"], S["w"]] == 1.0
    assert a[S["u"], S["theta"]] == -g  # nose up tilts the thrust backwards
    assert a[S["v"], S["phi"]] == g  # right wing down tilts it to the right
    assert b[S["w"], 0] == -1.0 / m  # more thrust: accelerate up = -z (NED)
    for k, (rate, angle) in enumerate((("p", "phi"), ("q", "theta"), ("r", "psi"))):
        assert a[S[angle], S[rate]] == 1.0
        assert b[S[rate], 1 + k] == 1.0 / spec.inertia_kg_m2[k]
    assert np.count_nonzero(a) == 10 and np.count_nonzero(b) == 4


@pytest.mark.parametrize("name", VEHICLES)
def test_rotor_drag_and_rolling_moment_terms(name):
    spec = load_vehicle(name)
    plain, aero = numeric(name), numeric(name, include_aero=True)
    n = len(spec.rotors)
    w_hover = math.sqrt(spec.mass_kg * GRAVITY_M_S2 / (n * spec.k_thrust))  # (4.8)
    jx, jy, jz = spec.inertia_kg_m2
    # Rotor drag (4.12), (4.14): F = -sum(w_i) k_d (u, v, 0) in still air.
    drag = -n * w_hover * spec.rotor_drag_k_d / spec.mass_kg
    assert aero.A[S["u"], S["u"]] == pytest.approx(drag, rel=0.03)
    assert aero.A[S["v"], S["v"]] == pytest.approx(drag, rel=0.03)
    # Moments: rolling moment (4.13), (4.15) sum(w_i) k_r V_a_perp, and the drag acting at the
    # rotors, z_i (FRD, negative: above the centre of mass) from the centre of mass.
    z_sum = sum(r.position_frd_m[2] for r in spec.rotors)
    roll_k = n * w_hover * spec.rolling_moment_k_r
    expected = {
        ("p", "u"): -roll_k / jx,
        ("q", "v"): -roll_k / jy,
        ("p", "v"): w_hover * spec.rotor_drag_k_d * z_sum / jx,
        ("q", "u"): -w_hover * spec.rotor_drag_k_d * z_sum / jy,
        ("r", "u"): 0.0,
        ("r", "v"): 0.0,
    }
    delta = aero.A - plain.A
    for (row, col), value in expected.items():
        assert delta[S[row], S[col]] == pytest.approx(value, rel=0.03, abs=ATOL), (row, col)
    mask = np.ones((12, 12), dtype=bool)
    for row, col in [("u", "u"), ("v", "v"), *expected]:
        mask[S[row], S[col]] = False
    np.testing.assert_allclose(delta[mask], 0.0, atol=ATOL)
    np.testing.assert_allclose(aero.B, plain.B, rtol=RTOL, atol=ATOL)
    # And the analytic terms of sitl.linearize agree with the numbers.
    ana = seed_hover_model(spec, include_aero=True)
    np.testing.assert_allclose(aero.A, ana.A, rtol=RTOL, atol=ATOL)


@pytest.mark.parametrize("name", VEHICLES)
def test_no_drag_model_is_an_integrator_chain(name):
    spec = load_vehicle(name)
    ana = seed_hover_model(spec, yaw_rad=YAWS_RAD[1]).A
    assert np.max(np.abs(np.linalg.eigvals(ana))) < 1e-12
    num = numeric(name, yaw_rad=YAWS_RAD[1]).A
    # Chains up to 4 long (q -> theta -> u -> x_n): a rounding error e moves eigenvalues by
    # about e^(1/4), so 1e-9 noise gives ~1e-4; nilpotency, A^4 = 0, is the sharp statement.
    assert np.max(np.abs(np.linalg.eigvals(num))) < 1e-3
    a4 = np.linalg.matrix_power(num, 4)
    assert np.max(np.abs(a4)) < 1e-6 * np.max(np.abs(np.linalg.matrix_power(np.abs(num), 3)))
    assert np.max(np.abs(np.linalg.matrix_power(num, 3))) > 1.0  # the chain is really 4 long


@pytest.mark.parametrize("include_aero", [False, True])
@pytest.mark.parametrize("name", VEHICLES)
def test_controllable(name, include_aero):
    lm = numeric(name, include_aero=include_aero)
    ctrb = lm.controllability_matrix()
    assert ctrb.shape == (12, 48)
    assert np.linalg.matrix_rank(ctrb) == 12
    assert np.linalg.matrix_rank(seed_hover_model(load_vehicle(name)).controllability_matrix()) == 12


def test_dynamics_is_nonlinear_away_from_hover():
    """f itself (not only its Jacobian): a 30 deg roll at hover thrust sags, g (1 - cos 30) down."""
    spec = load_vehicle("quad_x")
    f = HoverDynamics(spec, model=build_model(spec.with_camera_mount("fixed")))
    x = np.zeros(12)
    x[S["phi"]] = math.radians(30.0)
    xdot = f(x, np.zeros(4))
    # Body frame: gravity R^T g e_z minus thrust m g / m along z: (0, g sin phi, g cos phi - g).
    np.testing.assert_allclose(
        xdot[3:6], [0.0, GRAVITY_M_S2 * 0.5, GRAVITY_M_S2 * (math.cos(math.radians(30)) - 1)], atol=1e-9
    )
