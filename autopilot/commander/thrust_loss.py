"""Thrust loss: a vehicle that sinks although its motors give all they have (a motor or propeller lost).

A vehicle that loses a motor does not always flip: with stiff rate loops the mixer keeps it level by
giving up collective thrust (a quadrotor's opposite motor goes to idle), and it comes down upright.
The attitude checks of :mod:`.failure_detector` (FD_FAIL_R/FD_FAIL_P) never see that, so this check
looks where ArduPilot's Copter does (``thrust_loss_check``, "Potential Thrust Loss (N)"): while armed
and in the air, in a mode that controls the attitude, for ``TRIGGER_S`` (1 s) without a break:

* the attitude is under control: tilt below ``MAX_TILT_DEG``, 45 deg (ArduPilot: attitude error under 30 deg;
  here the tilt, bounded by PX4's default MPC_TILTMAX_AIR, for a quadrotor falling with a motor lost leans
  past 30 deg within its first second with some sensor noise: simulator seed 111 reached 38 deg at 5 m/s down,
  and the check's timer, started again at 30 deg, never ran out before the impact; beyond 45 deg, up to the
  60 deg of FD_FAIL_R/FD_FAIL_P, the vehicle is flipping, not flying);
* the motors are at their limit: one output at ``SATURATED`` or more (ArduPilot: throttle at 90 % or
  the mixer's upper throttle limit reached) and the throttle at ``MIN_THROTTLE`` or more (25 %: not a
  limit that a low commanded throttle causes);
* descending faster than ``LEVEL_SINK_M_S`` (ArduPilot: at all, but with the collective at 90 %; here one
  motor at its limit is the sign, and a yaw or a turn puts one there for a moment too); while leaning
  more than ``LEVEL_DEG`` (ArduPilot checks only below a 15 deg desired lean) faster than
  ``MANOEUVRE_SINK_M_S``.  Braking from a follow or a mission leg at MPC_ACC_HOR (4 m/s^2) leans 22 deg
  with a motor at its limit and may sink a little for a second: the first version (any descent, up to
  30 deg) took a manoeuvre for a lost motor once, and its failsafe brought a healthy vehicle down in the
  follow-me end-to-end test.  A motor lost in a hover leans up to ~26 deg while it sinks ever faster,
  so ArduPilot's 15 deg limit alone reported it only after the impact;
* sinking faster than the position controller asks, by ``LEVEL_SINK_M_S`` (its vertical velocity
  setpoint; none, as in the attitude modes: holding the height).  ArduPilot's check waits for the
  collective at 90 %, so a descent the pilot asked for never meets it; here one motor at its limit is
  the sign, and a commanded descent while yawing meets that: a MAVSDK go-to sent at the end of a
  take-off, 90 deg of yaw on the way down at 1.1 m/s, was reported as a thrust loss and landed.  A lost
  motor sinks against the setpoint, which then asks for a climb.

A fall from a low hover can still end before that second has passed without a break (one output dipping
under its limit, the lean passing 45 deg for a moment): the vehicle then sits upright on the ground with a
motor at its limit, the position controller asking for a climb and the land detector never landing it
(it waits for low thrust), its motors at full throttle on a wreck.  So the check also counts a vehicle
*stuck*: level, within ``GROUND_BAND_M`` of the height it was armed at, still (vertical speed under
``LEVEL_SINK_M_S``), a motor at its limit and the throttle at ``MIN_THROTTLE`` or more, while asked to
climb faster than ``LEVEL_SINK_M_S``, for ``TRIGGER_S``: reported as a thrust loss "on the ground at full
throttle" (:attr:`ThrustLossCheck.stuck`), and disarmed by the crash check's ground test ``GROUND_S``
after it began.  A take-off climbs and a landing asks to descend, so neither meets it.

The likely motor is the one with the highest output low-passed over ``OUTPUT_TAU_S`` (0.5 s), as
ArduPilot's ``AP_MotorsMatrix::check_for_failed_motor``: the controllers ask the motor that gives
nothing for more and more, up to its limit.  Motors are numbered from 1 in the mixer's order (the
simulator's SIM_ENGINE_FAIL numbers).

On the ground after a thrust loss the position controller keeps asking for full thrust, so the land
detector, which waits for low thrust, never lands it: :meth:`ThrustLossCheck.grounded` is the ground
test of the crash check instead (:meth:`autopilot.commander.failure_detector.FailureDetector.step`): within
``GROUND_BAND_M`` of the height it was armed at, moving slower than the land detector's limits
(LNDMC_Z_VEL_MAX, LNDMC_XY_VEL_MAX) and accelerating less than the crash check's 3 m/s^2, for
``GROUND_S``.  A vehicle that lost thrust and settled elsewhere (a roof) is not disarmed by this: a
still vehicle in the air at full thrust cannot be told from one on a roof without a range sensor.
Times are simulated µs; NED metres and m/s; angles radians unless named ``_deg``.
"""

from __future__ import annotations

import math

import numpy as np

