"""Failsafes: what the commander does by itself when something it relies on fails (PX4's failsafe actions).

:func:`decide` is a pure function, as PX4's newer failsafe framework: the commander builds a frozen
:class:`FailsafeInputs` (what the estimate, the inputs and links, the battery and the mode say now, with the
parameters) in every update, armed or not, and passes it with the failsafes' memory (:class:`FailsafeMemory`,
what was reported so far); it returns a :class:`FailsafeDecision` (the STATUSTEXTs to say, the action to take)
and the new memory, and the commander alone applies it (``Commander._check_failsafes``).  It watches, each with
PX4's parameters:

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
refused mode falls back (Return or Hold -> Land -> Descend: :func:`fallback_chain`), and an action never
"downgrades" a more cautious mode already flown (Land is not turned into Return: :func:`already_flown`).
Each event is reported once by a STATUSTEXT naming the action (and again when the input is regained); it
does not trigger again while it lasts, so the pilot may take over by switching modes, as in PX4.  Actions
are taken only while armed and flying; on the ground the event is only reported.  Input ages use both clocks
(:func:`autopilot.topics.input_age_s`; ``commander.wall_s`` None: simulated time only).  The watches run in
order; one that raises an alarm stops the pass (``FailsafeDecision.resume_at``): the commander applies it and
calls again from the next watch with a new snapshot, so each watch sees the mode the previous one left.
:func:`status` gives the published :class:`~autopilot.topics.FailsafeStatus` (MAV_STATE_CRITICAL
while an action is in force, MAV_STATE_EMERGENCY at battery emergency or after a termination).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Callable

from pymavlink.dialects.v20 import common as S

from autopilot.commander.mode_requirements import EstimateValidity, estimate_refusal
from autopilot.navigation import offboard
from autopilot.parameters import ParamDef, ParameterStore, ParamType, param
from autopilot.topics import BatteryWarning, FailsafeStatus
from mavsim_core.px4_modes import Mode

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


@dataclass(frozen=True)
class FailsafeParams:
    """The parameters the failsafes read (PX4's names in :data:`PARAMS`), and OFFBOARD's loss fallback."""

    rc_loss_t_s: float
    rcl_act: int
    rcl_except: int
    dl_loss_t_s: float
    dll_act: int
    low_bat_act: int
    posctl_navl: int
    offboard_fallback: Target  # COM_OBL_RC_ACT's mode (:func:`autopilot.navigation.offboard.loss_fallback_mode`)

    @classmethod
    def from_store(cls, params: ParameterStore) -> FailsafeParams:
        g = params.get
        return cls(
            g("COM_RC_LOSS_T"), int(g("NAV_RCL_ACT")), int(g("COM_RCL_EXCEPT")), g("COM_DL_LOSS_T"),
            int(g("NAV_DLL_ACT")), int(g("COM_LOW_BAT_ACT")), int(g("COM_POSCTL_NAVL")),
            offboard.loss_fallback_mode(params),
        )  # fmt: skip


@dataclass(frozen=True)
class FailsafeInputs:
    """What the vehicle says now, for :func:`decide` (ages in s, both clocks; None: never seen)."""

    armed: bool
    in_air: bool
    mode: Mode
    estimate: EstimateValidity | None  # None: no estimate yet (nothing is watched)
    manual_age_s: float | None  # the pilot's sticks (MANUAL_CONTROL)
    gcs_age_s: float | None  # the ground station's HEARTBEAT
    offboard_lost: bool  # armed in OFFBOARD, its setpoints silent for COM_OF_LOSS_T (False otherwise)
    battery_frac: float  # remaining charge (fraction; < 0 or NaN unknown)
    battery_level: BatteryWarning  # its grade (:func:`.health.battery_warning`)
    params: FailsafeParams

    @property
    def flying(self) -> bool:
        return self.armed and self.in_air


@dataclass(frozen=True)
class FailsafeMemory:
    """What the failsafes have reported so far, so each event is said and acted on once."""

    gcs_lost: bool = False
    rc_lost: bool = False
    offboard_lost: bool = False
    position_lost: bool = False
    attitude_lost: bool = False
    battery_level: BatteryWarning = BatteryWarning.NONE  # the highest level reported while armed


@dataclass(frozen=True)
class Alarm:
    """A failure to report in one STATUSTEXT ``what`` (at ``severity``) and, flying, the action ``target``."""

    severity: int
    what: str
    target: Target


@dataclass(frozen=True)
class FailsafeDecision:
    """What to do now: say ``texts`` (in order), then raise ``alarm`` (None: none); ``resume_at``: the watch to
    run next in this update (None: the pass is over)."""

    texts: tuple[tuple[int, str], ...] = ()
    alarm: Alarm | None = None
    resume_at: int | None = None


Watch = Callable[[FailsafeInputs, FailsafeMemory], tuple[FailsafeMemory, tuple[tuple[int, str], ...], Alarm | None]]


def decide(s: FailsafeInputs, m: FailsafeMemory, start: int = 0) -> tuple[FailsafeDecision, FailsafeMemory]:
    """The failsafes' decision in this situation, from watch ``start`` on (0: a new update), and the new memory."""
    if start == 0 and not s.armed and m.battery_level is not BatteryWarning.NONE:
        m = replace(m, battery_level=BatteryWarning.NONE)
    if s.estimate is None:
        return FailsafeDecision(), m
    texts: tuple[tuple[int, str], ...] = ()
    for k in range(start, len(WATCHES)):
        m, said, alarm = WATCHES[k](s, m)
        texts += said
        if alarm is not None:
            return FailsafeDecision(texts, alarm, k + 1 if k + 1 < len(WATCHES) else None), m
    return FailsafeDecision(texts), m


def _estimator(s: FailsafeInputs, m: FailsafeMemory):
    e = s.estimate
    assert e is not None
    if e.attitude:
        if m.attitude_lost:
            m = replace(m, attitude_lost=False)
    elif s.flying and not m.attitude_lost:
        return replace(m, attitude_lost=True), (), Alarm(S.MAV_SEVERITY_CRITICAL, "Attitude estimate lost", DESCEND)
    if e.position:
        if m.position_lost:
            return replace(m, position_lost=False), ((S.MAV_SEVERITY_INFO, "Position estimate regained"),), None
        return m, (), None
    if m.position_lost or not s.flying or not e.attitude or estimate_refusal(s.mode, e) is None:
        return m, (), None  # (a mode that flies without a position: ALTCTL, STABILIZED, ACRO, AUTO.LAND)
    p = s.params
    pilot = s.manual_age_s is not None and s.manual_age_s <= p.rc_loss_t_s  # ALTCTL's sticks
    target: Target = Mode.ALTCTL if pilot and p.posctl_navl == 0 else Mode.AUTO_LAND
    if estimate_refusal(Mode.AUTO_LAND, e) is not None:
        target = DESCEND  # no height either
    return replace(m, position_lost=True), (), Alarm(S.MAV_SEVERITY_CRITICAL, "Position estimate lost", target)


def _offboard(s: FailsafeInputs, m: FailsafeMemory):
    if s.mode is not Mode.OFFBOARD or not s.armed or not s.offboard_lost:
        return (replace(m, offboard_lost=False) if m.offboard_lost else m), (), None
    if m.offboard_lost:
        return m, (), None
    alarm = Alarm(S.MAV_SEVERITY_CRITICAL, "Offboard control lost", s.params.offboard_fallback)
    return replace(m, offboard_lost=True), (), alarm


def _manual_control(s: FailsafeInputs, m: FailsafeMemory):
    p = s.params
    excepted = p.rcl_except & RCL_EXCEPT_BITS.get(s.mode, 0)
    target = None if excepted else NAV_ACTIONS.get(p.rcl_act)
    return _input_loss(m, s.manual_age_s, p.rc_loss_t_s, "rc_lost", "Manual control", target)


def _data_link(s: FailsafeInputs, m: FailsafeMemory):
    p = s.params
    return _input_loss(m, s.gcs_age_s, p.dl_loss_t_s, "gcs_lost", "Data link", NAV_ACTIONS.get(p.dll_act))


def _input_loss(m: FailsafeMemory, age_s: float | None, timeout_s: float, flag: str, what: str, target: Target):
    """One watched input (sticks, the data link), ``age_s`` silent (None: never seen, nothing to watch): its loss
    reported once and acted on (``target``), its return reported; ``flag`` names its FailsafeMemory field."""
    if age_s is None:
        return m, (), None
    was_lost: bool = getattr(m, flag)
    if age_s <= timeout_s:
        if was_lost:
            return _flagged(m, flag, False), ((S.MAV_SEVERITY_INFO, f"{what} regained"),), None
    elif not was_lost:
        return _flagged(m, flag, True), (), Alarm(S.MAV_SEVERITY_CRITICAL, f"{what} lost", target)
    return m, (), None


def _flagged(m: FailsafeMemory, flag: str, value: bool) -> FailsafeMemory:
    return replace(m, rc_lost=value) if flag == "rc_lost" else replace(m, gcs_lost=value)


BATTERY_WORDS = {
    BatteryWarning.LOW: ("Low battery", S.MAV_SEVERITY_WARNING, "return advised"),
    BatteryWarning.CRITICAL: ("Critical battery", S.MAV_SEVERITY_CRITICAL, "landing advised"),
    BatteryWarning.EMERGENCY: ("Emergency battery", S.MAV_SEVERITY_EMERGENCY, "land now"),
}


def _battery(s: FailsafeInputs, m: FailsafeMemory):
    """Each level once while armed, as it is reached; a charge that rises again lowers the level reported."""
    if not s.armed:
        return m, (), None
    level = s.battery_level
    if level is m.battery_level:
        return m, (), None
    m, raised = replace(m, battery_level=level), level > m.battery_level
    if not raised:
        return m, (), None
    what, severity, advice = BATTERY_WORDS[level]
    what = f"{what} ({s.battery_frac * 100:.0f}% left)"
    action = s.params.low_bat_act
    target: Target = None
    if level is BatteryWarning.CRITICAL and action in (2, 3):
        target = Mode.AUTO_RTL if action == 3 else Mode.AUTO_LAND
    elif level is BatteryWarning.EMERGENCY and action in (2, 3):
        target = Mode.AUTO_LAND
    if target is None or not s.flying:
        return m, ((severity, f"{what}: {advice}"),), None
    return m, (), Alarm(severity, what, target)


WATCHES: tuple[Watch, ...] = (_estimator, _offboard, _manual_control, _data_link, _battery)  # in this order


def already_flown(current: Target, target: Target) -> bool:
    """The mode (or DESCEND) flown now is as cautious as ``target`` or more: the action keeps it."""
    return target in RANK and RANK.get(current, 0) >= RANK[target]


def fallback_chain(target: Target) -> list[Target]:
    """``target`` and what to try, in order, when it is refused: Land, then Descend (never refused)."""
    return [target] + [m for m in (Mode.AUTO_LAND, DESCEND) if RANK[m] > RANK.get(target, 0)]


@dataclass
class FailsafeState:
    """The commander's record of the failsafes: their memory, and what applying their decisions did."""

    memory: FailsafeMemory = FailsafeMemory()
    in_force: Mode | None = None  # the mode a failsafe action put the vehicle in (None: none in force)
    terminated: bool = False  # the motors were stopped by a failsafe (until the next arming)
    critical_failure: bool = False  # armed, the failure detector finds a loss of control now (failure_detector)
    # the FailsafeStatus last published and its fields (:func:`status` publishes it again while they hold)
    published: tuple[tuple, FailsafeStatus] | None = field(default=None, repr=False, compare=False)


def status(st: FailsafeState, armed: bool, mode: Mode, rc_seen: bool, level: BatteryWarning) -> FailsafeStatus:
    """The failsafe part of the published status (``level``: the battery warning now); the record published
    last while its fields are the same (frozen: nobody can tell)."""
    battery_emergency = armed and level is BatteryWarning.EMERGENCY
    key = (
        armed and st.in_force is not None and mode is st.in_force,  # action_in_force
        (st.terminated and not armed) or battery_emergency or (armed and st.critical_failure),  # emergency
        rc_seen,
        st.memory.rc_lost,
        st.memory.gcs_lost,
    )
    last = st.published
    if last is None or last[0] != key:
        last = st.published = (key, FailsafeStatus(*key))
    return last[1]
