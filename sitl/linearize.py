"""Linearised hover model of [F 4.4], eqs (4.16)-(4.19).

Two sources of the same (A, B, C):

- :func:`linearize_hover` differentiates the simulated dynamics numerically:
  f(x, u) is evaluated through the MuJoCo model the simulator steps
  (:func:`sitl.model.build_model`) with ``mujoco.mj_forward``, optionally with
  the aerodynamic wrench of :class:`sitl.aerodynamics.Aerodynamics`, and A, B
  are central finite differences about hover.
- :func:`seed_hover_model` writes [F]'s analytic matrices (4.19), with the
  [F]'s typos corrected and in this project's frames (listed in its docstring).

Frames and units (the MAVLink frames of the flight controller):

- State x (12), [F]'s ordering::

      x = [x_n, y_n, z_n,   position, world NED, m
           u, v, w,         velocity, body FRD, m/s
           phi, theta, psi, ZYX Euler angles of the FRD->NED rotation, rad
           p, q, r]         angular rate, body FRD, rad/s

- Input u (4)::

      u = [T - m g,         collective thrust along body -z (up) minus the weight, N
           tau_roll, tau_pitch, tau_yaw]   body torque, FRD, N m

- Output y (6) = [x_n, y_n, z_n, phi, theta, psi].

MuJoCo works in ENU (world) and FLU (body); the only conversions used are those
of :mod:`sitl.frames`.  The free joint's qvel is (world linear velocity of the
body origin, ENU; body angular velocity, FLU); the vehicle's centre of mass is
its body origin (``<inertial pos="0 0 0">``).

Inputs reach the model as rotor thrusts, the simulator's actuator controls
(``data.ctrl[i]`` = thrust of rotor i in N): t = t_e + pinv(E) du, where E is
``spec.effectiveness_matrix()`` (rows roll, pitch, yaw torque and collective
thrust), du = (tau_roll, tau_pitch, tau_yaw, T - m g) and t_e = pinv(E) (0, 0,
0, m g) the hover thrusts (m g / n each for a symmetric frame).  Rotor lag
(the simulator's first-order motor model) is not part of this model: the input
is the thrust itself, as in [F].

Pure: no sockets, files or clocks; every call builds its own MjModel/MjData.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import mujoco
import numpy as np

from mavsim_core import quaternion as quat
from mavsim_core.constants import GRAVITY_M_S2
from mavsim_core.frames import enu_to_ned, flu_to_frd, frd_to_flu, ned_to_enu, quat_ned_frd_to_enu_flu
from params.vehicle import VehicleSpec
from sitl.aerodynamics import Aerodynamics
from sitl.model import build_model

STATE_LABELS = ("x_n", "y_n", "z_n", "u", "v", "w", "phi", "theta", "psi", "p", "q", "r")
STATE_UNITS = ("m", "m", "m", "m/s", "m/s", "m/s", "rad", "rad", "rad", "rad/s", "rad/s", "rad/s")
INPUT_LABELS = ("T-mg", "tau_roll", "tau_pitch", "tau_yaw")
INPUT_UNITS = ("N", "N m", "N m", "N m")
OUTPUT_LABELS = ("x_n", "y_n", "z_n", "phi", "theta", "psi")
_OUTPUT_STATES = (0, 1, 2, 6, 7, 8)

# Height (ENU z, m) at which the vehicle is put to evaluate f: far from the ground, no contact.
LINEARIZE_ALTITUDE_M = 50.0


@dataclass(frozen=True)
class LinearModel:
    """x_dot = A x + B u, y = C x about hover ([F eq. 4.17], 4.19); frames in the module docstring.

    x and u are deviations from the equilibrium x_e = (0, 0, 0, 0, 0, 0, 0, 0, yaw, 0, 0, 0), u_e = 0.
    """

    A: np.ndarray  # 12 x 12
    B: np.ndarray  # 12 x 4
    C: np.ndarray  # 6 x 12
    yaw_rad: float
    include_aero: bool
    source: str  # "mujoco" (numerical) or "seed" (analytic)
    mass_kg: float
    inertia_kg_m2: tuple[float, float, float]
    hover_thrusts_n: tuple[float, ...]
    # |f(x_e, u_e)| of the numerical model: how close (x_e, u_e) is to an equilibrium (0 for "seed").
    equilibrium_residual: float = 0.0
    state_labels: tuple[str, ...] = field(default=STATE_LABELS)
    input_labels: tuple[str, ...] = field(default=INPUT_LABELS)
    output_labels: tuple[str, ...] = field(default=OUTPUT_LABELS)

    @property
    def D(self) -> np.ndarray:
        return np.zeros((self.C.shape[0], self.B.shape[1]))

    def controllability_matrix(self) -> np.ndarray:
        """[B, AB, A^2 B, ..., A^11 B] (12 x 48)."""
        blocks = [self.B]
        for _ in range(self.A.shape[0] - 1):
            blocks.append(self.A @ blocks[-1])
        return np.hstack(blocks)


# --------------------------------------------------------------------------- attitude helpers


def euler_zyx_to_quat_wxyz(phi: float, theta: float, psi: float) -> np.ndarray:
    """Quaternion (w, x, y, z) of R = Rz(psi) Ry(theta) Rx(phi) (seed eq 4.1), FRD->NED here."""
    return quat.from_euler(phi, theta, psi)


def euler_rate_matrix(phi: float, theta: float) -> np.ndarray:
    """W of seed eqs (4.6)-(4.7): (phi_dot, theta_dot, psi_dot) = W (p, q, r)."""
    sf, cf = math.sin(phi), math.cos(phi)
    ct, tt = math.cos(theta), math.tan(theta)
    return np.array(
        [
            [1.0, sf * tt, cf * tt],
            [0.0, cf, -sf],
            [0.0, sf / ct, cf / ct],
        ]
    )


def _quat_to_mat(q_wxyz: np.ndarray) -> np.ndarray:
    m = np.empty(9)
    mujoco.mju_quat2Mat(m, np.asarray(q_wxyz, dtype=float))
    return m.reshape(3, 3)


# --------------------------------------------------------------------------- numerical model


def hover_thrusts_n(spec: VehicleSpec) -> np.ndarray:
    """Per-rotor thrusts (N) giving zero torque and collective thrust m g: pinv(E) (0, 0, 0, m g)."""
    e = spec.effectiveness_matrix()
    return np.linalg.pinv(e) @ np.array([0.0, 0.0, 0.0, spec.mass_kg * GRAVITY_M_S2])


class HoverDynamics:
    """f(x, u) of the simulated vehicle (state and input as in the module docstring).

    Evaluates the simulator's MuJoCo model with ``mj_forward`` (no time step): the
    vehicle is placed at ``LINEARIZE_ALTITUDE_M`` above the ground, so nothing touches.
    """

    def __init__(self, spec: VehicleSpec, include_aero: bool = False, model: mujoco.MjModel | None = None) -> None:
        self.spec = spec
        self.include_aero = include_aero
        self.model = build_model(spec.with_camera_mount("fixed")) if model is None else model
        self.data = mujoco.MjData(self.model)
        self.body_id = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, "vehicle")
        if self.model.nq != 7 or self.model.nv != 6:
            raise ValueError(f"expected one free joint (nq 7, nv 6), model has nq {self.model.nq}, nv {self.model.nv}")
        if self.model.nu != len(spec.rotors):
            raise ValueError(f"expected {len(spec.rotors)} rotor actuators, model has {self.model.nu}")
        self.mass_kg = spec.mass_kg
        self.effectiveness = spec.effectiveness_matrix()
        self.alloc = np.linalg.pinv(self.effectiveness)  # wrench (roll, pitch, yaw, T) -> thrusts
        self.thrust_e_n = hover_thrusts_n(spec)
        self.aero = Aerodynamics(spec) if include_aero else None

    def rotor_thrusts_n(self, u: np.ndarray) -> np.ndarray:
        """Input u = (T - m g, tau_roll, tau_pitch, tau_yaw) -> rotor thrusts (N)."""
        dw = np.array([u[1], u[2], u[3], u[0]], dtype=float)
        return self.thrust_e_n + self.alloc @ dw

    def __call__(self, x: np.ndarray, u: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=float)
        m, d = self.model, self.data
        mujoco.mj_resetData(m, d)
        pos_ned, vel_frd, (phi, theta, psi), rate_frd = x[0:3], x[3:6], x[6:9], x[9:12]
        q_ned_frd = euler_zyx_to_quat_wxyz(phi, theta, psi)
        r_ned_frd = _quat_to_mat(q_ned_frd)
        vel_ned = r_ned_frd @ vel_frd

        d.qpos[0:3] = ned_to_enu(pos_ned) + np.array([0.0, 0.0, LINEARIZE_ALTITUDE_M])
        d.qpos[3:7] = quat_ned_frd_to_enu_flu(q_ned_frd)
        d.qvel[0:3] = ned_to_enu(vel_ned)  # free joint: world linear velocity (ENU)
        d.qvel[3:6] = frd_to_flu(rate_frd)  # free joint: body angular velocity (FLU)
        thrusts = self.rotor_thrusts_n(u)
        d.ctrl[:] = thrusts
        if self.aero is not None:
            # Still air: relative wind V_a = -V_n (4.11), in the body frame; w_i = sqrt(T_i / k_T) (4.8).
            speeds = [math.sqrt(max(t, 0.0) / self.spec.k_thrust) for t in thrusts]
            v_air_flu = frd_to_flu(-vel_frd)
            wrench = self.aero.wrench_flu(speeds, v_air_flu)
            r_enu_flu = _quat_to_mat(d.qpos[3:7])
            # xfrc_applied: (force, torque) in world coordinates, applied at the body's centre of mass.
            d.xfrc_applied[self.body_id, 0:3] = r_enu_flu @ np.asarray(wrench[0:3])
            d.xfrc_applied[self.body_id, 3:6] = r_enu_flu @ np.asarray(wrench[3:6])
        mujoco.mj_forward(m, d)
        if d.ncon:
            raise RuntimeError(f"vehicle in contact ({d.ncon}) while linearising; raise LINEARIZE_ALTITUDE_M")

        acc_ned = enu_to_ned(d.qacc[0:3])
        rate_dot_frd = flu_to_frd(d.qacc[3:6])
        xdot = np.empty(12)
        xdot[0:3] = vel_ned  # P_dot = V_n (4.2)
        # V_b = R^T V_n  =>  V_b_dot = R^T V_n_dot - Omega x V_b  (R_dot = R S(Omega), 4.4)
        xdot[3:6] = r_ned_frd.T @ acc_ned - np.cross(rate_frd, vel_frd)
        xdot[6:9] = euler_rate_matrix(phi, theta) @ rate_frd  # (4.6)-(4.7)
        xdot[9:12] = rate_dot_frd
        return xdot


def _default_steps(spec: VehicleSpec) -> tuple[np.ndarray, np.ndarray]:
    """Finite-difference steps: 1e-6 in SI units of the state, relative to m g and m g l for inputs."""
    x_eps = np.full(12, 1e-6)
    arm_m = max(math.hypot(r.position_frd_m[0], r.position_frd_m[1]) for r in spec.rotors)
    mg = spec.mass_kg * GRAVITY_M_S2
    u_eps = np.array([1e-6 * mg, 1e-6 * mg * arm_m, 1e-6 * mg * arm_m, 1e-6 * mg * spec.k_moment])
    return x_eps, u_eps


def linearize_hover(
    spec: VehicleSpec,
    include_aero: bool = False,
    yaw_rad: float = 0.0,
    eps: float | tuple[np.ndarray, np.ndarray] | None = None,
    model: mujoco.MjModel | None = None,
) -> LinearModel:
    """A, B, C of seed eqs (4.17)-(4.19) from the simulator's own dynamics, by central differences.

    ``include_aero`` adds rotor drag (4.12), rolling moment (4.13) and body drag of
    :class:`sitl.aerodynamics.Aerodynamics` in still air.  ``eps`` is one step for every
    state and input, or a pair (state steps (12,), input steps (4,)); by default 1e-6 in
    SI units for the state and 1e-6 of m g (N) and m g l (N m) for the inputs.
    ``model`` defaults to the simulator's model of the airframe (its camera fixed: no gimbal joints); pass another
    MjModel of the same vehicle (one free-joint body "vehicle", one actuator per rotor)
    only to linearise a variant of it.
    """
    f = HoverDynamics(spec, include_aero=include_aero, model=model)
    if eps is None:
        x_eps, u_eps = _default_steps(spec)
    elif np.isscalar(eps):
        x_eps, u_eps = np.full(12, float(eps)), np.full(4, float(eps))
    else:
        x_eps, u_eps = (np.asarray(e, dtype=float) for e in eps)
    x_e = np.zeros(12)
    x_e[8] = yaw_rad
    u_e = np.zeros(4)

    a = np.empty((12, 12))
    for j in range(12):
        dx = np.zeros(12)
        dx[j] = x_eps[j]
        a[:, j] = (f(x_e + dx, u_e) - f(x_e - dx, u_e)) / (2 * x_eps[j])
    b = np.empty((12, 4))
    for j in range(4):
        du = np.zeros(4)
        du[j] = u_eps[j]
        b[:, j] = (f(x_e, u_e + du) - f(x_e, u_e - du)) / (2 * u_eps[j])
    return LinearModel(
        A=a,
        B=b,
        C=_output_matrix(),
        yaw_rad=yaw_rad,
        include_aero=include_aero,
        source="mujoco",
        mass_kg=spec.mass_kg,
        inertia_kg_m2=tuple(float(i) for i in spec.inertia_kg_m2),
        hover_thrusts_n=tuple(float(t) for t in f.thrust_e_n),
        equilibrium_residual=float(np.max(np.abs(f(x_e, u_e)))),
    )


# --------------------------------------------------------------------------- analytic model


def _output_matrix() -> np.ndarray:
    c = np.zeros((6, 12))
    for row, col in enumerate(_OUTPUT_STATES):
        c[row, col] = 1.0
    return c


def aero_hover_terms(spec: VehicleSpec) -> np.ndarray:
    """Extra entries of A (12 x 12) from seed eqs (4.11)-(4.15) at hover in still air.

    With V_a = -V (still air) and rotor i at r_i (FRD) turning at its hover speed w_i:
    V_a_perp = (-u, -v, 0) in FRD, so

    - force F_d = sum_i w_i k_d V_a_perp:  u_dot += -K/m u,  v_dot += -K/m v,  K = k_d sum_i w_i;
    - moment of the drag applied at the rotors, sum_i r_i x F_d,i:
      p_dot += k_d sum_i w_i z_i / I_xx v,  q_dot += -k_d sum_i w_i z_i / I_yy u,
      r_dot += (k_d sum_i w_i y_i u - k_d sum_i w_i x_i v) / I_zz  (zero for a symmetric frame);
    - rolling moment M_r = sum_i w_i k_r V_a_perp:  p_dot += -k_r sum w_i / I_xx u,
      q_dot += -k_r sum w_i / I_yy v.

    Body drag is quadratic in the airspeed, so it adds nothing at hover.  Rotor speeds
    come from the hover thrusts: w_i = sqrt(T_i / k_T) (4.8).
    """
    jx, jy, jz = spec.inertia_kg_m2
    m = spec.mass_kg
    w = np.sqrt(np.maximum(hover_thrusts_n(spec), 0.0) / spec.k_thrust)
    pos = np.array([r.position_frd_m for r in spec.rotors])
    kd, kr = spec.rotor_drag_k_d, spec.rolling_moment_k_r
    a = np.zeros((12, 12))
    U, V, P, Q, R = 3, 4, 9, 10, 11
    a[U, U] = -kd * w.sum() / m
    a[V, V] = -kd * w.sum() / m
    a[P, V] = kd * (w @ pos[:, 2]) / jx
    a[Q, U] = -kd * (w @ pos[:, 2]) / jy
    a[R, U] = kd * (w @ pos[:, 1]) / jz
    a[R, V] = -kd * (w @ pos[:, 0]) / jz
    a[P, U] += -kr * w.sum() / jx
    a[Q, V] += -kr * w.sum() / jy
    return a


def seed_hover_model(spec: VehicleSpec, yaw_rad: float = 0.0, include_aero: bool = False) -> LinearModel:
    """The analytic A, B, C of seed eq (4.19), corrected, in NED/FRD, with the spec's m and J.

    Intended matrices (small angles about phi = theta = 0, psi = yaw_rad; g = 9.80665 m/s^2,
    the simulator's gravity)::

        x_n_dot   = u cos(psi) - v sin(psi)        p_dot = tau_roll  / I_xx
        y_n_dot   = u sin(psi) + v cos(psi)        q_dot = tau_pitch / I_yy
        z_n_dot   = w                              r_dot = tau_yaw   / I_zz
        u_dot     = -g theta                       phi_dot = p
        v_dot     = +g phi                         theta_dot = q
        w_dot     = -(T - m g) / m                 psi_dot = r

    Derivation (NED world, FRD body): V_b_dot = R^T (g e_z) - (T/m) e_z - Omega x V_b, and
    R^T e_z = (-sin theta, cos theta sin phi, cos theta cos phi) is the third row of (4.1):
    nose-up pitch (theta > 0) tilts the thrust (body -z) backwards, u_dot = -g theta;
    right roll (phi > 0) tilts it to the right, v_dot = +g phi; thrust above the weight
    accelerates up, i.e. towards -z, w_dot = -(T - m g)/m.  W of (4.7) is the identity at
    hover and J Omega_dot = tau - Omega x J Omega loses its quadratic term.

    Corrections to [F]'s printed (4.19), and why:

    1. A is printed 12 x 13 with its attitude rows shifted: the phi_dot row is all zero and
       the ones of phi_dot = p, theta_dot = q, psi_dot = r sit in rows 8-10, columns 11-13.
       A state of 12 needs A 12 x 12 with A[phi, p] = A[theta, q] = A[psi, r] = 1 (eq 4.6
       with W = I at hover).
    2. B is printed 11 x 4 with 1/m on the v row (row 5) and 1/I on rows 9-11: one zero row
       is missing.  With 12 states the thrust enters the w row (row 6; thrust acts along
       body z) and 1/I_xx, 1/I_yy, 1/I_zz the p, q, r rows (10-12).
    3. The input "T - g" is a force difference: T - m g (N).
    4. "cos phi ~ 0, cos theta ~ 0" is meant as cos ~ 1 (small angles).
    5. Frames: [F] is ENU/FLU (thrust along +z_b); this project is NED/FRD, so the
       thrust row is -1/m (w positive down) and u_dot = -g theta (seed: +g theta).
       [F]'s v_dot = +g phi is what NED/FRD gives; in [F]'s own ENU/FLU it
       would be -g phi (positive roll about forward tilts +z_b toward -y_b), so the printed
       sign is an error there.
    6. The position rows rotate body velocity to the world by yaw (cos psi, -sin psi;
       sin psi, cos psi) and z_dot = w; these hold in NED/FRD unchanged (psi clockwise from
       North, z down in both frames) and are kept.
    7. C as printed selects (x_n, y_n, z_n, u, v, w) (columns 1-6), contradicting
       y = (x_n, y_n, z_n, phi, theta, psi); C here selects columns 1-3 and 7-9.
    8. (Not in 4.19, for the record) eq (4.5) is printed J Omega_dot = Omega x J Omega + ...;
       Euler's equation has -Omega x J Omega.  It is quadratic in Omega and vanishes at hover.
    9. m and J are the vehicle file's totals (``spec.mass_kg``, ``spec.inertia_kg_m2``), as
       given to MuJoCo; g is the simulator's 9.80665 m/s^2, not [F]'s rounded 9.81.

    ``include_aero`` adds :func:`aero_hover_terms` (the linearised eqs 4.11-4.15), which the
    [F]'s (4.19) leaves out.
    """
    g = GRAVITY_M_S2
    m = spec.mass_kg
    jx, jy, jz = (float(i) for i in spec.inertia_kg_m2)
    c, s = math.cos(yaw_rad), math.sin(yaw_rad)
    X, Y, Z, U, V, W, PHI, THETA, PSI, P, Q, R = range(12)
    a = np.zeros((12, 12))
    a[X, U], a[X, V] = c, -s
    a[Y, U], a[Y, V] = s, c
    a[Z, W] = 1.0
    a[U, THETA] = -g
    a[V, PHI] = g
    a[PHI, P] = a[THETA, Q] = a[PSI, R] = 1.0
    if include_aero:
        a += aero_hover_terms(spec)
    b = np.zeros((12, 4))
    b[W, 0] = -1.0 / m
    b[P, 1] = 1.0 / jx
    b[Q, 2] = 1.0 / jy
    b[R, 3] = 1.0 / jz
    return LinearModel(
        A=a,
        B=b,
        C=_output_matrix(),
        yaw_rad=yaw_rad,
        include_aero=include_aero,
        source="seed",
        mass_kg=m,
        inertia_kg_m2=(jx, jy, jz),
        hover_thrusts_n=tuple(float(t) for t in hover_thrusts_n(spec)),
    )
