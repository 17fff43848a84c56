"""Failsafes: what the commander does by itself when something it relies on fails (PX4's failsafe actions).

:func:`check` runs in every commander update (armed or not) and watches, each with PX4's parameters:

- the ground station's data link: its HEARTBEATs silent for ``COM_DL_LOSS_T`` s -> ``NAV_DLL_ACT``
  (PX4 default 0: report only); only once a ground station's HEARTBEAT was seen;
- the pilot's sticks (MANUAL_CONTROL; PX4's RC): silent for ``COM_RC_LOSS_T`` s -> ``NAV_RCL_ACT``
  (default Return), except in the modes of the ``COM_RCL_EXCEPT`` bitmask (1 Mission, 2 Hold,
  4 Offboard); only once sticks were seen;
- the battery, graded by BAT_LOW_THR / BAT_CRIT_THR / BAT_EMERGEN_THR (:mod:`.health`): low always
  warns; critical and emergency act by ``COM_LOW_BAT_ACT`` (0 warn, 2 land, 3 return at critical and
  land at emergency);
- the estimate: a position lost in a mode that needs one -> ALTCTL when the pilot has sticks and
  ``COM_POSCTL_NAVL`` is 0, else land (on the height estimate); an attitude lost -> descend
  (:class:`~autopilot.navigation.descend.DescendTask`: level, thrust just below hover);
- OFFBOARD: :func:`autopilot.navigation.offboard.offboard_lost` -> the mode of
  :func:`~autopilot.navigation.offboard.loss_fallback_mode`.

``NAV_*_ACT`` values, as PX4's: 0 disabled, 1 Hold, 2 Return, 3 Land, 5 Terminate, 6 Lockdown (both
stop the motors here: a forced disarm).  An action switches modes through ``Commander._enter``; a
refused mode falls back (Return or Hold -> Land -> Descend), and an action never "downgrades" a
more cautious mode already flown (Land is not turned into Return).  Each event is reported once by a
STATUSTEXT naming the action (and again when the input is regained); it does not trigger again while
it lasts, so the pilot may take over by switching modes, as in PX4.  Actions are taken only while
armed and flying; on the ground the event is only reported.  Input ages use both clocks
(:func:`autopilot.topics.input_age_s`; ``commander.wall_s`` None: simulated time only).
:func:`status` gives the published :class:`~autopilot.topics.FailsafeStatus` (MAV_STATE_CRITICAL
while an action is in force, MAV_STATE_EMERGENCY at battery emergency or after a termination).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Callable

from pymavlink.dialects.v20 import common as S

from autopilot.commander import health, mode_entry
from autopilot.navigation import offboard, started
from autopilot.navigation.descend import DescendTask
from autopilot.parameters import ParamDef, ParamType, param
from autopilot.topics import BatteryWarning, FailsafeStatus
from mavsim_core.px4_modes import Mode

if TYPE_CHECKING:
    from autopilot.commander.commander import Commander

_INT = ParamType.INT32
_NAV_ACT = "0 disabled, 1 Hold, 2 Return, 3 Land, 5 Terminate, 6 Lockdown (motors off)"
# The parameters this module reads (listed in autopilot/param_catalogue.py).
PARAMS: tuple[ParamDef, ...] = (
    param("COM_RC_LOSS_T", 0.5, 0.0, 35.0, "s", "Manual control (RC) loss time-out"),
    param("NAV_RCL_ACT", 2, 0, 6, "", f"Manual control (RC) loss action: {_NAV_ACT}", _INT),
    param(
        "COM_RCL_EXCEPT", 0, 0, 7, "",
        "Modes where manual control loss is ignored (bitmask: 1 Mission, 2 Hold, 4 Offboard)", _INT,
    ),
    param("COM_DL_LOSS_T", 10, 5, 300, "s", "Ground-station data link loss time-out (no HEARTBEAT)", _INT),
    param("NAV_DLL_ACT", 0, 0, 6, "", f"Data link loss action: {_NAV_ACT}", _INT),
    param(
        "COM_LOW_BAT_ACT", 0, 0, 3, "",
        "Battery failsafe: 0 warning, 2 land, 3 return at critical level and land at emergency level", _INT,
    ),
    param(
        "COM_POSCTL_NAVL", 0, 0, 1, "",
        "Position lost: 0 altitude mode if the pilot has sticks (else land), 1 land", _INT,
    ),
)  # fmt: skip

DESCEND, TERMINATE = "descend", "terminate"  # the actions that are not a mode
Target = Mode | str | None  # what an action does: a mode, DESCEND, TERMINATE, or None (report only)
NAV_ACTIONS: dict[int, Target] = {1: Mode.AUTO_LOITER, 2: Mode.AUTO_RTL, 3: Mode.AUTO_LAND, 5: TERMINATE, 6: TERMINATE}
# How cautious a mode is: an action never replaces a mode of the same or a higher rank.
RANK: dict[Target, int] = {Mode.AUTO_LOITER: 1, Mode.AUTO_RTL: 2, Mode.AUTO_LAND: 3, Mode.AUTO_PRECLAND: 3, DESCEND: 4}
PHRASE: dict[Target, str] = {
    Mode.AUTO_LOITER: "holding", Mode.AUTO_RTL: "returning", Mode.AUTO_LAND: "landing",
    Mode.AUTO_PRECLAND: "landing", DESCEND: "descending", Mode.ALTCTL: "altitude control",
    Mode.POSCTL: "position control",
}  # fmt: skip
RCL_EXCEPT_BITS = {Mode.AUTO_MISSION: 1, Mode.AUTO_LOITER: 2, Mode.OFFBOARD: 4}


@dataclass
class FailsafeState:
    """What the failsafes have reported and done so far (so each event is said and acted on once)."""

    gcs_lost: bool = False
    rc_lost: bool = False
    offboard_lost: bool = False
    position_lost: bool = False
    attitude_lost: bool = False
    battery_level: BatteryWarning = BatteryWarning.NONE  # the highest level reported while armed
    in_force: Mode | None = None  # the mode a failsafe action put the vehicle in (None: none in force)
    terminated: bool = False  # the motors were stopped by a failsafe (until the next arming)
    critical_failure: bool = False  # armed, the failure detector finds a loss of control now (failure_detector)
    # the FailsafeStatus last published and its fields (:func:`status` publishes it again while they hold)
    published: tuple[tuple, FailsafeStatus] | None = field(default=None, repr=False, compare=False)


def status(c: Commander, level: BatteryWarning | None = None) -> FailsafeStatus:
    """The failsafe part of the published status (``level``: the battery warning now, if the caller has it);
    the record published last while its fields are the same (frozen: nobody can tell)."""
    st = c.failsafe
    if level is None:
        level = health.battery_warning(c.battery.remaining_frac, c.params)
    armed = c.armed
    battery_emergency = armed and level is BatteryWarning.EMERGENCY
    key = (
        armed and st.in_force is not None and c.mode is st.in_force,  # action_in_force
        (st.terminated and not armed) or battery_emergency or (armed and st.critical_failure),  # emergency
        c.inputs.manual is not None,  # rc_seen
        st.rc_lost,
        st.gcs_lost,
    )
    last = st.published
    if last is None or last[0] != key:
        last = st.published = (key, FailsafeStatus(*key))
    return last[1]


def check(c: Commander, now_us: int) -> None:
    """Act on the failures of this update (see the module docstring)."""
    st = c.failsafe
    if c.armed:
        st.terminated = False
    else:
        st.in_force, st.battery_level = None, BatteryWarning.NONE
    if c.est is None:
        return
    _estimator(c)
    _offboard(c, now_us)
    _manual_control(c, now_us)
    _data_link(c, now_us)
    _battery(c)
    if st.in_force is not None and c.mode is not st.in_force:
        st.in_force = None  # the pilot took over


def _flying(c: Commander) -> bool:
    return c.armed and c.in_air


def _estimator(c: Commander) -> None:
    st, e = c.failsafe, c.est
    assert e is not None
    if e.attitude_valid:
        st.attitude_lost = False
    elif _flying(c) and not st.attitude_lost:
        st.attitude_lost = True
        act(c, DESCEND, S.MAV_SEVERITY_CRITICAL, "Attitude estimate lost")
        return
    if e.position_valid:
        if st.position_lost:
            st.position_lost = False
            c.say(S.MAV_SEVERITY_INFO, "Position estimate regained")
        return
    if st.position_lost or not _flying(c) or not e.attitude_valid:
        return
    if mode_entry.estimate_refusal(c, c.mode) is None:
        return  # the mode flies without a position (ALTCTL, STABILIZED, ACRO, AUTO.LAND on the height)
    st.position_lost = True
    pilot = mode_entry.input_refusal(c, Mode.ALTCTL) is None
    target: Target = Mode.ALTCTL if pilot and int(c.params.get("COM_POSCTL_NAVL")) == 0 else Mode.AUTO_LAND
    if mode_entry.estimate_refusal(c, Mode.AUTO_LAND) is not None:
        target = DESCEND  # no height either
    act(c, target, S.MAV_SEVERITY_CRITICAL, "Position estimate lost")


def _offboard(c: Commander, now_us: int) -> None:
    st = c.failsafe
    if c.mode is not Mode.OFFBOARD or not c.armed:
        st.offboard_lost = False
        return
    if not offboard.offboard_lost(c.inputs, now_us, c.wall_s, c.params):
        st.offboard_lost = False
    elif not st.offboard_lost:
        st.offboard_lost = True
        act(c, offboard.loss_fallback_mode(c.params), S.MAV_SEVERITY_CRITICAL, "Offboard control lost")


def _manual_control(c: Commander, now_us: int) -> None:
    age = c.inputs.manual_age_s(now_us, c.wall_s)
    if age is None:  # never seen: nothing to watch
        return

    def target() -> Target:
        excepted = int(c.params.get("COM_RCL_EXCEPT")) & RCL_EXCEPT_BITS.get(c.mode, 0)
        return None if excepted else NAV_ACTIONS.get(int(c.params.get("NAV_RCL_ACT")))

    _input_loss(c, age, c.params.get("COM_RC_LOSS_T"), "rc_lost", "Manual control", target)


def _data_link(c: Commander, now_us: int) -> None:
    age = c.inputs.gcs_age_s(now_us, c.wall_s)
    if age is not None:
        target = lambda: NAV_ACTIONS.get(int(c.params.get("NAV_DLL_ACT")))  # noqa: E731
        _input_loss(c, age, c.params.get("COM_DL_LOSS_T"), "gcs_lost", "Data link", target)


def _input_loss(
    c: Commander, age_s: float | None, timeout_s: float, flag: str, what: str, target: Callable[[], Target]
) -> None:
    """One watched input (sticks, the data link), ``age_s`` silent (None: never seen): its loss reported once
    and acted on (``target()``), its return reported; ``flag`` names its FailsafeState field."""
    if age_s is None:
        return
    was_lost = getattr(c.failsafe, flag)
    if age_s <= timeout_s:
        if was_lost:
            setattr(c.failsafe, flag, False)
            c.say(S.MAV_SEVERITY_INFO, f"{what} regained")
    elif not was_lost:
        setattr(c.failsafe, flag, True)
        act(c, target(), S.MAV_SEVERITY_CRITICAL, f"{what} lost")


BATTERY_WORDS = {
    BatteryWarning.LOW: ("Low battery", S.MAV_SEVERITY_WARNING, "return advised"),
    BatteryWarning.CRITICAL: ("Critical battery", S.MAV_SEVERITY_CRITICAL, "landing advised"),
    BatteryWarning.EMERGENCY: ("Emergency battery", S.MAV_SEVERITY_EMERGENCY, "land now"),
}


def _battery(c: Commander) -> None:
    """Each level once while armed, as it is reached; a charge that rises again lowers the level reported."""
    st = c.failsafe
    if not c.armed:
        return
    level = health.battery_warning(c.battery.remaining_frac, c.params)
    if level <= st.battery_level:
        st.battery_level = level
        return
    st.battery_level = level
    what, severity, advice = BATTERY_WORDS[level]
    what = f"{what} ({c.battery.remaining_frac * 100:.0f}% left)"
    action = int(c.params.get("COM_LOW_BAT_ACT"))
    target: Target = None
    if level is BatteryWarning.CRITICAL and action in (2, 3):
        target = Mode.AUTO_RTL if action == 3 else Mode.AUTO_LAND
    elif level is BatteryWarning.EMERGENCY and action in (2, 3):
        target = Mode.AUTO_LAND
    if target is None or not _flying(c):
        c.say(severity, f"{what}: {advice}")
        return
    act(c, target, severity, what)


def act(c: Commander, target: Target, severity: int, what: str) -> None:
    """Report ``what`` and, flying, take the action ``target``: one STATUSTEXT "what: action", said before
    the mode change's own messages."""
    at = len(c.events)
    phrase = take(c, target) if _flying(c) else None
    c.events.insert(at, (severity, f"{what}: {phrase}" if phrase else what))


