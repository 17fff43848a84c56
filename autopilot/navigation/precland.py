"""Precision landing (PX4's AUTO.PRECLAND) with the landing phases of [F 3].

Phases (:class:`PrecLandPhase`): PREPARATION hovers PLD_PREP_ALT (2.8 m, [F 3]) above the
ground until the target is seen; TRACKING flies the cubic spline of [F eq. 3.1] to the point
PLD_TRK_ALT (1 m) above the target in td = horizontal error / PLD_TRK_SPD (1 m/s), re-planned
each step on the target's latest position, plus the target's velocity (and, over a moving deck,
its acceleration) as feed-forward, the chase's tilt held where the camera still sees the target
(:mod:`autopilot.navigation.view_limited_catchup`, PLD_VIEW_LIM; ``gimbal_reach_rad``: the gimbal's reach);
APPROACHING holds the point above the target until the horizontal error stays below
PLD_APPR_RAD (5 cm) for APPROACH_HOLD_S and the docking may start (:mod:`dock_gate`, PLD_DOCK_CHK: timed to touch
square to the deck, not into its next turn change; the heading square to the deck, :mod:`deck_heading`,
PLD_DECK_YAW, is flown from tracking on), and DOCKING returns to it when the error exceeds PLD_HACC_RAD or the
heading will touch off square; DOCKING descends on a cubic spline onto the deck (its acceleration within
MPC_ACC_DOWN_MAX, fed forward) while tracking the target horizontally and reports ``done`` (``motors_cut``) at the
docking point.  A target unseen for PLD_BTOUT starts a SEARCH (PLD_SRCH_ALT above the ground, over where a deck that
drove on should be now, up to PLD_SRCH_TOUT, at most PLD_MAX_SRCH times); after that FALLBACK lands normally
(opportunistic) or holds and reports ``failed`` (required).  Every phase change is appended to ``events`` as
(time_us, text).

Frames and units: metres NED relative to the estimator origin, m/s, seconds; ``ground_down_m``
is the ground's down coordinate (NED).  The target's position is relative to the vehicle
(target minus vehicle, NED m), its velocity is over the ground (NED m/s).  Time is an input.
"""

from __future__ import annotations

import math

import numpy as np

from autopilot.navigation.cubic_spline import CubicSpline, duration_s
from autopilot.navigation.cut_lead import CutLead
from autopilot.navigation.deck_heading import DeckHeading
from autopilot.navigation.dock_gate import DockGate, yaw_rate_ned
from autopilot.navigation.flight_task import PositionSetpoint
from autopilot.navigation.land import LandTask
from autopilot.navigation.precland_types import (
    PARAMS,
    LandingTargetInput,
    PrecLandConfig,
    PrecLandMode,
    PrecLandPhase,
)
from autopilot.navigation.target_coast import STILL_M_S, TurnRate, acc_weight, coast
from autopilot.navigation.touchdown import Touchdown
from autopilot.navigation.view_limited_catchup import ViewLimits, view_cone
from autopilot.parameters import ParameterStore
from autopilot.topics import AttitudeSetpoint, VehicleEstimate

__all__ = ["PARAMS", "LandingTargetInput", "PrecLandConfig", "PrecLandMode", "PrecLandPhase", "PrecLandTask"]

TARGET_FRESH_S = 0.3  # a target measurement older than this does not count as seen
APPROACH_HOLD_S = 0.2  # the horizontal error stays below PLD_APPR_RAD this long before docking
APPROACH_SLIP_M_S = 0.1  # ... and the vehicle moves with the target to within this (m/s) before docking
APPROACH_PATIENCE_S = 5.0  # approaching longer than this: within PLD_HACC_RAD (and twice the slip) will do
DOCK_HOVER_M = 0.03  # the docking point: the feet this high (m) above the deck
# Over a moving deck the docking spline ends this far (m) below the deck's top: the legs meet it descending
# (about 0.5 m/s), the motors cut on the contact.  Ending above it at rest, the vehicle could stop blind a few cm
# over a turning deck (braked, bounced up) and hover for the settling time: 0.9 s blind, 0.2-0.34 m off.
DOCK_INTO_DECK_M = 0.05
# A target unseen this long (s) stays where it was (coasting to PLD_BTOUT took a vehicle 10 m from a figure-8)
COAST_MAX_S = 1.5
DOCK_DONE_M = 0.02  # docking point reached: within this (m, vertically) of it
DOCK_SETTLE_S = 0.5  # ... or this long after the docking spline ended (the camera is blind on the deck)
DOCK_TOUCH_M = 0.15  # the legs felt on the deck (ground contact) with the feet estimated this close: docked
DOCK_WAIT_S = 2.0  # the motors cut within 2 x PLD_APPR_RAD or after this long over a still deck (moving: at once)
# From tracking on, the horizontal velocity integrator learns only within this velocity error (m/s): the chase's
# catch-up would wind it up, and given back it held the vehicle 0.2 m behind a 3 m/s deck for seconds.
CHASE_INT_BAND_M_S = 0.5


