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
"""

from __future__ import annotations

import math
from typing import TYPE_CHECKING, Callable

import numpy as np
from pymavlink.dialects.v20 import common as S

from autopilot.commander.thrust_loss import ThrustLossCheck
from autopilot.parameters import ParamDef, ParameterStore, ParamType, param
from autopilot.topics import NO_ACTUATORS, ActuatorStatus
from mavsim_core.px4_modes import Mode

if TYPE_CHECKING:
    from autopilot.commander.commander import Commander

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


class FailureDetector:
    """The attitude checks (FD_FAIL_*), the thrust-loss check and the crash check's timer; :func:`check_failures`
    acts on them."""

    def __init__(self, params: ParameterStore) -> None:
        self.params = params
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

    def update(self, now_us: int, roll_rad: float, pitch_rad: float) -> bool:
        """One attitude (rad, FRD->NED Euler 3-2-1) while the checks apply; whether it is a failure now."""
        g = self.params.get
        self.roll_failed, self._roll_since_us = _beyond(now_us, roll_rad, g("FD_FAIL_R"), self._roll_since_us, g, "R")
        self.pitch_failed, self._pitch_since_us = _beyond(
            now_us, pitch_rad, g("FD_FAIL_P"), self._pitch_since_us, g, "P"
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


def _beyond(
    now_us: int, angle_rad: float, limit_deg: float, since_us: int | None, get: Callable[[str], float], axis: str
):
    """(failed, since): ``angle_rad`` beyond ``limit_deg`` (> 0) for FD_FAIL_<axis>_TTRI seconds (read with
    ``get`` only then); clears at once, as PX4's hysteresis from false to true only."""
    if not (limit_deg > 0 and abs(angle_rad) > math.radians(limit_deg)):
        return False, None
    since_us = now_us if since_us is None else since_us
    return now_us - since_us >= get(f"FD_FAIL_{axis}_TTRI") * 1e6, since_us


def check_failures(c: Commander, now_us: int, actuators: ActuatorStatus = NO_ACTUATORS) -> None:
    """The commander's update: detect, react once per arming, then the crash check.  ``actuators``: the
    flight controller's latest outputs (the thrust-loss check reads them)."""
    fd, est = c.failure_detector, c.est
    if not c.armed or est is None:
        fd.reset()
        c.failsafe.critical_failure = False
        return
    controlled = c.mode is not Mode.ACRO and est.attitude_valid  # PX4: only while the attitude is controlled
    if not controlled:
        fd.clear()
    elif fd.update(now_us, est.roll_rad, est.pitch_rad) and not fd.lost_control:
        fd.lost_control = True
        _react(c, now_us)
    tilt = math.acos(max(-1.0, min(1.0, math.cos(est.roll_rad) * math.cos(est.pitch_rad))))
    checking = controlled and c.in_air
    thrust = fd.thrust
    vel_down = float(est.vel_ned_m_s[2])
    outputs, throttle = actuators.motor_outputs, actuators.throttle_frac
    above_m = c.land_detector.ground_down_m - float(est.pos_ned_m[2])  # above where it was armed
    if thrust.update(now_us, checking, tilt, vel_down, outputs, throttle, c.vel_sp_down_m_s, above_m):
        which = f", likely motor {thrust.motor}" if thrust.motor else ""
        where = "on the ground at full throttle" if thrust.stuck else "descending at full throttle"
        c.say(S.MAV_SEVERITY_CRITICAL, f"Critical failure detected (thrust loss{which}): {where}")
    c.failsafe.critical_failure = c.armed and (fd.roll_failed or fd.pitch_failed or thrust.lost)
    if not c.armed or int(c.params.get("FS_CRASH_CHECK")) != 1:
        return
    grounded = False  # (only after a thrust loss: before one, its timer is never running)
    if thrust.lost:
        get = c.params.get
        grounded = thrust.grounded(
            now_us, above_m, est.vel_ned_m_s, est.accel_ned_m_s2, get("LNDMC_Z_VEL_MAX"), get("LNDMC_XY_VEL_MAX")
        )
    # (the crash check's tilt timer runs only after a loss of control: before one it is never running)
    if (fd.lost_control and fd.crashed(now_us, tilt, est.accel_ned_m_s2)) or grounded:
        c.say(S.MAV_SEVERITY_CRITICAL, "Crash detected: disarming")
        c._disarm("crash detected")
        c.failsafe.terminated = True  # the motors were stopped by a failsafe: EMERGENCY until the next arming
        fd.reset()


def _react(c: Commander, now_us: int) -> None:
    """PX4's reaction to a critical failure (see the module docstring), said in one STATUSTEXT."""
    p = c.params
    what = f"Critical failure detected ({c.failure_detector.axis})"
    lockdown_s = p.get("COM_LKDOWN_TKO")
    if lockdown_s > 0 and now_us - c.armed_at_us < lockdown_s * 1e6:
        c.say(S.MAV_SEVERITY_CRITICAL, f"{what}: lockdown")
        _stop_motors(c, "lockdown")
    elif int(p.get("CBRK_FLIGHTTERM")) != CBRK_FLIGHTTERM_KEY:
        c.say(S.MAV_SEVERITY_CRITICAL, f"{what}: terminating")
        _stop_motors(c, "flight termination")
    else:
        c.say(S.MAV_SEVERITY_CRITICAL, f"{what}: termination disabled (CBRK_FLIGHTTERM)")


def _stop_motors(c: Commander, why: str) -> None:
    c._disarm(why)
    c.failsafe.terminated, c.failsafe.in_force = True, None