def take(c: Commander, target: Target) -> str | None:
    """Do ``target`` (falling back when its mode is refused); what was done, in words (None: nothing)."""
    st = c.failsafe
    if target is None:
        return None
    if target == TERMINATE:
        c._disarm("flight termination")
        st.terminated, st.in_force = True, None
        return "motors stopped"
    current = DESCEND if isinstance(c.task, DescendTask) else c.mode
    if target in RANK and RANK.get(current, 0) >= RANK[target]:
        st.in_force = c.mode
        return f"already {PHRASE[current]}"
    chain = [target] + [m for m in (Mode.AUTO_LAND, DESCEND) if RANK[m] > RANK.get(target, 0)]
    for step in chain:
        if step == DESCEND:
            _descend(c)
            st.in_force = Mode.AUTO_LAND
            return PHRASE[DESCEND]
        assert isinstance(step, Mode)
        if c._enter(step) == S.MAV_RESULT_ACCEPTED:
            st.in_force = step
            return PHRASE.get(step, f"mode {step.label}")
    return None  # not reached: descending is never refused


def _descend(c: Commander) -> None:
    """Fly the descend task (level, thrust just below hover) in AUTO.LAND, as PX4 reports Descend."""
    assert c.est is not None
    c.task = started(DescendTask(c.hover_thrust_frac), c.est, c.now_us)
    c._switch_mode(Mode.AUTO_LAND)