TRIGGER_S = 1.0  # ArduPilot's THRUST_LOSS_CHECK_TRIGGER_SEC
MAX_TILT_DEG = 45.0  # attitude still controlled: PX4's MPC_TILTMAX_AIR default (the module docstring)
LEVEL_DEG = 15.0  # ArduPilot's lean limit of its thrust-loss check: leaning more is a manoeuvre ...
MANOEUVRE_SINK_M_S = 0.5  # ... and counts only when sinking faster than this
LEVEL_SINK_M_S = 0.2  # level: sinking faster than this (a height controller's small dip is not a loss)
SATURATED = 0.95  # a motor output (0..1) at its limit
MIN_THROTTLE = 0.25  # ArduPilot's minimum throttle for the check (fraction of the maximum collective thrust)
OUTPUT_TAU_S = 0.5  # low-pass of the outputs that names the likely motor (ArduPilot's)
GROUND_BAND_M = 1.0  # within this of the height at arming: on the ground
GROUND_ACCEL_M_S2 = 3.0  # still: accelerating less than this (the crash check's CRASH_CHECK_ACCEL_MAX)
GROUND_S = 2.0  # still on the ground this long after a thrust loss: disarmed (the crash check's time)


class ThrustLossCheck:
    """The thrust-loss timer, the likely motor, and the on-the-ground test after a loss (module docstring)."""

    def __init__(self) -> None:
        self._clear()

    def _clear(self) -> None:
        self.lost = False  # a thrust loss was found in this arming (cleared by :meth:`reset`)
        self.stuck = False  # ... found on the ground, stuck at full throttle (the module docstring)
        self.motor = 0  # the likely motor (1-based; 0 before any output was seen)
        self._since_us: int | None = None  # the conditions have held since
        self._still_since_us: int | None = None  # on the ground and still since (after a loss)
        self._filtered: list[float] | None = None  # low-passed motor outputs
        self._last_us: int | None = None

    def reset(self) -> None:
        """Disarmed: everything cleared."""
        self._clear()

    def update(
        self,
        now_us: int,
        checking: bool,
        tilt_rad: float,
        vel_down_m_s: float,
        outputs: tuple[float, ...],
        throttle: float,
        vel_sp_down_m_s: float = math.nan,
        height_above_arming_m: float = math.inf,
    ) -> bool:
        """One step; ``checking``: armed, in the air and the attitude controlled; ``vel_sp_down_m_s``: the
        position controller's vertical velocity setpoint (NaN: none); ``height_above_arming_m``: the estimate's
        height above where it was armed (the stuck case).  True once, at the loss."""
        self._filter(now_us, outputs)
        asked_down = vel_sp_down_m_s if math.isfinite(vel_sp_down_m_s) else 0.0
        at_limit = (
            checking
            and tilt_rad < math.radians(MAX_TILT_DEG)
            and bool(outputs)
            and max(outputs) >= SATURATED
            and throttle >= MIN_THROTTLE
        )
        sinking = stuck = False
        if at_limit:  # (most steps: not at the limit, nothing more to look at)
            sinking = (
                vel_down_m_s > (LEVEL_SINK_M_S if tilt_rad < math.radians(LEVEL_DEG) else MANOEUVRE_SINK_M_S)
                and vel_down_m_s - asked_down > LEVEL_SINK_M_S
            )
            stuck = (
                tilt_rad < math.radians(LEVEL_DEG)
                and height_above_arming_m < GROUND_BAND_M
                and abs(vel_down_m_s) < LEVEL_SINK_M_S
                and asked_down < -LEVEL_SINK_M_S
            )
        if not (sinking or stuck):
            self._since_us = None
            return False
        if self._since_us is None:
            self._since_us = now_us
        if self.lost or now_us - self._since_us < TRIGGER_S * 1e6:
            return False
        self.lost = True
        if stuck:  # still on the ground since the conditions began: the crash check's timer with them
            self.stuck, self._still_since_us = True, self._since_us
        if self._filtered is not None:
            self.motor = int(np.argmax(self._filtered)) + 1
        return True

    def grounded(
        self,
        now_us: int,
        height_above_arming_m: float,
        vel_ned_m_s: np.ndarray,
        accel_ned_m_s2: np.ndarray,
        z_vel_max_m_s: float,
        xy_vel_max_m_s: float,
    ) -> bool:
        """After a loss: on the ground near where it was armed, and still, for GROUND_S (module docstring)."""
        still = (
            self.lost
            and height_above_arming_m < GROUND_BAND_M
            and abs(float(vel_ned_m_s[2])) < z_vel_max_m_s
            and math.hypot(float(vel_ned_m_s[0]), float(vel_ned_m_s[1])) < xy_vel_max_m_s
            and float(np.linalg.norm(accel_ned_m_s2)) < GROUND_ACCEL_M_S2
        )
        if not still:
            self._still_since_us = None
            return False
        if self._still_since_us is None:
            self._still_since_us = now_us
        return now_us - self._still_since_us >= GROUND_S * 1e6

    def _filter(self, now_us: int, outputs: tuple[float, ...]) -> None:
        """Low-pass the outputs (plain floats: numpy's per-call cost on a few values would be most of it)."""
        if not outputs:
            return
        f = self._filtered
        if f is None or len(f) != len(outputs) or self._last_us is None:
            self._filtered = [float(v) for v in outputs]
        else:
            dt = max(0.0, (now_us - self._last_us) * 1e-6)
            k = dt / (dt + OUTPUT_TAU_S)
            self._filtered = [x + k * (float(v) - x) for x, v in zip(f, outputs)]
        self._last_us = now_us
