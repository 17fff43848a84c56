"""Vehicle files (params.vehicle): hover speed, broken files refused clearly, unknown names.

No sockets, no processes, no clocks.  (From tests/test_units.py, split by subject.)
"""

from __future__ import annotations

import math

import pytest

from params.vehicle import VEHICLE_DIR, VehicleFileError, load_vehicle

QUAD_TOML = (VEHICLE_DIR / "quad_x.toml").read_text()


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


@pytest.mark.parametrize(
    ("edit", "message"),
    [
        (lambda t: t.replace("k_thrust = 8.54858e-6", ""), "missing 'k_thrust'"),
        (
            lambda t: t.replace('spin = ["ccw", "ccw", "cw", "cw"]', 'spin = ["ccw", "cww", "cw", "cw"]'),
            "rotor 2 spin must be 'ccw' or 'cw', is 'cww'",
        ),
        (
            lambda t: t.replace(
                "positions_frd_m = [[0.46, 0.46, -0.06], [-0.46, -0.46, -0.06], [0.46, -0.46, -0.06], "
                "[-0.46, 0.46, -0.06]]",
                "positions_frd_m = [[0.46, 0.46, -0.06], [-0.46, -0.46, -0.06], [0.46, -0.46, -0.06]]",
            ).replace('spin = ["ccw", "ccw", "cw", "cw"]', 'spin = ["ccw", "ccw", "cw"]'),
            "a multirotor needs at least 4 rotors, has 3",
        ),
        (lambda t: t.replace("mass_kg = 1.0", "mass_kg = -1.0"), "'mass_kg' must be > 0, is -1.0"),
        (lambda t: t.replace("[legs]", "[lags]"), "missing section [legs]"),
        (lambda t: t.replace("max_speed_rad_s = 838.0", "max_speed_rad_s = 500.0"), "cannot hover with margin"),
    ],
)
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