class PrecLandTask:
    """The precision-landing flight task (FlightTask interface plus the target input).

    ``params`` gives the fallback landing's MPC_LAND_* values; ``config`` the PLD_* values.
    """

    def __init__(
        self,
        ground_down_m: float,
        params: ParameterStore,
        config: PrecLandConfig | None = None,
        mode: PrecLandMode = PrecLandMode.OPPORTUNISTIC,
        yaw_rad: float | None = None,
        feet_below_m: float = 0.0,
    ) -> None:
        self.ground_down_m = ground_down_m
        self.feet_below_m = feet_below_m  # the vehicle's feet below its reference point: docked when they touch
        self.params = params
        self.cfg = config or PrecLandConfig()
        self.mode = mode
        self.yaw_rad = yaw_rad
        self.events: list[tuple[int, str]] = []
        self.phase = PrecLandPhase.PREPARATION
        self.searches = 0
        self.motors_cut = False
        self._failed = False
        self._target: LandingTargetInput | None = None
        self._seen_us: int | None = None  # time of the latest fresh, valid target
        self._tgt_pos: np.ndarray | None = None  # target's latest absolute position, m NED
        self._tgt_vel = np.zeros(3)
        self._tgt_acc = np.zeros(3)  # fed forward while tracking, approaching and docking
        self._dock_end_m = DOCK_HOVER_M  # the feet's height over the deck where the docking spline ends
        self._turn = TurnRate()  # the target's turn rate from its measured headings
        self._lead = CutLead()  # approaching and docking aim off the deck's centre: the drift after the cut
        self._view = ViewLimits.from_store(params)  # the chase keeps the marker in the camera's view
        self.on_deck = False  # set by the commander each step: ground contact (land detector, disturbance observer)
        self.gimbal_reach_rad: float | None = None  # ... and the gimbal device's reach (rad; None: no device)
        self.hover_thrust_frac = 0.5  # ... and the vehicle's hover thrust (fraction of maximum; the touchdown's)
        self._touchdown: Touchdown | None = None  # TOUCHDOWN: level on the deck before the cut (PLD_TD_LEVEL)
        self._fallback: LandTask | None = None
        self.heading = DeckHeading(0.0, False)  # the heading: square to the deck (PLD_DECK_YAW), set on activate
        self._gate = DockGate(int(params.get("PLD_DOCK_CHK")))  # when the docking may start, when it climbs out
        self._last_us: int | None = None  # time of the previous update
        self._used_us: int | None = None  # timestamp of the latest measurement taken
        # the latest measurement moved to its time: (us, position m NED, velocity m/s NED, turn rate rad/s); a search
        # follows the one it started from while the deck was moving
        self._fix: tuple[int, np.ndarray, np.ndarray, float] | None = None
        self._search_fix: tuple[int, np.ndarray, np.ndarray, float] | None = None

    # ---- interface -------------------------------------------------------------------------
    def activate(self, est: VehicleEstimate, now_us: int) -> None:
        """Start in PREPARATION over the vehicle's position, PLD_PREP_ALT above the ground."""
        if self.yaw_rad is None:
            self.yaw_rad = est.yaw_rad
        self.heading = DeckHeading.from_store(self.params, self.yaw_rad)
        self._hold = np.array([est.pos_ned_m[0], est.pos_ned_m[1], self.ground_down_m - self.cfg.prep_alt_m])
        self._enter(PrecLandPhase.PREPARATION, now_us, "hover above the ground until the target is seen")

    def feed_target(self, target: LandingTargetInput | None) -> None:
        """The latest landing-target estimate (None or invalid: not seen)."""
        self._target = target

    def update(
        self, est: VehicleEstimate, now_us: int, target: LandingTargetInput | None = None
    ) -> PositionSetpoint | AttitudeSetpoint:
        """The setpoint for this step; ``target`` (if given) is fed first."""
        if target is not None:
            self._target = target
        visible = self._observe(est, now_us)
        acc = self._tgt_acc * acc_weight(self._tgt_vel)  # the target's acceleration fed forward (none if still)
        if self.phase in (PrecLandPhase.APPROACHING, PrecLandPhase.DOCKING):
            self._lead.update(now_us, est.q_wxyz, est.accel_ned_m_s2, acc)
        self._transitions(est, now_us, visible)
        return self._setpoint(est, now_us, acc)

    @property
    def done(self) -> bool:
        return self.motors_cut

    @property
    def failed(self) -> bool:
        return self._failed

    @property
    def target_pos_ned_m(self) -> np.ndarray | None:
        """The target's estimated position now (m NED; measured, or predicted on while unseen), None before
        it was seen."""
        return None if self._tgt_pos is None else self._tgt_pos.copy()

    @property
    def target_velocity_ned_m_s(self) -> np.ndarray:
        """The target's latest velocity over the ground (m/s NED; zero before it is seen)."""
        return self._tgt_vel.copy()

    def shift(self, delta_ned_m: np.ndarray) -> None:
        """Move the held point, the target and the ground with an estimator reset."""
        self._hold = self._hold + delta_ned_m
        if self._fix is not None:
            self._fix = (self._fix[0], self._fix[1] + delta_ned_m, *self._fix[2:])
        if self._search_fix is not None:
            self._search_fix = (self._search_fix[0], self._search_fix[1] + delta_ned_m, *self._search_fix[2:])
        if self._tgt_pos is not None:
            self._tgt_pos = self._tgt_pos + delta_ned_m
        self.ground_down_m += float(delta_ned_m[2])
        if self._fallback is not None:
            self._fallback.shift(delta_ned_m)

    # ---- internals -------------------------------------------------------------------------
    def _enter(self, phase: PrecLandPhase, now_us: int, why: str) -> None:
        self.phase = phase
        self._phase_us = now_us
        self.events.append((now_us, f"Precland: {phase.value} ({why})"))

    def _observe(self, est: VehicleEstimate, now_us: int) -> bool:
        """Take a new measurement of the target (each once), else predict it on at its last velocity;
        True while the latest measurement is younger than TARGET_FRESH_S."""
        t = self._target
        new = t is not None and t.valid and t.timestamp_us != self._used_us and t.timestamp_us <= now_us
        if new and t is not None:
            rel, vel = np.asarray(t.rel_pos_ned_m, float), np.asarray(t.vel_ned_m_s, float)
            if np.all(np.isfinite(rel)) and np.all(np.isfinite(vel)):
                # The measurement is as old as its timestamp: move it on to now (target_coast).
                acc = t.acc_ned_m_s2
                acc = np.asarray(acc, float) if acc is not None and np.all(np.isfinite(acc)) else np.zeros(3)
                age_s = (now_us - t.timestamp_us) * 1e-6
                self._turn.add(t.timestamp_us, vel, t.turn_rad_s)
                turn = self._turn.rate()
                self._gate.observe_turn(t.timestamp_us, turn)
                self._tgt_pos, self._tgt_vel, self._tgt_acc = coast(
                    est.pos_ned_m + rel, vel, acc, age_s, turn, acc_weight(vel)
                )
                self.heading.observe(now_us, t.square_yaw_rad, self._tgt_vel, t.turn_rad_s)
                self._fix = (now_us, self._tgt_pos.copy(), self._tgt_vel.copy(), turn)
                self._used_us = t.timestamp_us
                self._seen_us = t.timestamp_us  # the loss time (PLD_BTOUT) counts from the last measurement
            else:
                new = False
        if not new and self._tgt_pos is not None and self._last_us is not None:
            # Unseen: the target's point moves on at its last velocity, turning as it was (target_coast), for
            # COAST_MAX_S; then it stays where it was, and so does the vehicle.
            if self._lost_s(now_us) > COAST_MAX_S:
                self._tgt_vel, self._tgt_acc = np.zeros(3), np.zeros(3)
            dt_s = max(0.0, (now_us - self._last_us) * 1e-6)
            self._tgt_pos, self._tgt_vel, self._tgt_acc = coast(
                self._tgt_pos, self._tgt_vel, self._tgt_acc, dt_s, self._turn.rate(), acc_weight(self._tgt_vel)
            )
        self._last_us = now_us
        return self._lost_s(now_us) <= TARGET_FRESH_S

    def _lost_s(self, now_us: int) -> float:
        return math.inf if self._seen_us is None else (now_us - self._seen_us) * 1e-6

    def _feet_above_target(self, est: VehicleEstimate) -> float:
        assert self._tgt_pos is not None
        return float(self._tgt_pos[2] - est.pos_ned_m[2]) - self.feet_below_m

    def _above_target(self, height_m: float) -> np.ndarray:
        assert self._tgt_pos is not None
        return self._tgt_pos - np.array([0.0, 0.0, height_m])

    def _aim(self, height_m: float) -> np.ndarray:
        """The approach's and docking's point: above the target, off its centre by the cut's lead (cut_lead)."""
        return self._above_target(height_m) + self._lead.offset_ned_m(self.params.get("PLD_CUT_LEAD"))

    def _start_tracking(self, est: VehicleEstimate, now_us: int, why: str) -> None:
        offset = est.pos_ned_m - self._above_target(self.cfg.trk_alt_m)
        # [F eq. 3.1]'s td is the horizontal error over the mean speed; a larger height change
        # sets it instead, so the descent to the tracking height is as gentle as the approach.
        td = duration_s(max(float(np.linalg.norm(offset[:2])), abs(float(offset[2]))), self.cfg.trk_spd_m_s)
        self._spline = CubicSpline(offset, np.zeros(3), td)
        self._enter(PrecLandPhase.TRACKING, now_us, f"{why}; td {td:.1f} s")

    def _dock_plan(self, est: VehicleEstimate) -> tuple[float, float, float]:
        """The docking spline's end (the feet's height over the deck, m), its height to descend (m) and time (s)."""
        moving = float(np.linalg.norm(self._tgt_vel[:2])) >= STILL_M_S
        end_m = -DOCK_INTO_DECK_M if moving else DOCK_HOVER_M
        h = (self._feet_above_target(est) if self._tgt_pos is not None else self.cfg.trk_alt_m) - end_m
        # [F 3]'s td (h over the mean speed), but never shorter than the cubic's peak acceleration 6 h / td^2
        # allows within MPC_ACC_DOWN_MAX: 0.7 m in 0.7 s starts with 8.5 m/s^2 down, a near free fall whose
        # low collective thrust leaves the motors no room to hold the attitude just above the deck.
        acc_max = self.params.get("MPC_ACC_DOWN_MAX")
        return end_m, h, max(duration_s(h, self.cfg.trk_spd_m_s), math.sqrt(6.0 * abs(h) / acc_max))

    def _start_docking(self, est: VehicleEstimate, now_us: int) -> None:
        self._dock_end_m, h, td = self._dock_plan(est)
        self._spline = CubicSpline(np.array([-h]), np.array([0.0]), td)
        err = float(np.linalg.norm(self._aim(0.0)[:2] - est.pos_ned_m[:2]))
        notes = [f"{err:.2f} m off, moving with it"]
        if self._gate.planned_off_rad is not None:  # (PLD_DOCK_CHK bit 1: timed to touch square)
            notes.append(f"{math.degrees(self._gate.planned_off_rad):+.0f} deg off square at the touch")
        waited = self._gate.waited()  # what held it, if anything
        self._enter(PrecLandPhase.DOCKING, now_us, "; ".join(notes + ([f"held: {waited}"] if waited else [])))

    def _lose(self, est: VehicleEstimate, now_us: int) -> None:
        """The target is gone for longer than PLD_BTOUT (or never came): search or fall back."""
        if self.searches < self.cfg.max_srch:
            self.searches += 1
            down = self.ground_down_m - self.cfg.srch_alt_m
            self._hold = np.array([est.pos_ned_m[0], est.pos_ned_m[1], down])
            # a deck that drove on is searched for where it should be now (target_coast), a still one in place
            moving = self._fix is not None and float(np.linalg.norm(self._fix[2][:2])) >= STILL_M_S
            self._search_fix = self._fix if moving else None
            self._enter(PrecLandPhase.SEARCH, now_us, f"target lost, search {self.searches} of {self.cfg.max_srch}")
            return
        self._enter_fallback(est, now_us)

    def _enter_fallback(self, est: VehicleEstimate, now_us: int) -> None:
        self._hold = est.pos_ned_m.astype(float).copy()
        if self.mode is PrecLandMode.OPPORTUNISTIC:
            self._fallback = LandTask(self.ground_down_m, self.params, yaw_rad=self.yaw_rad)
            self._fallback.activate(est, now_us)
            self._enter(PrecLandPhase.FALLBACK, now_us, "target not found, normal landing")
        else:
            self._failed = True
            self._enter(PrecLandPhase.FALLBACK, now_us, "target not found, holding (precision landing required)")

    def _transitions(self, est: VehicleEstimate, now_us: int, visible: bool) -> None:
        cfg, ph = self.cfg, self.phase
        in_phase_s = (now_us - self._phase_us) * 1e-6
        if ph is PrecLandPhase.PREPARATION or ph is PrecLandPhase.SEARCH:
            if visible:
                self._start_tracking(est, now_us, "target seen")
            elif in_phase_s > cfg.srch_tout_s:
                self._lose(est, now_us)
            return
        if ph in (PrecLandPhase.TRACKING, PrecLandPhase.APPROACHING, PrecLandPhase.DOCKING):
            height_above_target = self._feet_above_target(est) if self._tgt_pos is not None else math.inf
            final = ph is PrecLandPhase.DOCKING and height_above_target < cfg.fappr_alt_m
            if self._lost_s(now_us) > cfg.btout_s and not final:
                self._lose(est, now_us)
                return
        if ph is PrecLandPhase.TRACKING and in_phase_s >= self._spline.td_s:
            self._enter(PrecLandPhase.APPROACHING, now_us, "spline flown")
            self._lead.reset()
            self._close_since_us: int | None = None
        elif ph is PrecLandPhase.APPROACHING:
            err = float(np.linalg.norm(self._aim(0.0)[:2] - est.pos_ned_m[:2]))
            slip = float(np.linalg.norm(est.vel_ned_m_s[:2] - self._tgt_vel[:2]))  # speed over the deck
            # [F 3]: within PLD_APPR_RAD; a deck that turns may keep the error above that for good,
            # so after APPROACH_PATIENCE_S PX4's acceptance radius PLD_HACC_RAD will do.
            patient = in_phase_s >= APPROACH_PATIENCE_S
            close = err < cfg.appr_rad_m and slip < APPROACH_SLIP_M_S
            close_enough = patient and err < cfg.hacc_rad_m and slip < 2 * APPROACH_SLIP_M_S
            rate, ahead_s = yaw_rate_ned(est.rate_frd_rad_s, est.roll_rad, est.pitch_rad), self._dock_plan(est)[2]
            if not (close or close_enough) or not visible:
                self._close_since_us = None
            elif self._close_since_us is None:
                self._close_since_us = now_us
            held = self._gate.hold_reason(now_us, self.heading, est.yaw_rad, rate, ahead_s)  # (PLD_DOCK_CHK)
            if self._close_since_us is not None and (now_us - self._close_since_us) * 1e-6 >= APPROACH_HOLD_S:
                if not held:
                    self._gate.start(now_us, self.heading, est.yaw_rad, rate, ahead_s)
                    self._start_docking(est, now_us)
        elif ph is PrecLandPhase.DOCKING:
            err = float(np.linalg.norm(self._aim(0.0)[:2] - est.pos_ned_m[:2]))
            rate, ahead_s = (
                yaw_rate_ned(est.rate_frd_rad_s, est.roll_rad, est.pitch_rad),
                self._spline.td_s - in_phase_s,
            )
            off = (
                self._gate.abort_reason(
                    now_us, self.heading, est.yaw_rad, rate, max(0.0, ahead_s), self._feet_above_target(est)
                )
                if self._tgt_pos is not None
                else ""
            )
            if (err > cfg.hacc_rad_m and visible) or off:
                why = off or f"horizontal error above {cfg.hacc_rad_m:.2f} m"
                self._enter(PrecLandPhase.APPROACHING, now_us, why)
                self._close_since_us = None
            elif self._tgt_pos is not None:
                settled_s = in_phase_s - self._spline.td_s - DOCK_SETTLE_S
                feet_m = self._feet_above_target(est)
                touching = self.on_deck and feet_m <= DOCK_TOUCH_M  # (the height estimate may be cm off)
                there = feet_m <= DOCK_HOVER_M + DOCK_DONE_M or settled_s >= 0.0 or touching
                # Over a still deck, wait there for the error to shrink (a gust); a moving deck is
                # tracked blind (the camera is too close to see the marker whole): cut at once.
                # Legs on the deck (ground contact: the deck carries weight, or pushed up in an impact) end
                # the docking at once: sliding on the deck in wind the error only grew (0.03 -> 0.29 m).
                still = float(np.linalg.norm(self._tgt_vel[:2])) < STILL_M_S
                waited = err <= 2.0 * cfg.appr_rad_m or settled_s >= DOCK_WAIT_S or touching
                level_s = float(self.params.get("PLD_TD_LEVEL"))
                if not still and level_s > 0.0:  # a moving deck: on to the contact, level on the legs, then cut
                    if touching or settled_s >= 0.0:
                        self._touchdown = Touchdown(level_s, now_us)
                        how = "legs on the deck" if touching else "docking spline flown"
                        self._enter(PrecLandPhase.TOUCHDOWN, now_us, f"{how} {err:.2f} m off, levelling")
                elif there and (not still or waited):
                    self._cut(now_us, f"{'legs on the deck' if touching else 'docking point reached'} {err:.2f} m off")
        elif ph is PrecLandPhase.TOUCHDOWN and self._touchdown is not None:
            why = self._touchdown.finished(est, now_us, self.on_deck)
            if why:
                self._cut(now_us, why)

    def _cut(self, now_us: int, why: str) -> None:
        self.motors_cut = True
        self._enter(PrecLandPhase.DONE, now_us, f"{why}, motors off")

    def _setpoint(self, est: VehicleEstimate, now_us: int, acc: np.ndarray) -> PositionSetpoint | AttitudeSetpoint:
        """The setpoint of the phase now; ``acc``: the target's acceleration fed forward (m/s^2 NED)."""
        ph, zero = self.phase, np.zeros(3)
        assert self.yaw_rad is not None  # (activate fixed it)
        in_phase_s = (now_us - self._phase_us) * 1e-6
        if ph is PrecLandPhase.TOUCHDOWN and self._touchdown is not None:  # level on the legs, turning with the deck
            return self._touchdown.setpoint(est.yaw_rad, self._turn.rate(), self.hover_thrust_frac)
        if ph is PrecLandPhase.FALLBACK and self._fallback is not None:
            return self._fallback.update(est, now_us)
        if ph is PrecLandPhase.SEARCH and self._search_fix is not None:
            t_us, pos, vel, turn = self._search_fix
            pos, vel, _ = coast(pos, vel, zero, (now_us - t_us) * 1e-6, turn)
            return PositionSetpoint(
                np.array([pos[0], pos[1], self._hold[2]]), np.array([vel[0], vel[1], 0.0]), self.yaw_rad
            )
        if ph in (PrecLandPhase.PREPARATION, PrecLandPhase.SEARCH, PrecLandPhase.FALLBACK):
            return PositionSetpoint(self._hold.copy(), zero, self.yaw_rad)
        base, vel = self._above_target(self.cfg.trk_alt_m), self._tgt_vel.copy()
        self._view = self._view.with_device(self.gimbal_reach_rad)  # (PLD_CAM_REACH -1: follows the device)
        band, cone = CHASE_INT_BAND_M_S, view_cone(self._above_target(0.0) - est.pos_ned_m, self._view)
        yaw, rate = self.heading.setpoint(now_us, est.yaw_rad)  # square to the deck (PLD_DECK_YAW), turning with it
        if ph is PrecLandPhase.DOCKING:
            yaw, rate = self._gate.yaw_setpoint(now_us) or (yaw, rate)  # timed to touch square (PLD_DOCK_CHK)
        chase = (band, cone, rate, self._view.slew_m_s3)  # the chase's limits and yaw rate, from tracking on
        if ph is PrecLandPhase.TRACKING:
            p = self._spline.at(in_phase_s)
            return PositionSetpoint(base + p.pos, vel + p.vel, yaw, p.acc + acc, *chase)
        if ph is PrecLandPhase.APPROACHING:
            return PositionSetpoint(self._aim(self.cfg.trk_alt_m), vel, yaw, acc, *chase)
        # the reference point at the docking point (DONE), or where the docking spline ends (in a moving deck)
        deck = self._aim(self.feet_below_m + (self._dock_end_m if ph is PrecLandPhase.DOCKING else DOCK_HOVER_M))
        if ph is PrecLandPhase.DOCKING:
            p = self._spline.at(in_phase_s)
            pos = np.array([deck[0], deck[1], deck[2] + float(p.pos[0])])
            down = np.array([0.0, 0.0, 1.0])  # the spline's descent: its velocity and acceleration fed forward
            v_sp, a_sp = vel + float(p.vel[0]) * down, acc + float(p.acc[0]) * down
            return PositionSetpoint(pos, v_sp, yaw, a_sp, *chase)
        return PositionSetpoint(deck, vel, yaw, None, band)  # DONE: the deck (motors are off)
