"""Gains for an identified rate plant, and the margins before and after (one axis).

The new gains come from :func:`mavsim_core.loop_design.design_rate_pid` with the specification the
default gains were designed to (``design-gains``, docs/tuning.md): pole placement on the identified
plant, the widest-bandwidth placement whose full discrete loop (gyro filter, the derivative's low-pass)
keeps DESIGN_PHASE_MARGIN_DEG of phase margin and loop_design's minimum gain margin, with P at most the
axis' authority at hover / ERR_REF_RAD_S (this binds for yaw, turned by rotor drag only).  PX4's
MC_AT_RISE_TIME can ask for a slower loop: a closed-loop rise time t_r wants a crossover near
0.35 / t_r (a first-order closed loop's 10-90 % rise time is 0.35 / its bandwidth), used when it is
below the fastest design's.  The gains are clamped into their parameters' declared ranges and the
margins reported are those of the clamped gains, on the identified plant: what the vehicle would fly.

Pure: plants and gains in, frozen records out.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from autopilot.tuning.identify import IdentifiedPlant
from mavsim_core.autotune_report import AxisReport
from mavsim_core.loop_design import LoopFilters, Margins, PidGains, RatePlant, design_rate_pid, rate_loop_margins

DESIGN_PHASE_MARGIN_DEG = 45.0  # as design-gains' default (sitl/gain_design.py)
ERR_REF_RAD_S = 0.1  # P x this rate error stays within the axis' authority (as design-gains)
RISE_TO_CROSSOVER = 0.35  # crossover (Hz) ~ this / rise time (s)

Ranges = tuple[tuple[float, float], tuple[float, float], tuple[float, float]]  # (min, max) of P, I, D


@dataclass(frozen=True, slots=True)
class AxisProposal:
    axis: str  # roll, pitch, yaw
    plant: IdentifiedPlant
    gains_now: PidGains
    gains_new: PidGains
    margins_now: Margins  # the current gains on the identified plant
    margins_new: Margins  # the proposal on the identified plant

    def report(self) -> AxisReport:
        """The record :mod:`mavsim_core.autotune_report` turns into the STATUSTEXT line."""
        g0, g1, m0, m1 = self.gains_now, self.gains_new, self.margins_now, self.margins_new
        return AxisReport(
            axis=self.axis,
            effectiveness=self.plant.effectiveness,
            motor_tau_s=self.plant.motor_tau_s,
            delay_s=self.plant.delay_s,
            fit=self.plant.fit,
            gains_now=(g0.p, g0.i, g0.d),
            gains_new=(g1.p, g1.i, g1.d),
            crossover_hz=(m0.crossover_hz, m1.crossover_hz),
            phase_margin_deg=(m0.phase_margin_deg, m1.phase_margin_deg),
            gain_margin_db=(m0.gain_margin_db, m1.gain_margin_db),
        )


def _clamp(g: PidGains, ranges: Ranges) -> PidGains:
    (p0, p1), (i0, i1), (d0, d1) = ranges
    return PidGains(min(max(g.p, p0), p1), min(max(g.i, i0), i1), min(max(g.d, d0), d1))


def propose(
    axis: str,
    plant: IdentifiedPlant,
    gains_now: PidGains,
    rise_time_s: float,
    ranges: Ranges,
    filters: LoopFilters = LoopFilters(),
    authority_rad_s2: float = math.inf,
) -> AxisProposal:
    """New gains for ``plant`` (module docstring); ValueError if no design meets the margins."""
    model = RatePlant(plant.effectiveness, plant.motor_tau_s, plant.delay_s)
    p_max = authority_rad_s2 / ERR_REF_RAD_S
    fastest = design_rate_pid(model, None, DESIGN_PHASE_MARGIN_DEG, filters, p_max)
    f_fast = _margins(model, fastest, filters).crossover_hz
    wanted_hz = RISE_TO_CROSSOVER / rise_time_s
    gains = fastest if not wanted_hz < f_fast else design_rate_pid(model, wanted_hz, DESIGN_PHASE_MARGIN_DEG, filters)
    gains = _clamp(gains, ranges)
    return AxisProposal(
        axis, plant, gains_now, gains, _margins(model, gains_now, filters), _margins(model, gains, filters)
    )


def _margins(model: RatePlant, gains: PidGains, f: LoopFilters) -> Margins:
    return rate_loop_margins(model, gains, f.sample_hz, f.d_cutoff_hz, f.gyro_cutoff_hz)
