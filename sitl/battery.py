"""Battery: a LiPo pack whose voltage sags with current and falls as it discharges.

Open-circuit voltage per cell is a piecewise-linear function of state of charge
(typical LiPo curve, 4.2 V full, 3.5 V empty); terminal voltage is that minus
I R.  Current comes from the rotors' shaft power divided by an efficiency.  For tests the charge
can instead fall at a steady rate and stop at a floor (PX4 SITL's SIM_BAT_DRAIN, SIM_BAT_MIN_PCT).
"""

from __future__ import annotations

import bisect

_SOC = (0.0, 0.05, 0.1, 0.2, 0.5, 0.8, 0.95, 1.0)
_OCV = (3.3, 3.5, 3.6, 3.7, 3.8, 3.95, 4.1, 4.2)
_LAST = len(_SOC) - 1


def cell_ocv_v(soc: float) -> float:
    """Open-circuit voltage of one cell (V) at a state of charge 0..1 (linear between table points)."""
    soc = min(max(soc, 0.0), 1.0)
    i = min(max(bisect.bisect_right(_SOC, soc), 1), len(_SOC) - 1)
    f = (soc - _SOC[i - 1]) / (_SOC[i] - _SOC[i - 1])
    return _OCV[i - 1] + f * (_OCV[i] - _OCV[i - 1])


class Battery:
    def __init__(
        self,
        cells: int = 4,
        capacity_mah: float = 5000.0,
        internal_resistance_ohm: float = 0.02,
        efficiency: float = 0.7,
        idle_current_a: float = 0.5,
    ) -> None:
        self.cells = cells
        self.capacity_as = capacity_mah * 3.6
        self.r_ohm = internal_resistance_ohm
        self.efficiency = efficiency
        self.idle_current_a = idle_current_a
        self.used_as = 0.0
        self.current_a = idle_current_a
        self.voltage_v = self.open_circuit_v()

    @property
    def remaining_frac(self) -> float:
        return max(0.0, 1.0 - self.used_as / self.capacity_as)

    @property
    def consumed_mah(self) -> float:
        return self.used_as / 3.6

    def open_circuit_v(self) -> float:
        return self.cells * cell_ocv_v(self.remaining_frac)

    def step(self, shaft_power_w: float, dt_s: float, drain_s: float = 0.0, min_frac: float = 0.0) -> None:
        """Draw the current the rotors need for dt_s seconds.

        ``drain_s`` > 0: the charge falls at a steady rate that empties the full pack in ``drain_s``
        seconds, whatever the load (PX4 SITL's SIM_BAT_DRAIN; the current and the sag still follow the
        rotors).  ``min_frac``: the charge never falls below this fraction, and rises to it when it is
        raised above the charge (SIM_BAT_MIN_PCT).
        """
        # The arithmetic of open_circuit_v() and of min/max, inline (every lockstep period: calls cost most here).
        cap, used = self.capacity_as, self.used_as
        soc = 1.0 - used / cap
        soc = soc if soc > 0.0 else 0.0  # max(0.0, soc)
        if soc > 1.0:  # cell_ocv_v's clamp (soc >= 0 here)
            soc = 1.0
        i = bisect.bisect_right(_SOC, soc)
        i = 1 if i < 1 else _LAST if i > _LAST else i
        ocv = self.cells * (_OCV[i - 1] + (soc - _SOC[i - 1]) / (_SOC[i] - _SOC[i - 1]) * (_OCV[i] - _OCV[i - 1]))
        current = self.current_a = self.idle_current_a + shaft_power_w / self.efficiency / (1.0 if 1.0 > ocv else ocv)
        self.voltage_v = ocv - current * self.r_ohm
        used += cap * dt_s / drain_s if drain_s > 0.0 else current * dt_s
        floor = 0.0 if min_frac < 0.0 else 1.0 if min_frac > 1.0 else min_frac  # min(max(min_frac, 0.0), 1.0)
        limit = cap * (1.0 - floor)
        self.used_as = limit if limit < used else used  # min(used, limit)
