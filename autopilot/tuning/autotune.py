"""The autotune state machine (MAV_CMD_DO_AUTOTUNE_ENABLE), as PX4's mc_autotune_attitude_control.

While the vehicle flies in a position-holding mode (Hold or Position), each axis of MC_AT_AXES in turn
(roll, pitch, yaw) gets SETTLE_S of quiet and then EXCITE_S of a PRBS (:mod:`.excitation`, amplitude
MC_AT_SYSID_AMP rad/s or less where the axis has little authority (:mod:`.authority`), its own integral
within +-2 deg) added to its rate setpoint; the flight controller hands back each step's (alpha_sp,
body rate) (:meth:`Autotune.record`).  At the end of an axis its plant
is identified (:mod:`.identify`); after the last one the gains are designed and the margins computed
(:mod:`.proposal`) and reported, one STATUSTEXT per axis (:mod:`mavsim_core.autotune_report`).

Nothing is applied until accepted.  The proposal is held (phase READY) until:
- DO_AUTOTUNE_ENABLE param1 = 2: accept, the gains are set through the parameter store (exactly as a
  PARAM_SET: ground stations get PARAM_VALUE and the change is saved); param1 = 0: reject, dropped;
- or, by MC_AT_APPLY as PX4: 1 applies it at the next disarm, 2 at once in the air; 0 (the default)
  waits for the accept.  A ground station can also simply write the MC_*RATE_P/I/D values of the report.
param1 = 1 starts a run (refused: disabled, not flying, not in Hold/Position); sent again while a run is
going or a proposal waits it is a progress poll, as QGroundControl sends it every second: IN_PROGRESS
with the progress in per cent (20-39 roll, 40-59 pitch, 60-79 yaw, 95 proposal waiting).  param1 = 0
aborts a run.  A run is aborted at once by any mode change, a disarm or a landing, and by
the ground station; the excitation stops with it and the gains stay what they were.  For FAILED_HOLD_S
after a failure, param1 = 1 answers FAILED (so a polling ground station learns it rather than starting
another run), saying so once.

Pure: no socket, no clock (times are the flight controller's simulated µs, counted in control periods),
no MAVLink (answers are :class:`Reply`, named as MAV_RESULT; messages go to ``say(severity, text)`` with
a MAV_SEVERITY name).
"""

from __future__ import annotations

import math
from enum import Enum
from typing import Callable

import numpy as np

from autopilot.parameters import ParamDef, ParamError, ParameterStore, param
from autopilot.tuning.authority import excitation_amplitude
from autopilot.tuning.excitation import Prbs
from autopilot.tuning.identify import IdentifiedPlant, identify_rate_plant
from autopilot.tuning.proposal import AxisProposal, propose
from mavsim_core.autotune_report import AXES, axis_line
from mavsim_core.loop_design import LoopFilters, PidGains
from mavsim_core.param_types import ParamType
from mavsim_core.px4_modes import Mode

SETTLE_S = 0.5  # quiet before each axis' excitation, s
EXCITE_S = 4.0  # excitation (and samples) per axis, s
FAILED_HOLD_S = 2.0  # a poll within this long after a failure is answered FAILED, s
# PRBS bit length per axis, control periods: yaw (weak, slow) is excited with longer bits, so its
# rate moves well above the gyro noise within the little authority it has
BIT_SAMPLES = (3, 3, 25)
HOLD_MODES = frozenset({Mode.POSCTL, Mode.AUTO_LOITER})  # the position-holding modes it runs in
MAX_SPREAD = 0.15  # an identified b whose two halves of the samples differ more than this (/ b) is refused
EFFECTIVENESS_RANGE = (0.2, 5.0)  # an identified b outside this is refused

