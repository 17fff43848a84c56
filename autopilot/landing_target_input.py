"""LANDING_TARGET messages -> the landing-target estimate the precision landing flies on.

Pure (no sockets, no clock): the process loop hands each received LANDING_TARGET to
:meth:`LandingTargetInput.on_message` with its sender's system id; the flight controller
calls :meth:`record_state` every control step and :meth:`update` in its 50 Hz outer loop.

- Only our own system's messages count (a companion computer is a component of the vehicle);
  others are counted in ``ignored_other_system`` and change nothing.
- Each message is decoded by :func:`autopilot.mavlink.landing_target.decode_landing_target`
  (PX4's LOCAL_NED form, ArduPilot's BODY_FRD form, the angular form) with the attitude and
  position the vehicle had **at the message's ``time_usec``** (the capture time; in lockstep the
  simulator's clock is ours), looked up in a one-second history of control steps.  A
  ``time_usec`` of 0, in the future or older than the history is taken as the receipt time.
- A refusal (NaN, an unknown frame, ...) is reported once per distinct reason as a STATUSTEXT
  (``events``), never once per message.
- The measurement, as old as its capture time, is moved on to now with the estimated relative
  velocity, then fused by the Kalman filter (:mod:`autopilot.navigation.landing_target_estimator`,
  ``LTEST_*``), or, with ``PLD_DECK_MDL`` = 1 (the default), each fix, as the deck's position at its capture
  time, feeds the turning-deck filter (:mod:`autopilot.navigation.deck_turn_filter`), whose deck is predicted to
  now; with ``PLD_PREDICTOR`` = 1 the target's track feeds the document's 4th-order polynomial predictor
  (:mod:`autopilot.navigation.target_predictor`, [F 3]).

Frames: NED metres and m/s relative to the estimator origin; attitude (w, x, y, z) FRD -> NED.
"""

from __future__ import annotations

import bisect
import math
from collections import deque
from typing import Any

import numpy as np

from autopilot.mavlink.landing_target import LandingTargetRefusal, decode_landing_target
from autopilot.navigation.deck_turn_filter import DeckState, DeckTurnFilter
from autopilot.navigation.landing_target_estimator import LandingTargetEstimator, LandingTargetSettings
from autopilot.navigation.precland import LandingTargetInput as TargetForTask
from autopilot.navigation.target_predictor import PolynomialTargetPredictor
from autopilot.parameters import ParamDef, ParameterStore, ParamType, param
from autopilot.topics import LandingTargetEstimate, LandingTargetMeasurement, VehicleEstimate

PARAMS: tuple[ParamDef, ...] = (
    param(
        "PLD_PREDICTOR",
        0,
        0,
        1,
        "",
        "Landing target predictor: 0 Kalman filter (LTEST_*), 1 4th-order polynomial of the track [F 3] (ours)",
        ParamType.INT32,
    ),
    param(
        "PLD_DECK_MDL", 1, 0, 1, "",
        "Landing deck model (Kalman predictor): 0 constant velocity relative to the vehicle (LTEST_*, PX4's), "
        "1 a deck that turns (constant speed and turn rate, deck_turn_filter; ours)",
        ParamType.INT32,
    ),
    param(
        "PLD_DECK_HDG", 0, 0, 2, "",
        "The turning deck model (PLD_DECK_MDL 1) also takes the marker's heading from LANDING_TARGET's orientation "
        "as the ground vehicle's (its edges along the vehicle's axes): 0 positions only, 1 the heading with the "
        "marker's distance behind the vehicle's turning axle learnt in turns, 2 learnt from PLD_DECK_LAG (ours)",
        ParamType.INT32,
    ),
    param(
        "PLD_DECK_LAG", 0.0, -0.5, 0.5, "m",
        "With PLD_DECK_HDG 2: how far the landing marker's centre is behind the ground vehicle's turning axle "
        "(the rear axle of a car-like vehicle; negative: ahead of it), a first guess within 5 cm (ours)",
    ),
)  # fmt: skip

HISTORY_US = 1_000_000  # attitude/position history kept for delayed measurements
ACC_TAU_S = 0.3  # low-pass time constant of the target's acceleration (differenced velocity estimate)


