"""The landing deck's horizontal motion as a coordinated turn (constant speed and turn rate): an interacting multiple
model (filterpy's IMMEstimator) of two unscented Kalman filters on the deck's absolute position, one whose turn rate
holds, one whose turn rate may jump, so that a deck driving a circle or a figure-8 is predicted on its arc, through
the gaps between fixes and while the marker is out of view, and a figure-8's reversed turn is taken up within a few
fixes.

Issue 34 item 5.  The per-axis constant-velocity Kalman (:mod:`autopilot.navigation.landing_target_estimator`)
assumes the deck drives straight: on a 2 m circle at 2 m/s (1 rad/s, 2 m/s^2 across the track) its velocity lags
the deck's heading by ~20 deg, which held the vehicle 0.35-0.6 m outside the deck's circle; its position drifted
0.5-0.8 m in 0.7 s blind; fixes then fell outside its gate and it restarted with the deck taken as still (velocity
0), whose differenced velocity step fed 7-8 m/s^2 forward and saturated the mixer.  Here:

* state ``[north m, east m, v_north m/s, v_east m/s, turn rate rad/s, marker lag m]`` (turn rate positive clockwise
  seen from above, north toward east), moved on by :func:`turn_step` (a straight drive when the rate is ~0);
* process noise: white acceleration ``acc_var`` ((m/s^2)^2, along and across the track alike) and a turn rate
  that wanders by ``turn_acc_var`` ((rad/s^2)^2) in the steady model, by ``jump_turn_acc_var`` in the manoeuvring
  one (a figure-8 reverses its turn, +1 -> -1 rad/s, within a quarter of a second);
* chosen by measurement on the UGV's own tracks (the kept truth logs of 2 m/s circle and figure-8 landings, fixes
  at 20 Hz with 2 cm noise, predicted 0.1 / 0.35 / 0.7 / 1.5 s ahead from every fix; mean error, cm): circle
  1.2 / 1.8 / 2.7 / 5.4 (one steady turn filter 1.4 / 2.2 / 3.7 / 8.3; the constant-velocity Kalman with the
  heading coast of target_coast 7.7 / 17 / 31 / 57); figure-8 2.8 / 7.9 / 22 / 83 (one turn filter 6.1 / 16 / 39
  / 130, 4.1 / 11 / 27 / 94 with a looser turn rate that is twice as far off on the circle; the CV Kalman 7.9 /
  19 / 40 / 108): across the figure-8's crossing no model knows which way the deck will turn;
* measurement: the deck's north and east position (m, NED, from the estimator's origin) at its capture time;
  gated with a 2-degree-of-freedom chi-square test; after ``REFIT_AFTER_REJECTS`` refusals in a row the filter is
  re-seated on the fix *keeping its velocity and turn rate* (a deck does not stop because the fit slipped);
* with ``heading`` (PLD_DECK_HDG 1 or 2; the flight controller's default is 0, the landing scenario sets 2:
  docs/landing.md, "The marker's heading in the deck model"), the marker's heading (LANDING_TARGET's orientation,
  modulo 90 deg), when the sender gives it, fused after each fix's position (:meth:`DeckTurnFilter._fuse_heading`):
  a ground vehicle points where it drives, so at a figure-8's crossing the heading turns the other way at once,
  where the positions take a few fixes to show it (20 Hz, 2 cm, 2 deg: the turn rate has the new sign 0.1 s after
  the crossing, against 0.25-0.85 s, and the velocity is off by 0.05-0.11 m/s over the next 0.5 s, against
  0.21-0.89).  A marker not over the turning axle points into the turn by atan(lag x rate / speed) from its
  direction of travel (4.3 deg on the simulated UGV, 0.15 m behind its axle, on a 2 m circle at 2 m/s; fused as if
  it pointed along the track, that bias held the vehicle ahead of the deck: 11 of the first 24 figure-8 landings
  landed): the lag is the state's sixth element, learnt in the turns.  On a steady turn it and the direction of
  travel shift the heading alike, so learnt from 0 (mode 1) a lag can run to its bound at 1 m/s and bend the
  velocity 2-4 deg; learnt from a first guess (``lag_m``, mode 2: PLD_DECK_LAG, the pad's mount, within
  ``lag_prior_var_m2``) it settles on the vehicle's effective lag (0.18 m for the simulated UGV, whose geometry says
  0.15: its wheels slip) and the velocity stays within 0.4 deg;
* the filter lives at the time of its latest fix; :meth:`DeckTurnFilter.state_at` predicts the mean forward
  (fixes arrive in time order, 50 ms late: it is never run backwards), straight on when the turn's acceleration
  is below STRAIGHT_PREDICT_BELOW_M_S2 (a straight drive's fitted rate is noise).

Pure: time is an input (microseconds), no I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING

import numpy as np

from autopilot.navigation.deck_heading import square

if TYPE_CHECKING:
    from filterpy.kalman import IMMEstimator

    from autopilot.navigation.fast_ukf import RowsUKF

CHI2_GATE_2DOF = 13.8  # 99.9 % of a chi-square with 2 degrees of freedom
REFIT_AFTER_REJECTS = 3  # refused fixes in a row before the filter is re-seated on the next one
STRAIGHT_BELOW_RAD_S = 1e-4  # a smaller turn rate is moved on as a straight drive (no division by ~0)
MAX_TURN_RATE_RAD_S = 2.0  # the turn rate is held to this (a UGV turning on the spot is not a deck to land on)
# Predicted on (state_at), a turn whose acceleration across the track (rate x speed, m/s^2) is below this is taken
# as a straight drive: the fitted rate of a deck driving a line wanders by ~0.06 rad/s, 0.28 m sideways after
# 1.5 s at 3 m/s; a 2 m circle at 1 m/s is 0.5 m/s^2 (as target_coast's dead band).
STRAIGHT_PREDICT_BELOW_M_S2 = 0.25


@dataclass(frozen=True, slots=True)
class DeckTurnSettings:
    """Noise and timing of :class:`DeckTurnFilter` (units in the names)."""

    acc_var_m2_s4: float = 0.3  # white acceleration of the deck, per axis
    turn_acc_var_rad2_s4: float = 0.05  # how fast its turn rate may change: steady model
    jump_turn_acc_var_rad2_s4: float = 100.0  # ... manoeuvring model
    stay_prob: float = 0.995  # the chance a model holds from one fix to the next
    pos_var_in_m2: float = 0.1  # initial position variance
    vel_var_in_m2_s2: float = 4.0  # initial velocity variance (a deck seen first may already drive 2 m/s)
    turn_var_in_rad2_s2: float = 0.5  # initial turn-rate variance
    timeout_s: float = 2.0  # no accepted fix for this long: the estimate is invalid, the next fix restarts
    # The marker's heading (modulo 90 deg) as the ground vehicle's (with ``heading``): its variance, rad^2 (0: not
    # fused), fused only while the deck drives faster than heading_min_speed_m_s and within heading_gate_rad.
    heading_var_rad2: float = math.radians(3.0) ** 2
    heading_min_speed_m_s: float = 0.5
    heading_gate_rad: float = math.radians(25.0)
    lag_var_in_m2: float = 0.1  # the marker's lag behind the turning axle (m): initial variance
    lag_prior_var_m2: float = 0.05**2  # ... when a first guess is given (the pad's mount: PLD_DECK_LAG)
    lag_var_m2_s: float = 1e-4  # ... and its random walk (a fixed mount, learnt in the turns)
    lag_max_m: float = 0.5  # ... held within +-this (the heading is known modulo 90 deg: no aliased fit)
    heading_vel_var_max_m2_s2: float = 0.05  # fused only once the velocity is known this well (per axis)


@dataclass(frozen=True, slots=True)
class DeckState:
    """The deck's horizontal state at ``timestamp_us``: position (m NED), velocity over the ground (m/s NED),
    acceleration (m/s^2 NED, that of the turn), turn rate (rad/s, clockwise from above), position variance
    (m^2, north and east)."""

    timestamp_us: int
    pos_ne_m: np.ndarray
    vel_ne_m_s: np.ndarray
    acc_ne_m_s2: np.ndarray
    turn_rad_s: float
    pos_var_m2: np.ndarray


def turn_step(x: np.ndarray, dt_s: float) -> np.ndarray:
    """The state ``[n, e, vn, ve, w, ...]`` moved on by ``dt_s`` at its constant speed and turn rate (NED, m, m/s,
    rad/s clockwise from above); what follows ``w`` (the marker's lag behind the turning axle, m) holds."""
    n, e, vn, ve, w = (float(v) for v in x[:5])
    rest = [float(v) for v in x[5:]]
    th = w * dt_s
    if abs(w) < STRAIGHT_BELOW_RAD_S:
        return np.array([n + vn * dt_s, e + ve * dt_s, vn, ve, w, *rest])
    s, c = math.sin(th), math.cos(th)
    return np.array(
        [n + (vn * s - ve * (1.0 - c)) / w, e + (ve * s + vn * (1.0 - c)) / w, vn * c - ve * s, vn * s + ve * c, w,
         *rest]
    )  # fmt: skip


def turn_step_rows(xs: np.ndarray, dt_s: float) -> np.ndarray:
    """:func:`turn_step` of each row of ``xs`` (the sigma points of :class:`DeckTurnFilter`'s filters), in one call."""
    xs = np.asarray(xs, dtype=float)
    n, e, vn, ve, w = xs[:, 0], xs[:, 1], xs[:, 2], xs[:, 3], xs[:, 4]
    straight = np.abs(w) < STRAIGHT_BELOW_RAD_S
    w_div = np.where(straight, 1.0, w)
    th = w * dt_s
    s, c = np.sin(th), np.cos(th)
    out = xs.copy()
    out[:, 0] = np.where(straight, n + vn * dt_s, n + (vn * s - ve * (1.0 - c)) / w_div)
    out[:, 1] = np.where(straight, e + ve * dt_s, e + (ve * s + vn * (1.0 - c)) / w_div)
    out[:, 2] = np.where(straight, vn, vn * c - ve * s)
    out[:, 3] = np.where(straight, ve, vn * s + ve * c)
    return out


def _measure(x: np.ndarray) -> np.ndarray:
    return np.asarray(x[:2], dtype=float)


def _heading_off_square(x: np.ndarray, square_yaw_rad: float) -> np.ndarray:
    """The deck's heading in state ``x`` off the marker's heading ``square_yaw_rad``, modulo 90 deg (rad).  A ground
    vehicle points where its turning axle drives; its marker, ``x[5]`` metres behind that axle, moves
    atan(lag x turn rate / speed) off that heading in a turn (toward the inside: its velocity is the state's)."""
    vn, ve, w, lag = float(x[2]), float(x[3]), float(x[4]), float(x[5])
    heading = math.atan2(ve, vn) + math.atan2(lag * w, math.hypot(vn, ve))
    return np.array([square(heading - square_yaw_rad)])  # (the difference of two headings of a square)


def _heading_off_square_rows(xs: np.ndarray, square_yaw_rad: float) -> np.ndarray:
    """:func:`_heading_off_square` of each row of ``xs`` (the sigma points), as a column."""
    vn, ve, w, lag = xs[:, 2], xs[:, 3], xs[:, 4], xs[:, 5]
    heading = np.arctan2(ve, vn) + np.arctan2(lag * w, np.hypot(vn, ve))
    return np.asarray(square(heading - square_yaw_rad))[:, None]  # (square() on an array: numpy's % as Python's)


_heading_off_square.rows = _heading_off_square_rows  # type: ignore[attr-defined]  # (RowsUKF.update: all at once)


def _measure_rows(xs: np.ndarray) -> np.ndarray:
    return np.asarray(xs[:, :2], dtype=float)


_measure.rows = _measure_rows  # type: ignore[attr-defined]


class DeckTurnFilter:
    """Feed :meth:`update` with the deck's measured positions in time order; read :meth:`state_at`.  ``heading``:
    the marker's heading is fused too, with the marker's lag as a sixth state, learnt in the turns from 0 (PLD_DECK_HDG
    1) or from ``lag_m`` (m behind the turning axle, PLD_DECK_HDG 2 with PLD_DECK_LAG: the pad's mount) with a
    variance of ``lag_prior_var_m2``; without it the filter is the five-state one, the marker's heading ignored."""

    def __init__(
        self, settings: DeckTurnSettings | None = None, heading: bool = False, lag_m: float | None = None
    ) -> None:
        s = settings or DeckTurnSettings()
        self.heading = bool(heading)
        self._n = 6 if self.heading else 5
        # The lag's first guess (m; the pad's mount on the ground vehicle, PLD_DECK_HDG 2): learnt from there.
        self.lag_m = None if lag_m is None or not self.heading else max(-s.lag_max_m, min(s.lag_max_m, float(lag_m)))
        if self.lag_m is not None:
            s = replace(s, lag_var_in_m2=s.lag_prior_var_m2)
        self.settings = s
        self._turn_vars = (s.turn_acc_var_rad2_s4, s.jump_turn_acc_var_rad2_s4)
        self._ukfs: list[RowsUKF] = []  # built with the first fix (_build)
        self._imm: IMMEstimator | None = None
        self._t_us: int | None = None  # time of the state (the latest accepted fix)
        self.rejected_count = 0
        self._rejected_in_row = 0

    def _build(self) -> IMMEstimator:
        """The two filters and their IMM.  filterpy is imported here, with the first fix: its package imports
        scipy.stats, 0.7 s of CPU that every flight controller would pay at start-up (mavsim_core/butterworth.py)."""
        if self._imm is not None:
            return self._imm
        from filterpy.kalman import IMMEstimator

        from autopilot.navigation.fast_ukf import RowsMerweSigmaPoints, RowsUKF

        s, n = self.settings, self._n
        self._ukfs = [
            RowsUKF(n, 2, 0.05, _measure, turn_step_rows, RowsMerweSigmaPoints(n, 0.3, 2.0, 0.0))
            for _ in (s.turn_acc_var_rad2_s4, s.jump_turn_acc_var_rad2_s4)
        ]
        switch = np.array([[s.stay_prob, 1.0 - s.stay_prob], [1.0 - s.stay_prob, s.stay_prob]])
        self._imm = IMMEstimator(self._ukfs, np.array([0.5, 0.5]), switch)
        return self._imm

    @property
    def started(self) -> bool:
        return self._t_us is not None

    def valid_at(self, t_us: int) -> bool:
        return self._t_us is not None and (t_us - self._t_us) * 1e-6 <= self.settings.timeout_s

    def _start(self, t_us: int, z: np.ndarray, vel: np.ndarray, turn: float, p: np.ndarray, lag: float = 0.0) -> None:
        x = np.array([z[0], z[1], vel[0], vel[1], turn, lag][: self._n], dtype=float)
        imm = self._build()
        for f in self._ukfs:
            f.x, f.P = x.copy(), p.copy()
        imm.x, imm.P = x.copy(), p.copy()
        self._t_us = t_us

    def _q(self, dt_s: float, turn_var_rad2_s4: float | None = None) -> np.ndarray:
        """The process noise of ``dt_s``: white acceleration on each axis, a wandering turn rate (the steady
        model's unless ``turn_var_rad2_s4``)."""
        qa = self.settings.acc_var_m2_s4
        qw = self.settings.turn_acc_var_rad2_s4 if turn_var_rad2_s4 is None else turn_var_rad2_s4
        q = np.zeros((self._n, self._n))
        for p, v in ((0, 2), (1, 3)):
            q[p, p] = qa * dt_s**4 / 4.0
            q[p, v] = q[v, p] = qa * dt_s**3 / 2.0
            q[v, v] = qa * dt_s**2
        q[4, 4] = qw * dt_s**2
        if self._n > 5:
            q[5, 5] = self.settings.lag_var_m2_s * dt_s
        return q

    def update(self, t_us: int, pos_ne_m: np.ndarray, var_m2: float, square_yaw_rad: float | None = None) -> bool:
        """Fuse the deck's position ``pos_ne_m`` (m NED, north and east) seen at ``t_us`` with variance ``var_m2``
        per axis, and the marker's heading then (``square_yaw_rad``, rad NED modulo 90 deg; None: not seen) as the
        ground vehicle's heading (with ``heading``: :meth:`_fuse_heading`); False if the position was refused (not
        finite, older than the state, or outside the gate)."""
        z = np.asarray(pos_ne_m, dtype=float)[:2]
        if not np.all(np.isfinite(z)) or not math.isfinite(var_m2) or var_m2 <= 0.0:
            return False
        s = self.settings
        if not self.valid_at(t_us):
            p0 = np.diag(
                ([s.pos_var_in_m2] * 2 + [s.vel_var_in_m2_s2] * 2 + [s.turn_var_in_rad2_s2, s.lag_var_in_m2])[: self._n]
            )
            self._start(t_us, z, np.zeros(2), 0.0, p0, self.lag_m or 0.0)
            self._rejected_in_row = 0
            return True
        assert self._t_us is not None and self._imm is not None
        imm = self._imm
        dt_s = (t_us - self._t_us) * 1e-6
        if dt_s < 0.0:
            return False
        r = np.eye(2) * var_m2
        for f, qw in zip(self._ukfs, self._turn_vars):
            f._dt, f.Q, f.R = dt_s, self._q(dt_s, qw), r  # (the IMM calls predict() and update(z) without them)
        if dt_s > 0.0:
            imm.predict()
            self._t_us = t_us
        innov = z - imm.x[:2]
        cov = imm.P[:2, :2] + r
        if float(innov @ np.linalg.solve(cov, innov)) > CHI2_GATE_2DOF:
            self.rejected_count += 1
            self._rejected_in_row += 1
            if self._rejected_in_row <= REFIT_AFTER_REJECTS:
                return False
            # The fit slipped: re-seat the position on the fix, keep the velocity and turn rate (loosened).
            x = imm.x.copy()
            p = imm.P.copy()
            p[:2, :] = 0.0
            p[:, :2] = 0.0
            p[0, 0] = p[1, 1] = max(var_m2, s.pos_var_in_m2)
            p[2:4, 2:4] += np.eye(2) * 0.25 * s.vel_var_in_m2_s2
            self._start(t_us, z, x[2:4].copy(), float(x[4]), p, float(x[5]) if self._n > 5 else 0.0)
            self._rejected_in_row = 0
            return True
        imm.update(z)
        self._fuse_heading(square_yaw_rad)
        for f in self._ukfs:
            f.x[4] = max(-MAX_TURN_RATE_RAD_S, min(MAX_TURN_RATE_RAD_S, float(f.x[4])))
            if self._n > 5:
                f.x[5] = max(-s.lag_max_m, min(s.lag_max_m, float(f.x[5])))
            f.P = 0.5 * (f.P + f.P.T)
        self._rejected_in_row = 0
        return True

    def _fuse_heading(self, square_yaw_rad: float | None) -> None:
        """The marker's heading as the ground vehicle's (it drives where it points, the marker ``x[5]`` behind its
        turning axle: :func:`_heading_off_square`; the marker's square gives it modulo 90 deg, which a reverse drive
        does not change), fused after
        the position of the same fix into each model, whose probabilities it weighs too (a sequential update of
        the IMM).  At a figure-8's crossing the heading turns the other way at once, where the positions need a
        few fixes to show it.  Skipped below the speed at which a velocity has a direction, beyond the gate (a
        marker read the wrong way round), and with ``heading_var_rad2`` 0."""
        s, imm = self.settings, self._imm
        if not self.heading or imm is None or s.heading_var_rad2 <= 0.0:
            return
        if square_yaw_rad is None or not math.isfinite(square_yaw_rad):
            return
        if math.hypot(float(imm.x[2]), float(imm.x[3])) < s.heading_min_speed_m_s:
            return
        if max(float(imm.P[2, 2]), float(imm.P[3, 3])) > s.heading_vel_var_max_m2_s2:
            return  # (a direction of travel not yet fitted: the heading would be put into the lag)
        if abs(float(_heading_off_square(imm.x, square_yaw_rad)[0])) > s.heading_gate_rad:
            return
        r = np.array([[s.heading_var_rad2]])
        likelihood = np.empty(len(self._ukfs))
        for k, f in enumerate(self._ukfs):
            f.sigmas_f = f.points_fn.sigma_points(f.x, f.P)  # (the sigma points of the state after the position)
            f.update(np.zeros(1), R=r, hx=_heading_off_square, square_yaw_rad=square_yaw_rad)
            likelihood[k] = f.likelihood
        mu = imm.mu * likelihood
        if float(mu.sum()) > 0.0:
            imm.mu = mu / mu.sum()
        imm._compute_mixing_probabilities()
        imm._compute_state_estimate()
        imm.x_post, imm.P_post = imm.x.copy(), imm.P.copy()

    def shift(self, delta_ne_m: np.ndarray) -> None:
        """Move the deck by ``delta_ne_m`` (m, north and east) with an estimator reset of the vehicle's position: the
        fixes are the vehicle's position plus the relative one, so the deck's frame moved with it."""
        d = np.asarray(delta_ne_m, dtype=float)[:2]
        if not np.all(np.isfinite(d)):
            return
        if self._imm is None:
            return
        for f in self._ukfs:
            f.x[:2] += d
        self._imm.x[:2] += d

    @property
    def marker_lag_m(self) -> float:
        """How far behind the ground vehicle's turning axle its marker sits (m), as learnt from its heading in turns
        (0 before the first fix)."""
        return 0.0 if self._imm is None or self._n < 6 else float(self._imm.x[5])

    def state_at(self, t_us: int) -> DeckState | None:
        """The deck's state predicted to ``t_us`` (the filter is not advanced); None before the first fix or after
        the timeout."""
        if not self.valid_at(t_us) or self._t_us is None:
            return None
        assert self._imm is not None
        dt_s = max(0.0, (t_us - self._t_us) * 1e-6)
        x = self._imm.x.copy()
        if abs(float(x[4])) * math.hypot(float(x[2]), float(x[3])) < STRAIGHT_PREDICT_BELOW_M_S2:
            x[4] = 0.0
        x = turn_step(x, dt_s)
        vn, ve, w = float(x[2]), float(x[3]), float(x[4])
        var = np.diag(self._imm.P)[:2] + np.diag(self._q(dt_s))[:2]
        return DeckState(t_us, x[:2].copy(), np.array([vn, ve]), np.array([-w * ve, w * vn]), w, var)