# The parameters this module reads (listed in autopilot/param_catalogue.py); PX4's names and meanings.
PARAMS: tuple[ParamDef, ...] = (
    param("MC_AT_EN", 1, 0, 1, "", "Autotune enabled (MAV_CMD_DO_AUTOTUNE_ENABLE is refused when 0)", ParamType.INT32),
    param(
        "MC_AT_APPLY",
        0,
        0,
        2,
        "",
        "When the proposed rate gains are applied: 0 when accepted (DO_AUTOTUNE_ENABLE param1 2), "
        "1 at the next disarm, 2 at once in the air",
        ParamType.INT32,
    ),
    param("MC_AT_SYSID_AMP", 0.7, 0.1, 6.0, "rad/s", "Amplitude of the PRBS added to the rate setpoint"),
    param(
        "MC_AT_RISE_TIME",
        0.01,
        0.01,
        0.5,
        "s",
        "Wanted rate closed-loop rise time; never faster than a 45 deg phase margin and the axis' authority "
        "allow (the default: as fast as that)",
    ),
    param("MC_AT_AXES", 7, 1, 7, "", "Axes tuned (bits: 0 roll, 1 pitch, 2 yaw)", ParamType.INT32),
)
_NAMES = ("ROLL", "PITCH", "YAW")


class Phase(Enum):
    IDLE = "idle"
    SETTLE = "settle"  # an axis' quiet lead-in
    EXCITE = "excite"  # an axis excited and logged
    READY = "ready"  # the proposal is held
    FAILED = "failed"  # the last run failed or was aborted


class Reply(Enum):
    """The answer to a command, named as MAVLink's MAV_RESULT."""

    ACCEPTED = "ACCEPTED"
    DENIED = "DENIED"
    FAILED = "FAILED"
    IN_PROGRESS = "IN_PROGRESS"


def gain_names(axis: int) -> tuple[str, str, str]:
    """MC_ROLLRATE_P, _I, _D (axis 0 roll, 1 pitch, 2 yaw)."""
    return tuple(f"MC_{_NAMES[axis]}RATE_{k}" for k in "PID")  # type: ignore[return-value]


