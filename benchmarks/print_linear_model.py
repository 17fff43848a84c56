"""Print the hover linearisation ([F] eqs. 4.17-4.19) of a vehicle.

A and B come from sitl.linearize.linearize_hover (central differences through the
simulator's MuJoCo model); the largest difference from the corrected analytic model
of [F] (sitl.linearize.seed_hover_model) and the eigenvalues of A follow.
Frames: state (x_n, y_n, z_n NED m; u, v, w FRD m/s; phi, theta, psi rad; p, q, r FRD
rad/s), input (T - m g N; tau_roll, tau_pitch, tau_yaw FRD N m).

A tool of a few seconds (most of it imports): no progress bar.

Usage: ``python benchmarks/print_linear_model.py firefly [--aero] [--yaw-deg 30]``
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from params.vehicle import load_vehicle  # noqa: E402
from sitl.linearize import linearize_hover, seed_hover_model  # noqa: E402

from _cli import parser  # noqa: E402


def table(matrix: np.ndarray, rows, cols) -> str:
    width = 11
    lines = [" " * 7 + "".join(f"{c:>{width}}" for c in cols)]
    for label, row in zip(rows, matrix):
        cells = "".join(f"{'0':>{width}}" if v == 0 or abs(v) < 5e-9 else f"{v:>{width}.4g}" for v in row)
        lines.append(f"{label:>6} {cells}")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> None:
    ap = parser(__doc__, progress=False)
    ap.add_argument("vehicle", nargs="?", default="quad_x", help="vehicle name or TOML path")
    ap.add_argument("--aero", action="store_true", help="include rotor drag, rolling moment and body drag")
    ap.add_argument("--yaw-deg", type=float, default=0.0, help="hover heading, degrees from North")
    args = ap.parse_args(argv)
    spec = load_vehicle(args.vehicle)
    yaw = math.radians(args.yaw_deg)
    lm = linearize_hover(spec, include_aero=args.aero, yaw_rad=yaw)
    ana = seed_hover_model(spec, yaw_rad=yaw, include_aero=args.aero)
    inertia = ", ".join(f"{j:.6g}" for j in spec.inertia_kg_m2)
    print(
        f"{spec.name}: m = {spec.mass_kg:.6g} kg, J = diag({inertia}) kg m^2, "
        f"yaw {args.yaw_deg:g} deg, aero {'on' if args.aero else 'off'}, "
        f"hover thrust {lm.hover_thrusts_n[0]:.4f} N x {len(spec.rotors)}"
    )
    print("\nA (x_dot = A x + B u)")
    print(table(lm.A, lm.state_labels, lm.state_labels))
    print("\nB")
    print(table(lm.B, lm.state_labels, lm.input_labels))
    print(
        f"\nmax |A - A_seed| = {np.max(np.abs(lm.A - ana.A)):.2e}, "
        f"max |B - B_seed| = {np.max(np.abs(lm.B - ana.B)):.2e}, "
        f"|f(x_e, u_e)| = {lm.equilibrium_residual:.1e}"
    )
    eig = np.linalg.eigvals(lm.A)
    print("eigenvalues of A:", np.array2string(np.sort_complex(eig), precision=4, suppress_small=True))
    print("rank of [B AB ... A^11 B]:", np.linalg.matrix_rank(lm.controllability_matrix()))


if __name__ == "__main__":
    main()
