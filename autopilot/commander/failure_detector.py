"""Failure detector: a loss of attitude control (PX4's FailureDetector) or of thrust, its reaction, the crash check.

Detection, as PX4's ``FailureDetector::updateAttitudeStatus``: while armed in a mode that controls
the attitude (every mode but ACRO), the estimated roll beyond ``FD_FAIL_R`` degrees for
``FD_FAIL_R_TTRI`` seconds, or the pitch beyond ``FD_FAIL_P`` for ``FD_FAIL_P_TTRI``, is a critical
failure (0 degrees disables an axis; Euler angles 3-2-1, so a vehicle on its back reads roll ~180).
A vehicle whose attitude controller fails, or that loses a motor or propeller with soft rate loops,
flips within a few tenths of a second; no controlled flight comes near 60 degrees (MPC_TILTMAX_AIR
limits the position modes).  With stiff rate loops a vehicle that lost a motor need not flip: the
mixer keeps it level by giving up thrust and it comes down upright.  That is found by the thrust-loss
check (:mod:`.thrust_loss`, ArduPilot's: descending, level, at full throttle with a motor at its limit
for 1 s), reported once per arming by a CRITICAL STATUSTEXT "Critical failure detected (thrust loss,
likely motor N): descending at full throttle" (the motor named from the mixer's outputs) with
HEARTBEAT EMERGENCY until the vehicle is disarmed; it changes nothing else (a hexacopter may still
hold its height and land, and neither PX4 nor ArduPilot terminates on it).

Reaction, as PX4's commander (``failsafe.cpp``, critical failure), reported once per arming by a
CRITICAL STATUSTEXT "Critical failure detected (roll): <action>":

* within ``COM_LKDOWN_TKO`` seconds of arming (a vehicle tipping over at take-off): lockdown, the
  motors stop (a forced disarm here);
* later, with flight termination enabled (``CBRK_FLIGHTTERM`` not 121212): terminate, the motors stop
  (a forced disarm; HEARTBEAT EMERGENCY until the next arming);
* later, with ``CBRK_FLIGHTTERM`` 121212 (PX4's default: the circuit breaker disables termination):
  warn only; HEARTBEAT EMERGENCY ("lost control ... in mayday and going down") while the attitude is
  beyond the limits.

Crash check, as ArduPilot's (``FS_CRASH_CHECK`` 1, Copter's ``crash_check``: attitude off by more than
30 degrees with an acceleration below 3 m/s^2 for 2 s -> "Crash: Disarming"): after a loss of control
in this arming, a vehicle tilted more than ``CRASH_TILT_DEG`` whose acceleration (NED, gravity
removed) stays below ``CRASH_ACCEL_M_S2`` for ``CRASH_TIME_S`` lies on the ground; after a thrust
loss in this arming, one still within a metre of the height it was armed at for 2 s sits on the
ground upright (:meth:`.thrust_loss.ThrustLossCheck.grounded`: the land detector never lands it, as
the position controller keeps asking for full thrust).  Either way: "Crash detected: disarming"
(CRITICAL), and it is disarmed, so motors do not run on a wreck (HEARTBEAT EMERGENCY until the next
arming).  Requiring the loss of control or of thrust first keeps a hover in a strong wind (a steady
tilt, at rest) from ever being taken for a crash.  Angles are radians inside, degrees in the
parameters; times are simulated µs.

:class:`FailureDetector` is fed a frozen :class:`FailureInputs` each update (its only input; its timers are its
own) and returns a frozen :class:`FailureDecision`: the STATUSTEXTs to say and the motors to stop, in order; the
commander applies it (``Commander._check_failures``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from pymavlink.dialects.v20 import common as S

from autopilot.commander.thrust_loss import ThrustLossCheck
from autopilot.parameters import ParamDef, ParameterStore, ParamType, param
from autopilot.topics import ActuatorStatus, VehicleEstimate
from mavsim_core import quaternion as quat
from mavsim_core.px4_modes import Mode

CBRK_FLIGHTTERM_KEY = 121212  # CBRK_FLIGHTTERM at this value: the circuit breaker is in, no termination
CRASH_TILT_DEG = 30.0  # ArduPilot's CRASH_CHECK_ANGLE_DEVIATION_DEG
CRASH_ACCEL_M_S2 = 3.0  # ArduPilot's CRASH_CHECK_ACCEL_MAX
CRASH_TIME_S = 2.0  # ArduPilot's CRASH_CHECK_TRIGGER_SEC

# The parameters this module reads (listed in autopilot/param_catalogue.py).
PARAMS: tuple[ParamDef, ...] = (
    param("FD_FAIL_R", 60, 0, 180, "deg", "Failure detector: maximum roll (0: roll not checked)", ParamType.INT32),
    param("FD_FAIL_P", 60, 0, 180, "deg", "Failure detector: maximum pitch (0: pitch not checked)", ParamType.INT32),
    param("FD_FAIL_R_TTRI", 0.3, 0.02, 5.0, "s", "Failure detector: time beyond FD_FAIL_R before a failure"),
    param("FD_FAIL_P_TTRI", 0.3, 0.02, 5.0, "s", "Failure detector: time beyond FD_FAIL_P before a failure"),
    param(
        "CBRK_FLIGHTTERM", CBRK_FLIGHTTERM_KEY, 0, CBRK_FLIGHTTERM_KEY, "",
        "Circuit breaker for flight termination: 121212 disables terminating on a failure detector trigger "
        "(warn only); any other value stops the motors", ParamType.INT32,
    ),
    param(
        "COM_LKDOWN_TKO", 3.0, -1.0, 5.0, "s",
        "Failure detector trigger this soon after arming: lockdown (motors stop) whatever CBRK_FLIGHTTERM "
        "(0 or less: never)",
    ),
    param(
        "FS_CRASH_CHECK", 1, 0, 1, "",
        "Crash check after a loss of control or of thrust: 0 disabled, 1 disarm a vehicle lying tilted and still "
        "(or, after a thrust loss, still on the ground)", ParamType.INT32,
    ),
)  # fmt: skip


@dataclass(frozen=True)
class FailureParams:
    """The parameters the failure detector reads (:data:`PARAMS`, and the land detector's LNDMC_*_VEL_MAX)."""

    fail_r_deg: float
    fail_p_deg: float
    fail_r_ttri_s: float
    fail_p_ttri_s: float
    flightterm_breaker: int  # CBRK_FLIGHTTERM
    lockdown_s: float  # COM_LKDOWN_TKO
    crash_check: int  # FS_CRASH_CHECK
    z_vel_max_m_s: float  # LNDMC_Z_VEL_MAX
    xy_vel_max_m_s: float  # LNDMC_XY_VEL_MAX

    @classmethod
    def from_store(cls, params: ParameterStore) -> FailureParams:
        g = params.get
        return cls(
            g("FD_FAIL_R"), g("FD_FAIL_P"), g("FD_FAIL_R_TTRI"), g("FD_FAIL_P_TTRI"), int(g("CBRK_FLIGHTTERM")),
            g("COM_LKDOWN_TKO"), int(g("FS_CRASH_CHECK")), g("LNDMC_Z_VEL_MAX"), g("LNDMC_XY_VEL_MAX"),
        )  # fmt: skip


@dataclass(frozen=True)
class FailureInputs:
    """What the failure detector judges in one update."""

    now_us: int
    armed: bool
    armed_at_us: int
    in_air: bool
    mode: Mode
    est: VehicleEstimate | None
    actuators: ActuatorStatus  # the flight controller's latest outputs (the thrust-loss check reads them)
    vel_sp_down_m_s: float  # the position controller's vertical velocity (NaN: none)
    ground_down_m: float  # the height it was armed at (m NED down, the land detector's)
    params: FailureParams


@dataclass(frozen=True)
class StopMotors:
    """Stop the motors (a forced disarm, ``why`` in its STATUSTEXT): HEARTBEAT EMERGENCY until the next arming."""

    why: str


Step = tuple[int, str] | StopMotors  # a STATUSTEXT (severity, text) to say, or the motors to stop


@dataclass(frozen=True)
class FailureDecision:
    """What to do now, in order (``steps``), and whether a critical failure holds after them."""

    steps: tuple[Step, ...] = ()
    critical_failure: bool = False


class FailureDetector:
    """The attitude checks (FD_FAIL_*), the thrust-loss check and the crash check's timer, fed one
    :class:`FailureInputs` per update (:meth:`step`)."""

    def __init__(self) -> None:
        self.roll_failed = False
        self.pitch_failed = False
        self.lost_control = False  # a failure was found in this arming (cleared at disarm)
        self._roll_since_us: int | None = None  # beyond FD_FAIL_R since
        self._pitch_since_us: int | None = None
        self._still_since_us: int | None = None  # tilted and still since (the crash check)
        self.thrust = ThrustLossCheck()  # descending at full throttle (a motor lost without a flip)

    def reset(self) -> None:
        """Disarmed: everything cleared."""
        self.clear()
        self.lost_control = False
        self._still_since_us = None
        self.thrust.reset()

    def clear(self) -> None:
        """The attitude checks cleared (ACRO, or no attitude estimate)."""
        self.roll_failed = self.pitch_failed = False
        self._roll_since_us = self._pitch_since_us = None

    def update(self, now_us: int, roll_rad: float, pitch_rad: float, p: FailureParams) -> bool:
        """One attitude (rad, FRD->NED Euler 3-2-1) while the checks apply; whether it is a failure now."""
        self.roll_failed, self._roll_since_us = _beyond(
            now_us, roll_rad, p.fail_r_deg, p.fail_r_ttri_s, self._roll_since_us
        )
        self.pitch_failed, self._pitch_since_us = _beyond(
            now_us, pitch_rad, p.fail_p_deg, p.fail_p_ttri_s, self._pitch_since_us
        )
        return self.roll_failed or self.pitch_failed

    def crashed(self, now_us: int, tilt_rad: float, accel_ned_m_s2: np.ndarray) -> bool:
        """After a loss of control: tilted and still (see the module docstring) for CRASH_TIME_S."""
        still = tilt_rad > math.radians(CRASH_TILT_DEG) and float(np.linalg.norm(accel_ned_m_s2)) < CRASH_ACCEL_M_S2
        if not (self.lost_control and still):
            self._still_since_us = None
            return False
        if self._still_since_us is None:
            self._still_since_us = now_us
        return now_us - self._still_since_us >= CRASH_TIME_S * 1e6

    @property
    def axis(self) -> str:
        return "roll" if self.roll_failed else "pitch"

    def step(self, s: FailureInputs) -> FailureDecision:
        """Detect, react once per arming, then the crash check (the module docstring)."""
        est, p = s.est, s.params
        if not s.armed or est is None:
            self.reset()
            return FailureDecision()
        steps: list[Step] = []
        armed: bool = s.armed
        controlled = s.mode is not Mode.ACRO and est.attitude_valid  # PX4: only while the attitude is controlled
        if not controlled:
            self.clear()
        elif self.update(s.now_us, est.roll_rad, est.pitch_rad, p) and not self.lost_control:
            self.lost_control = True
            steps += _reaction(self.axis, s.now_us - s.armed_at_us, p)
            armed = not isinstance(steps[-1], StopMotors)
        tilt = quat.tilt_rad(est.roll_rad, est.pitch_rad)
        thrust = self.thrust
        above_m = s.ground_down_m - float(est.pos_ned_m[2])  # above where it was armed
        outputs, throttle = s.actuators.motor_outputs, s.actuators.throttle_frac
        vel_down = float(est.vel_ned_m_s[2])
        if thrust.update(
            s.now_us, controlled and s.in_air, tilt, vel_down, outputs, throttle, s.vel_sp_down_m_s, above_m
        ):
            which = f", likely motor {thrust.motor}" if thrust.motor else ""
            where = "on the ground at full throttle" if thrust.stuck else "descending at full throttle"
            steps.append((S.MAV_SEVERITY_CRITICAL, f"Critical failure detected (thrust loss{which}): {where}"))
        critical = armed and (self.roll_failed or self.pitch_failed or thrust.lost)
        if not armed or p.crash_check != 1:
            return FailureDecision(tuple(steps), critical)
        grounded = False  # (only after a thrust loss: before one, its timer is never running)
        if thrust.lost:
            grounded = thrust.grounded(
                s.now_us, above_m, est.vel_ned_m_s, est.accel_ned_m_s2, p.z_vel_max_m_s, p.xy_vel_max_m_s
            )
        # (the crash check's tilt timer runs only after a loss of control: before one it is never running)
        if (self.lost_control and self.crashed(s.now_us, tilt, est.accel_ned_m_s2)) or grounded:
            steps += [(S.MAV_SEVERITY_CRITICAL, "Crash detected: disarming"), StopMotors("crash detected")]
            self.reset()
        return FailureDecision(tuple(steps), critical)


def _beyond(now_us: int, angle_rad: float, limit_deg: float, time_s: float, since_us: int | None):
    """(failed, since): ``angle_rad`` beyond ``limit_deg`` (> 0) for ``time_s`` (FD_FAIL_<axis>_TTRI); clears
    at once, as PX4's hysteresis from false to true only."""
    if not (limit_deg > 0 and abs(angle_rad) > math.radians(limit_deg)):
        return False, None
    since_us = now_us if since_us is None else since_us
    return now_us - since_us >= time_s * 1e6, since_us


def _reaction(axis: str, since_arming_us: int, p: FailureParams) -> list[Step]:
    """PX4's reaction to a critical failure (see the module docstring), said in one STATUSTEXT."""
    what = f"Critical failure detected ({axis})"
    if p.lockdown_s > 0 and since_arming_us < p.lockdown_s * 1e6:
        return [(S.MAV_SEVERITY_CRITICAL, f"{what}: lockdown"), StopMotors("lockdown")]
    if p.flightterm_breaker != CBRK_FLIGHTTERM_KEY:
        return [(S.MAV_SEVERITY_CRITICAL, f"{what}: terminating"), StopMotors("flight termination")]
    return [(S.MAV_SEVERITY_CRITICAL, f"{what}: termination disabled (CBRK_FLIGHTTERM)")]
