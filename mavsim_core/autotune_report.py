"""The autotune's per-axis result as one STATUSTEXT line: written by the flight controller, read by ``gcs``.

One line per tuned axis, readable as it is in any ground station's message list (QGroundControl shows
STATUSTEXT) and parsed back by ``gcs autotune`` (:func:`parse_axis_line`)::

    Autotune roll: b 1.02 tau 12.4 ms delay 0 ms fit 0.78; P 12>16.14 I 6>60 D 0.15>0;
    fc 1.92>2.58 Hz PM 81.2>55.0 deg GM 18.9>16.8 dB

(one line on the wire, chunked by MAVLink 2's STATUSTEXT id/chunk_seq).  ``b`` is the identified
effectiveness (no unit), ``tau`` the motor lag, ``delay`` the extra transport delay; P (1/s), I (1/s^2),
D (no unit) are the rate gains now > proposed; fc the rate loop's crossover, PM/GM its phase and gain
margins, with the gains now > with the proposal, both on the identified plant.  GM may be ``inf``.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

AXES = ("roll", "pitch", "yaw")
PREFIX = "Autotune "


@dataclass(frozen=True, slots=True)
class AxisReport:
    axis: str  # roll, pitch or yaw
    effectiveness: float  # b
    motor_tau_s: float
    delay_s: float
    fit: float
    gains_now: tuple[float, float, float]  # P 1/s, I 1/s^2, D
    gains_new: tuple[float, float, float]
    crossover_hz: tuple[float, float]  # now, proposed
    phase_margin_deg: tuple[float, float]
    gain_margin_db: tuple[float, float]


def _g(x: float) -> str:
    return f"{x:.4g}"


def axis_line(r: AxisReport) -> str:
    """The STATUSTEXT line of one axis (module docstring)."""
    (p0, i0, d0), (p1, i1, d1) = r.gains_now, r.gains_new
    fc, pm, gm = r.crossover_hz, r.phase_margin_deg, r.gain_margin_db
    return (
        f"{PREFIX}{r.axis}: b {r.effectiveness:.3f} tau {r.motor_tau_s * 1e3:.1f} ms delay {r.delay_s * 1e3:.0f} ms"
        f" fit {r.fit:.2f}; P {_g(p0)}>{_g(p1)} I {_g(i0)}>{_g(i1)} D {_g(d0)}>{_g(d1)};"
        f" fc {fc[0]:.2f}>{fc[1]:.2f} Hz PM {pm[0]:.1f}>{pm[1]:.1f} deg GM {gm[0]:.1f}>{gm[1]:.1f} dB"
    )


_NUM = r"([-+0-9.eE]+|inf|nan)"
_LINE = re.compile(
    rf"^{PREFIX}(roll|pitch|yaw): b {_NUM} tau {_NUM} ms delay {_NUM} ms fit {_NUM}; "
    rf"P {_NUM}>{_NUM} I {_NUM}>{_NUM} D {_NUM}>{_NUM}; "
    rf"fc {_NUM}>{_NUM} Hz PM {_NUM}>{_NUM} deg GM {_NUM}>{_NUM} dB$"
)


def parse_axis_line(text: str) -> AxisReport | None:
    """The report of an :func:`axis_line`, or None if ``text`` is not one."""
    m = _LINE.match(text.strip())
    if m is None:
        return None
    v = [float(x) for x in m.groups()[1:]]
    return AxisReport(
        axis=m.group(1),
        effectiveness=v[0],
        motor_tau_s=v[1] / 1e3,
        delay_s=v[2] / 1e3,
        fit=v[3],
        gains_now=(v[4], v[6], v[8]),
        gains_new=(v[5], v[7], v[9]),
        crossover_hz=(v[10], v[11]),
        phase_margin_deg=(v[12], v[13]),
        gain_margin_db=(v[14], v[15]),
    )


def margin_ok(r: AxisReport, min_pm_deg: float = 30.0, min_gm_db: float = 6.0) -> bool:
    """The proposal's margins are at least these (NaN fails)."""
    pm, gm = r.phase_margin_deg[1], r.gain_margin_db[1]
    return math.isfinite(pm) and pm >= min_pm_deg and gm >= min_gm_db
