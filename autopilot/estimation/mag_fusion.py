"""Three-axis magnetometer fusion into the EKF, against the World Magnetic Model's field at the origin.

Measurement model (gauss, FRD body; ``F_ned`` the WMM field vector at the origin, gauss NED)::

    m = R^T F_ned + noise          (R: FRD -> NED, the filter's attitude)

With the EKF's body-frame attitude error (q_true = q * exp(dtheta)), R_true^T F = (I - [dtheta]x) R^T F,
so the innovation's Jacobian is d(m)/d(dtheta) = [m0]x with m0 = R^T F_ned; nothing else enters.  The
three components are fused as one vector update (a 3x3 innovation covariance), rejected together if
any component fails its gate (test ratio innovation^2 / (gate^2 S_ii) > 1), as PX4's EKF2 does.
The estimator fuses one reading every 100 ms (as it fused the heading), which keeps the filter's
cost per IMU sample where it was.

Why three axes and not the heading alone (``EKF2_MAG_TYPE``, PX4's numbers: 0 = automatic, the
three-axis fusion once the field at the origin is known; 1 = heading only): the field's direction
is known (declination and inclination from the model), so the magnetometer measures the whole
attitude, roll and pitch included.  That separates a tilt error from a horizontal accelerometer
bias, which gravity and GPS alone cannot do while the vehicle keeps its heading (both make the same
horizontal acceleration error).  The price: an uncalibrated magnetometer (an offset below the field
strength check of :mod:`autopilot.estimation.mag_health`) pulls roll and pitch as well as yaw;
``EKF2_MAG_TYPE = 1`` keeps it to the heading.  No earth-field or body-bias states: the field is the
model's, the magnetometer is assumed calibrated (the simulator's offsets default to zero).
"""

from __future__ import annotations

import numpy as np

from autopilot.estimation.ekf import TH, ErrorStateEkf
from autopilot.parameters import ParamDef, ParamType, param

MAG_TYPE_AUTO, MAG_TYPE_HEADING = 0, 1

P_MAG_TYPE = param(
    "EKF2_MAG_TYPE",
    MAG_TYPE_AUTO,
    0,
    1,
    "",
    "Magnetometer fusion: 0 = three-axis against the World Magnetic Model once the origin is known, 1 = heading only",
    ParamType.INT32,
)
P_MAG_NOISE = param("EKF2_MAG_NOISE", 0.005, 0.001, 1.0, "gauss", "Magnetometer measurement noise (per axis)")
P_MAG_GATE = param("EKF2_MAG_GATE", 5.0, 1.0, 20.0, "SD", "Innovation gate of three-axis magnetometer fusion")

# The parameters this module reads (listed in autopilot/param_catalogue.py).
PARAMS: tuple[ParamDef, ...] = (P_MAG_TYPE, P_MAG_NOISE, P_MAG_GATE)


def fuse_mag_vector(
    ekf: ErrorStateEkf,
    mag_frd: np.ndarray,
    field_ned: np.ndarray,
    noise: float,
    gate: float,
    since_rad: np.ndarray | None = None,
) -> bool:
    """Fuse one magnetometer reading (gauss, FRD) against ``field_ned`` (gauss, NED); False if gated out.

    ``noise`` is the per-axis 1-sigma (gauss), ``gate`` in standard deviations.  ``since_rad`` (FRD): the
    rotation between the reading's time and the time the filter's state describes (the last IMU sample's
    rate x its period: the sample holds over the period, the reading is of its start); the expected
    reading is turned back by it.  Sets ``ekf.ratio["mag"]`` to the largest component's test ratio and
    counts a rejection in ``ekf.rejected["mag"]``."""
    x, y, z = (ekf.r_ned_frd.T @ field_ned).tolist()
    if since_rad is not None:  # R(t)^T F = exp([w dt]x) R(t + dt)^T F, to first order
        a, b, c = since_rad.tolist()
        x, y, z = x + b * z - c * y, y + c * x - a * z, z + a * y - b * x
    h = np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])  # [m0]x: d(m)/d(dtheta); nothing else enters
    pht = ekf.cov[:, TH] @ h.T  # P H^T, 15x3
    s = h @ pht[TH]
    s.flat[::4] += noise * noise
    innov = mag_frd - (x, y, z)
    ratio = innov * innov / (gate * gate * np.diagonal(s))
    worst = float(ratio.max())
    ekf.ratio["mag"] = worst
    if worst > 1.0:
        ekf.rejected["mag"] += 1
        return False
    k = pht @ _inverse_sym3(s)  # P H^T S^-1
    ekf.cov -= k @ pht.T
    ekf.inject(k @ innov)
    return True


def _inverse_sym3(s: np.ndarray) -> np.ndarray:
    """The inverse of a symmetric positive-definite 3x3 matrix (its adjugate over its determinant): a few
    float operations instead of a LAPACK call."""
    (a, b, c), (_, d, e), (_, _, f) = s.tolist()
    c00, c01, c02 = d * f - e * e, c * e - b * f, b * e - c * d
    c11, c12, c22 = a * f - c * c, b * c - a * e, a * d - b * b
    inv_det = 1.0 / (a * c00 + b * c01 + c * c02)
    return np.array([[c00, c01, c02], [c01, c11, c12], [c02, c12, c22]]) * inv_det
