"""The flight controller's parameter catalogue: every module's ``PARAMS``, listed explicitly.

Each module defines the parameters it reads next to its code (``PARAMS``, see
:mod:`autopilot.parameters`); this list is the one place that says which modules' parameters
the flight controller has.  ``docs/parameters.md`` is generated from it
(``python -m autopilot.param_catalogue --markdown``) and a test keeps the two in sync.
"""

from __future__ import annotations

import argparse
import sys

from autopilot import flight_controller, flight_recorder, landing_target_input, system_id, telemetry_extras
from autopilot.commander import commander, failsafes, failure_detector, health
from autopilot.control import gains_from_params
from autopilot.estimation import ekf, estimator, mag_fusion, mahony, position_kf
from autopilot.mavlink import failure_injection, gimbal_control
from autopilot.navigation import (
    cut_lead,
    deck_heading,
    dock_gate,
    follow_target,
    geofence,
    goto,
    land,
    land_detector,
    landing_target_estimator,
    loiter,
    manual_modes,
    mission,
    offboard,
    orbit,
    precland,
    precland_gimbal,
    rtl,
    takeoff,
    touchdown,
    view_limited_catchup,
)
from autopilot.parameters import FLIGHT_FLOORS, RULES, ParamDef, ParameterStore, definitions
from autopilot.tuning import autotune

# Grouped as PX4 groups its parameters: controllers, estimation, navigation, commander.
_MODULE_PARAMS: tuple[tuple[ParamDef, ...], ...] = (
    gains_from_params.PARAMS,
    flight_controller.PARAMS,
    ekf.PARAMS,
    mag_fusion.PARAMS,
    position_kf.PARAMS,
    mahony.PARAMS,
    estimator.PARAMS,
    takeoff.PARAMS,
    loiter.PARAMS,
    goto.PARAMS,
    land.PARAMS,
    rtl.PARAMS,
    mission.PARAMS,
    geofence.PARAMS,
    land_detector.PARAMS,
    commander.PARAMS,
    health.PARAMS,
    failsafes.PARAMS,
    failure_detector.PARAMS,
    manual_modes.PARAMS,
    offboard.PARAMS,
    precland.PARAMS,
    deck_heading.PARAMS,
    cut_lead.PARAMS,
    dock_gate.PARAMS,
    touchdown.PARAMS,
    precland_gimbal.PARAMS,
    view_limited_catchup.PARAMS,
    orbit.PARAMS,
    follow_target.PARAMS,
    landing_target_estimator.PARAMS,
    landing_target_input.PARAMS,
    flight_recorder.PARAMS,
    system_id.PARAMS,
    telemetry_extras.PARAMS,
    failure_injection.PARAMS,
    gimbal_control.PARAMS,
    autotune.PARAMS,
)


def catalogue() -> dict[str, ParamDef]:
    """Every parameter of the flight controller, by name (ValueError on a conflicting duplicate)."""
    return definitions(d for group in _MODULE_PARAMS for d in group)


def default_store() -> ParameterStore:
    """A parameter store holding the catalogue at its declared defaults, with the cross-parameter rules."""
    return ParameterStore(catalogue(), RULES)


def _fmt(x: float) -> str:
    return f"{x:g}"


FLOORS_TEXT = (
    "While the vehicle is armed these gains are refused below a fraction of their default (the vehicle's);"
    " disarmed, any value of the range is accepted. Below them the vehicle cannot be flown (issue 18)."
)


def markdown() -> str:
    """The parameter reference (docs/parameters.md): name, type, default, range, unit, description."""
    lines = [
        "# Flight controller parameters",
        "",
        "Generated from the code by `python -m autopilot.param_catalogue --markdown > docs/parameters.md`;",
        "`tests/test_param_catalogue.py` fails when this file and the code disagree.",
        "Names are PX4's where PX4 has the same parameter. Integers travel byte-wise encoded",
        "in PARAM_VALUE, as PX4 sends them.",
        "",
        "| name | type | default | min | max | unit | description |",
        "|---|---|---|---|---|---|---|",
    ]
    for name, d in sorted(catalogue().items()):
        reboot = " (applies at the next start)" if d.reboot_required else ""
        lines.append(
            f"| `{name}` | {d.ptype} | {_fmt(d.default)} | {_fmt(d.min)} | {_fmt(d.max)} | "
            f"{d.unit} | {d.description.replace('|', '/')}{reboot} |"
        )
    lines += [
        "",
        "## Rules between parameters",
        "",
        "A set that would break one of these is refused with a STATUSTEXT saying why.",
        "",
    ]
    lines += [f"- `{r.lhs} {r.op} {r.rhs}`: {r.why}" for r in RULES]
    lines += ["", "## Floors while armed", "", FLOORS_TEXT, ""]
    lines += [
        f"- `{f.name}` >= {f.fraction:g} x default{' (or 0: off)' if f.zero_is_off else ''}: {f.why}"
        for f in FLIGHT_FLOORS
    ]
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--markdown", action="store_true", help="print the Markdown parameter reference")
    args = p.parse_args(argv)
    if args.markdown:
        sys.stdout.write(markdown())
    else:
        for name, d in sorted(catalogue().items()):
            print(f"{name:16} {d.ptype:6} {_fmt(d.default):>8} [{_fmt(d.min)}, {_fmt(d.max)}] {d.unit}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