class Autotune:
    """One vehicle's autotune; ``dt_s`` the control period, ``say(severity_name, text)`` its messages."""

    def __init__(
        self,
        params: ParameterStore,
        dt_s: float,
        say: Callable[[str, str], None],
        authority_rad_s2: tuple[float, float, float] = (math.inf, math.inf, math.inf),
    ) -> None:
        """``authority_rad_s2``: per axis the angular acceleration the mixer has at hover
        (:func:`autopilot.tuning.authority.hover_authority`): the excitation stays well inside it."""
        self.params, self.dt_s, self.say = params, dt_s, say
        self.authority_rad_s2 = authority_rad_s2
        self.phase = Phase.IDLE
        self.proposals: tuple[AxisProposal, ...] = ()
        self._axes: list[int] = []
        self._k = 0  # index into _axes
        self._n = 0  # periods in the current phase
        self._u: list[float] = []
        self._y: list[float] = []
        self._prbs: Prbs | None = None
        self._plants: dict[int, IdentifiedPlant] = {}
        self._mode: Mode | None = None
        self._failed_us: int | None = None
        self._hold_said = False  # the FAILED hold's reason has been said (once per failure)
        self._applied = False  # the last run's gains were applied (progress 100 until the next start)
        self._settle_n = max(1, round(SETTLE_S / dt_s))
        self._excite_n = max(60, round(EXCITE_S / dt_s))

    # -- state ---------------------------------------------------------------------------
    @property
    def busy(self) -> bool:
        """Running or holding a proposal: the flight controller calls :meth:`update` every step."""
        return self.phase in (Phase.SETTLE, Phase.EXCITE, Phase.READY)

    @property
    def running(self) -> bool:
        return self.phase in (Phase.SETTLE, Phase.EXCITE)

    @property
    def axis(self) -> int:
        return self._axes[self._k]

    @property
    def progress(self) -> int:
        """Per cent, as PX4 reports it to QGroundControl: 20-39 roll, 40-59 pitch, 60-79 yaw, 95 ready."""
        if self.phase is Phase.READY:
            return 95
        if not self.running:
            return 100 if self._applied else 0
        done = self._n + (self._settle_n if self.phase is Phase.EXCITE else 0)
        return 20 * (self.axis + 1) + int(19 * done / (self._settle_n + self._excite_n))

    # -- the command -------------------------------------------------------------------------
    def command(self, action: int, mode: Mode, armed: bool, in_air: bool, now_us: int) -> Reply:
        """DO_AUTOTUNE_ENABLE param1: 1 start (or poll), 0 abort or reject, 2 accept (module docstring)."""
        if action == 0:
            if self.running:
                self._fail(now_us, "Autotune aborted by the ground station: gains unchanged")
            elif self.phase is Phase.READY:
                self.phase, self.proposals = Phase.IDLE, ()
                self.say("INFO", "Autotune: proposal rejected, gains unchanged")
            return Reply.ACCEPTED
        if action == 2:
            if self.phase is not Phase.READY:
                self.say("CRITICAL", "Autotune: no proposal to accept")
                return Reply.DENIED
            return Reply.ACCEPTED if self._apply() else Reply.FAILED
        if self.busy:
            return Reply.IN_PROGRESS
        if self.phase is Phase.FAILED and self._failed_us is not None:
            age_s = (now_us - self._failed_us) * 1e-6
            if age_s < FAILED_HOLD_S:
                if not self._hold_said:  # (once: a polling ground station asks every second)
                    self._hold_said = True
                    self.say(
                        "WARNING",
                        f"Autotune: the last run stopped {age_s:.1f} s ago; start again after {FAILED_HOLD_S:g} s",
                    )
                return Reply.FAILED
        return self._start(mode, armed, in_air)

    def _start(self, mode: Mode, armed: bool, in_air: bool) -> Reply:
        why = None
        if self.params.get("MC_AT_EN") == 0:
            why = "disabled (MC_AT_EN 0)"
        elif not (armed and in_air):
            why = "not flying: take off first"
        elif mode not in HOLD_MODES:
            why = f"fly in Hold or Position mode, not {mode.label}"
        if why is not None:
            self.say("CRITICAL", f"Autotune denied: {why}")
            return Reply.DENIED
        bits = int(self.params.get("MC_AT_AXES"))
        self._axes = [a for a in range(3) if bits >> a & 1]
        self._mode, self._plants, self.proposals, self._applied = mode, {}, (), False
        self._k = 0
        self.say("INFO", f"Autotune started: {', '.join(AXES[a] for a in self._axes)}; a mode change stops it")
        self._begin_axis()
        return Reply.IN_PROGRESS

    def _begin_axis(self) -> None:
        self.phase, self._n = Phase.SETTLE, 0
        self._u, self._y = [], []
        self.say("INFO", f"Autotune: {AXES[self.axis]} {self.progress} %")

    def _fail(self, now_us: int, text: str) -> None:
        self.phase, self._failed_us, self._prbs, self._hold_said = Phase.FAILED, now_us, None, False
        self.say("WARNING", text)

    # -- every control period while busy ----------------------------------------------------
    def update(self, now_us: int, mode: Mode, armed: bool, in_air: bool) -> np.ndarray | None:
        """The excitation to add to the rate setpoint this period (rad/s FRD), or None: nothing to add."""
        if self.phase is Phase.READY:
            if not armed and self.params.get("MC_AT_APPLY") == 1:
                self._apply()
            return None
        why = None
        if not armed:
            why = "disarmed"
        elif mode is not self._mode:
            why = f"mode changed to {mode.label}"
        elif not in_air:
            why = "landed"
        if why is not None:
            self._fail(now_us, f"Autotune aborted: {why}; gains unchanged")
            return None
        if self.phase is Phase.SETTLE:
            self._n += 1
            if self._n >= self._settle_n:
                p_gain = self.params.get(gain_names(self.axis)[0])
                amp = excitation_amplitude(self.params.get("MC_AT_SYSID_AMP"), p_gain, self.authority_rad_s2[self.axis])
                self.phase, self._n, self._prbs = Phase.EXCITE, 0, Prbs(amp, self.dt_s, BIT_SAMPLES[self.axis])
            return None
        assert self._prbs is not None
        out = np.zeros(3)
        out[self.axis] = self._prbs.next()
        return out

    def record(self, alpha_sp_rad_s2: np.ndarray, rate_rad_s: np.ndarray, now_us: int) -> None:
        """This period's rate-controller output (rad/s^2) and measured body rate (rad/s), FRD."""
        if self.phase is not Phase.EXCITE:
            return
        a = self.axis
        self._u.append(float(alpha_sp_rad_s2[a]))
        self._y.append(float(rate_rad_s[a]))
        self._n += 1
        if self._n == self._excite_n // 2:
            self.say("INFO", f"Autotune: {AXES[a]} {self.progress} %")
        if self._n >= self._excite_n:
            self._end_axis(now_us)

    def _end_axis(self, now_us: int) -> None:
        a = self.axis

        try:
            plant = identify_rate_plant(np.array(self._u), np.array(self._y), self.dt_s)
        except ValueError as exc:
            self._fail(now_us, f"Autotune {AXES[a]}: identification failed ({exc})")
            return
        lo, hi = EFFECTIVENESS_RANGE
        if not (plant.effectiveness_spread <= MAX_SPREAD and lo <= plant.effectiveness <= hi):
            model = f"b {plant.effectiveness:.2f}, halves differ {plant.effectiveness_spread * 100:.0f} %"
            self._fail(now_us, f"Autotune {AXES[a]}: no usable model ({model})")
            return
        self._plants[a] = plant
        self._k += 1
        if self._k < len(self._axes):
            self._begin_axis()
        else:
            self._finish(now_us)

    def _finish(self, now_us: int) -> None:
        """Design every tuned axis, report, then hold (or apply, by MC_AT_APPLY)."""
        get = self.params.get
        filters = LoopFilters(sample_hz=1.0 / self.dt_s, gyro_cutoff_hz=get("IMU_GYRO_CUTOFF"))
        proposals = []
        for a, plant in self._plants.items():
            names = gain_names(a)
            now = PidGains(*(get(n) for n in names))
            ranges = tuple((self.params.definition(n).min, self.params.definition(n).max) for n in names)
            try:
                rise, authority = get("MC_AT_RISE_TIME"), self.authority_rad_s2[a]
                proposals.append(propose(AXES[a], plant, now, rise, ranges, filters, authority))  # type: ignore[arg-type]
            except ValueError as exc:
                self._fail(now_us, f"Autotune {AXES[a]}: no gains meet the margins ({exc})")
                return
        self.proposals, self.phase, self._prbs = tuple(proposals), Phase.READY, None
        for p in proposals:
            self.say("INFO", axis_line(p.report()))
        if get("MC_AT_APPLY") == 2:
            self._apply()
        elif get("MC_AT_APPLY") == 1:
            self.say("INFO", "Autotune done: the new gains apply at the next disarm")
        else:
            self.say("INFO", "Autotune done: accept (DO_AUTOTUNE_ENABLE 2) or reject (0)")

    def _apply(self) -> bool:
        """Set the proposal through the parameter store, all or nothing; True if applied."""
        values: dict[str, float] = {}
        for p in self.proposals:
            a = AXES.index(p.axis)
            values.update(zip(gain_names(a), (p.gains_new.p, p.gains_new.i, p.gains_new.d)))
        try:
            for name, v in values.items():
                self.params.check(name, v)
        except ParamError as exc:
            self.say("CRITICAL", f"Autotune: gains not applied ({exc})")
            return False
        for name, v in values.items():
            self.params.set(name, v)
        self.phase, self.proposals, self._applied = Phase.IDLE, (), True
        shown = ", ".join(f"{n} {v:.4g}" for n, v in values.items() if n.endswith("_P"))
        self.say("INFO", f"Autotune: new gains applied ({shown}, ...)")
        return True
