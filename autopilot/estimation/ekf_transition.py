"""The error-state EKF's transition matrix: the entries that one prediction rewrites, on plain floats.

The state is (position, velocity, attitude error, gyro bias, accelerometer bias), 15 entries, as in
:mod:`autopilot.estimation.ekf`.  Over one prediction interval of ``t`` seconds the transition F
is the identity except the blocks F[P, V] = t I (set by the EKF itself), F[V, TH] = -R [u]x,
F[V, BA] = -R t, F[TH, TH] = I - [d]x and F[TH, BG] = -t I, with R the attitude (FRD -> NED), u the
bias-corrected delta velocity (m/s, FRD) and d the bias-corrected delta angle (rad, FRD).
"""

from __future__ import annotations

import numpy as np

N = 15  # error-state size

# The entries of the transition matrix rewritten at each prediction (flat indices into the 15x15 F):
# the 3x3 blocks F[V, TH], F[V, BA] and F[TH, TH], row by row, then the diagonal of F[TH, BG].
F_INDEX = np.array(
    [r * N + c for r in range(3, 6) for c in range(6, 9)]
    + [r * N + c for r in range(3, 6) for c in range(12, 15)]
    + [r * N + c for r in range(6, 9) for c in range(6, 9)]
    + [6 * N + 9, 7 * N + 10, 8 * N + 11]
)


def f_blocks(r: tuple[float, ...], u: tuple[float, float, float], d: tuple[float, float, float], t: float) -> list:
    """The values of F at ``F_INDEX``: -R [u]x, -R t, I - [d]x and -t (R row by row; u the bias-corrected
    delta velocity, d the delta angle, FRD)."""
    r0, r1, r2, r3, r4, r5, r6, r7, r8 = r
    u0, u1, u2 = u
    d0, d1, d2 = d
    # -R [u]x, with [u]x = [[0, -u2, u1], [u2, 0, -u0], [-u1, u0, 0]]
    return [
        -(r1 * u2 - r2 * u1), -(r2 * u0 - r0 * u2), -(r0 * u1 - r1 * u0),
        -(r4 * u2 - r5 * u1), -(r5 * u0 - r3 * u2), -(r3 * u1 - r4 * u0),
        -(r7 * u2 - r8 * u1), -(r8 * u0 - r6 * u2), -(r6 * u1 - r7 * u0),
        -r0 * t, -r1 * t, -r2 * t, -r3 * t, -r4 * t, -r5 * t, -r6 * t, -r7 * t, -r8 * t,
        1.0, d2, -d1, -d2, 1.0, d0, d1, -d0, 1.0,
        -t, -t, -t,
    ]  # fmt: skip