class LandingTargetInput:
    """See the module docstring."""

    def __init__(self, params: ParameterStore, own_sysid: int = 1) -> None:
        self.params = params
        self.own_sysid = own_sysid
        self.estimator = LandingTargetEstimator(LandingTargetSettings.from_params(params.get))
        self.predictor = PolynomialTargetPredictor()
        self.deck = DeckTurnFilter()  # PLD_DECK_MDL 1: the deck's absolute motion, turning
        self._deck_down_m: float | None = None  # the deck's latest measured down coordinate (m NED)
        self._reset_count: int | None = None  # the estimator's position resets seen (the deck is moved with them)
        self._t: deque[int] = deque()
        self._state: deque[tuple[np.ndarray, np.ndarray, float]] = deque()  # q, position, height above ground
        self._pending: list[LandingTargetMeasurement] = []
        self.events: list[str] = []
        self._said: set[str] = set()
        self.received = 0
        self.accepted = 0
        self.ignored_other_system = 0
        self.estimate: LandingTargetEstimate | None = None
        self.target_acc_ned_m_s2 = np.zeros(3)  # the target's acceleration over the ground, low-passed
        self._prev_vel: tuple[int, np.ndarray] | None = None
        self._square: tuple[int, float] | None = None  # the latest fix's square heading: (capture us, rad NED)

    # ---- inputs ------------------------------------------------------------------------------
    def record_state(self, time_us: int, q_wxyz: np.ndarray, pos_ned_m: np.ndarray, height_m: float) -> None:
        """The vehicle's attitude, position and height above ground at one control step."""
        if self._t and time_us <= self._t[-1]:
            if time_us < self._t[-1]:  # time went back (a new simulator): forget the history
                self._t.clear()
                self._state.clear()
            else:
                return
        self._t.append(time_us)
        self._state.append((q_wxyz, pos_ned_m, height_m))
        while self._t and self._t[0] < time_us - HISTORY_US:
            self._t.popleft()
            self._state.popleft()

    def on_message(self, msg: Any, src_sysid: int, now_us: int) -> None:
        """One received LANDING_TARGET (a pymavlink message or anything with its fields)."""
        self.received += 1
        if src_sysid != self.own_sysid:
            self.ignored_other_system += 1
            return
        if not self._t:
            return  # no attitude yet
        stamp = int(getattr(msg, "time_usec", 0) or 0)
        if not (self._t[0] <= stamp <= now_us):
            stamp = now_us
        q, pos, height = self._state_at(stamp)
        result = decode_landing_target(msg, q, height, pos, timestamp_us=stamp)
        if isinstance(result, LandingTargetRefusal):
            self._say_once(result.reason)
            return
        self._pending.append(result)

    def _state_at(self, time_us: int) -> tuple[np.ndarray, np.ndarray, float]:
        i = bisect.bisect_left(self._t, time_us)
        i = min(i, len(self._t) - 1)
        if i > 0 and abs(self._t[i - 1] - time_us) < abs(self._t[i] - time_us):
            i -= 1
        return self._state[i]

    def _say_once(self, reason: str) -> None:
        if reason not in self._said:
            self._said.add(reason)
            self.events.append(reason)

    # ---- the 50 Hz update --------------------------------------------------------------------
    def update(self, now_us: int, est: VehicleEstimate) -> TargetForTask | None:
        """Fuse what arrived since the last call; the target as the precision landing reads it (None: unknown)."""
        self.estimator.set_settings(LandingTargetSettings.from_params(self.params.get))
        self.estimator.predict(now_us, est.accel_ned_m_s2)
        fresh = False
        turning = int(self.params.get("PLD_DECK_MDL")) == 1
        deck = None  # the turn filter's deck predicted to now (PLD_DECK_MDL 1), once per update
        if turning:
            fresh = self._fuse_deck(est)
            deck = self.deck.state_at(now_us)
        for meas in [] if turning else self._pending:
            rel = np.asarray(meas.rel_pos_ned_m, dtype=float)
            self.predictor.add_sample(meas.timestamp_us, rel + self._state_at(meas.timestamp_us)[1])
            # As old as its capture: the target where it was then (from the vehicle's position then),
            # moved on at its estimated velocity over the ground, seen from where the vehicle is now.
            prior = self.estimator.estimate(now_us, est.vel_ned_m_s)
            age_s = max(0.0, (now_us - meas.timestamp_us) * 1e-6)
            target_then = rel + self._state_at(meas.timestamp_us)[1]
            drift = prior.target_vel_ned_m_s * age_s if prior.valid and prior.target_vel_ned_m_s is not None else 0.0
            moved = target_then + drift - est.pos_ned_m
            now_meas = LandingTargetMeasurement(now_us, moved, meas.std_m, meas.source_frame, meas.valid, meas.angular)
            if self.estimator.update(now_meas, est.vel_ned_m_s):
                self.accepted += 1
                fresh = True
        for meas in self._pending:
            if meas.square_yaw_rad is not None:
                self._square = (meas.timestamp_us, meas.square_yaw_rad)
        self._pending.clear()
        e = self._deck_estimate(now_us, est, deck) if turning else self.estimator.estimate(now_us, est.vel_ned_m_s)
        if int(self.params.get("PLD_PREDICTOR")) == 1:
            poly = self.predictor.predict(now_us, 0.0, est.pos_ned_m, est.vel_ned_m_s)
            e = poly if poly.valid else e  # the fit needs 100 samples first; the filter until then
        self.estimate = e
        if turning:
            self.target_acc_ned_m_s2 = np.zeros(3) if deck is None else np.array([*deck.acc_ne_m_s2, 0.0])
        else:
            self._track_acceleration(now_us, e)
        if e is not None and e.valid and int(self.params.get("PLD_PREDICTOR")) == 1 and e.is_static is False:
            if e.rel_pos_var_m2 is not None and len(self.predictor._t_us) >= self.predictor.min_samples:
                self.target_acc_ned_m_s2 = self.predictor.last_acc_ned_m_s2.copy()
        if not fresh or not e.valid or e.target_vel_ned_m_s is None:
            return None  # no new measurement: the task predicts the target on by itself
        # Stamped now: the estimate is already moved on to now (the task must not move it again).
        turn = None if deck is None else deck.turn_rad_s
        return TargetForTask(
            now_us, e.rel_pos_ned_m, e.target_vel_ned_m_s, True, self.target_acc_ned_m_s2.copy(), turn,
            self._square_now(now_us, turn),
        )  # fmt: skip

    def _square_now(self, now_us: int, turn_rad_s: float | None) -> float | None:
        """The deck's square heading (rad NED, modulo 90 deg) moved on from its fix to now at the deck's turn rate;
        None without one in the last second (a sender without the target's orientation)."""
        if self._square is None or now_us - self._square[0] > HISTORY_US:
            return None
        age_s = max(0.0, (now_us - self._square[0]) * 1e-6)
        return self._square[1] + (turn_rad_s or 0.0) * age_s

    def _fuse_deck(self, est: VehicleEstimate) -> bool:
        """PLD_DECK_MDL 1: each pending fix as the deck's absolute position at its capture time into the turn filter
        (its variance from LTEST_MEAS_UNC by the range, as the constant-velocity filter's); True if one was taken."""
        if self._reset_count is not None and est.reset_count != self._reset_count and est.reset_delta_ned_m is not None:
            self.deck.shift(est.reset_delta_ned_m)
            if self._deck_down_m is not None:
                self._deck_down_m += float(est.reset_delta_ned_m[2])
        self._reset_count = est.reset_count
        taken = False
        unc = float(self.params.get("LTEST_MEAS_UNC"))
        mode = int(self.params.get("PLD_DECK_HDG"))  # the marker's heading as the deck's (deck_turn_filter)
        lag = float(self.params.get("PLD_DECK_LAG")) if mode == 2 else None
        if (mode > 0, lag) != (self.deck.heading, self.deck.lag_m):  # another model: it starts again from the next fix
            self.deck = DeckTurnFilter(heading=mode > 0, lag_m=lag)
        for meas in self._pending:
            rel = np.asarray(meas.rel_pos_ned_m, dtype=float)
            deck = rel + self._state_at(meas.timestamp_us)[1]
            self.predictor.add_sample(meas.timestamp_us, deck)
            var = meas.std_m**2 if math.isfinite(meas.std_m) else unc * max(float(rel[2]) ** 2, 1.0)
            square = meas.square_yaw_rad if mode > 0 else None
            if meas.valid and self.deck.update(meas.timestamp_us, deck[:2], var, square):
                taken = True
                self.accepted += 1
                self._deck_down_m = float(deck[2])
        return taken

    def _deck_estimate(self, now_us: int, est: VehicleEstimate, deck: DeckState | None) -> LandingTargetEstimate:
        """The turn filter's deck predicted to now (``deck``), as the target's estimate relative to the vehicle."""
        if deck is None or self._deck_down_m is None:
            zero = np.zeros(3)
            return LandingTargetEstimate(now_us, zero, zero.copy(), False)
        pos = np.array([*deck.pos_ne_m, self._deck_down_m])
        vel = np.array([*deck.vel_ne_m_s, 0.0])
        rel_vel = vel - np.asarray(est.vel_ned_m_s, dtype=float)
        rel_vel[2] = 0.0
        return LandingTargetEstimate(now_us, pos - est.pos_ned_m, rel_vel, True, False, vel, deck.pos_var_m2)

    def _track_acceleration(self, now_us: int, e: LandingTargetEstimate) -> None:
        """The target's acceleration: its velocity estimate differenced and low-passed (ACC_TAU_S)."""
        if not e.valid or e.target_vel_ned_m_s is None:
            self._prev_vel, self.target_acc_ned_m_s2 = None, np.zeros(3)
            return
        vel = np.asarray(e.target_vel_ned_m_s, dtype=float)
        if self._prev_vel is not None:
            dt = (now_us - self._prev_vel[0]) * 1e-6
            if dt > 0.0:
                raw = (vel - self._prev_vel[1]) / dt
                k = dt / (ACC_TAU_S + dt)
                self.target_acc_ned_m_s2 = self.target_acc_ned_m_s2 + k * (raw - self.target_acc_ned_m_s2)
        self._prev_vel = (now_us, vel)

    def pop_events(self) -> list[str]:
        out, self.events = self.events, []
        return out


def height_above_ground(est: VehicleEstimate, ground_down_m: float | None) -> float:
    """Height of the vehicle above the ground (m) from the estimate and the ground's down coordinate."""
    if ground_down_m is None:
        return math.nan
    return ground_down_m - float(est.pos_ned_m[2])
