"""``design-gains VEHICLE``: the cascade's gains designed from the vehicle file's model, as a .params file.

The model: the hover linearisation of [F] eqs (4.16)-(4.19) through the simulator's own MuJoCo model
(:func:`sitl.linearize.linearize_hover`) gives, per body axis, the angular acceleration per torque
(B = 1/J); the rate controller commands an angular acceleration that the flight controller multiplies by
the vehicle file's inertia, so the rate plant's gain is B J (1 when the file's inertia is the model's), and
the vertical one is -B m.  The motors add a first-order lag (the mean of the vehicle file's up and down
time constants: a torque is one rotor speeding up while another slows down); the loop's own hold (the
4 ms lockstep period), gyro low-pass (IMU_GYRO_CUTOFF) and derivative low-pass are modelled exactly
(:mod:`mavsim_core.loop_design`); the simulator adds no other delay on the rate path (a gyro sample is
answered before the physics steps).  The position loops fly on the estimator's output predictor (GPS
delay compensated), so their plant has only the 50 Hz hold.

Every loop is then designed (:mod:`mavsim_core.loop_design`, :mod:`sitl.cascade_design`), its
gains, crossover, margins and bandwidth printed with the predicted 10 m steps
(:mod:`sitl.cascade_sim`), and the gains written in QGroundControl's format (``--out``) or into
the marked block of ``params/vehicles/VEHICLE.params`` (``--update``).  The flight-controller settings
the design assumes (its defaults) are options.  Errors: argparse's one ``error:`` line, exit 2.
"""

from __future__ import annotations

import argparse
import math
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from mavsim_core.cli_checks import number_in, positive_number
from mavsim_core.constants import GRAVITY_M_S2, LOCKSTEP_DT_S
from mavsim_core.loop_design import LoopFilters, Margins, PidGains, RatePlant, design_rate_pid, rate_loop_response
from params.param_file import ParamEntry, atomic_write_text, format_qgc
from params.vehicle import VehicleSpec, load_vehicle, vehicle_path
from params.vehicle_arg import vehicle_argument
from sitl.cascade_design import (
    OuterLoop,
    design_attitude,
    design_position,
    design_velocity_xy,
    design_velocity_z,
    outer_grid_hz,
)
from sitl.cascade_sim import OuterGains, StepResult, simulate_xy_step, simulate_z_step, step_metrics

BEGIN, END = "# BEGIN design-gains", "# END design-gains"
REAL32 = 9
YAW_ERR_REF_RAD_S = 0.1  # an axis' P times this rate error stays within the axis' authority at hover
AXES = ("ROLL", "PITCH", "YAW")


@dataclass(frozen=True)
class Design:
    """Every loop of one vehicle."""

    plants: tuple[RatePlant, RatePlant, RatePlant]
    rate: tuple[PidGains, PidGains, PidGains]
    rate_margins: tuple[Margins, Margins, Margins]
    rate_bw_hz: tuple[float, float, float]
    attitude: tuple[OuterLoop, OuterLoop, OuterLoop]
    vel_xy: OuterLoop
    pos_xy: OuterLoop
    vel_z: OuterLoop
    pos_z: OuterLoop
    step_xy: StepResult
    step_z: StepResult
    z_gain: float  # vertical acceleration per commanded acceleration (1 = the file is the model)


def axis_plants(spec: VehicleSpec) -> tuple[tuple[RatePlant, RatePlant, RatePlant], float]:
    """The three body axes' rate plants and the vertical gain (1 = the vehicle file is the model)."""
    from sitl.linearize import linearize_hover  # MuJoCo: only once the options are checked

    lin = linearize_hover(spec)
    tau = 0.5 * (spec.time_constant_up_s + spec.time_constant_down_s)
    j = spec.inertia_kg_m2
    plants = tuple(RatePlant(float(lin.B[9 + k, 1 + k] * j[k]), tau, 0.0) for k in range(3))
    return plants, float(-lin.B[5, 0] * spec.mass_kg)  # type: ignore[return-value]


def authority_rad_s2(spec: VehicleSpec) -> np.ndarray:
    """Per axis (roll, pitch, yaw), the angular acceleration the rotors can add at hover (rad/s^2)."""
    e = spec.effectiveness_matrix()
    t_hover = np.linalg.pinv(e) @ np.array([0.0, 0.0, 0.0, spec.mass_kg * GRAVITY_M_S2])
    t_max = spec.max_thrust_per_rotor_n
    out = []
    for k in range(3):
        row = e[k]
        # each rotor pushed the way that adds torque about this axis, as far as it can go
        span = np.where(row > 0, t_max - t_hover, t_hover)
        out.append(float(np.abs(row) @ span) / spec.inertia_kg_m2[k])
    return np.array(out)


def design(spec: VehicleSpec, args: argparse.Namespace) -> Design:
    """Design every loop of the cascade for this vehicle (module docstring)."""
    filters = LoopFilters(1.0 / LOCKSTEP_DT_S, 30.0, args.gyro_cutoff)
    plants, z_gain = axis_plants(spec)
    auth = authority_rad_s2(spec)
    rate = tuple(
        design_rate_pid(p, phase_margin_deg=args.phase_margin, filters=filters, p_max=a / YAW_ERR_REF_RAD_S)
        for p, a in zip(plants, auth)
    )
    f = outer_grid_hz()
    closed = [rate_loop_response(p, g, f, filters)[1] for p, g in zip(plants, rate)]
    att = tuple(design_attitude(c, f, args.ratio, f"{a.lower()} angle") for c, a in zip(closed, AXES))
    slow = max(range(2), key=lambda k: -att[k].bandwidth_hz)  # the slower of roll and pitch flies x and y
    vel_xy = design_velocity_xy(att[slow].closed, f, args.ratio)
    pos_xy = design_position(vel_xy, f, args.ratio, "position xy")
    # Vertically the motors alone are inside; 4x below them the loop is stiff enough to feed the
    # vertical-velocity estimate's noise to the thrust (precision-landing touchdowns 2-5x further off
    # the marker), so this loop keeps twice the separation.
    vel_z = design_velocity_z(plants[0].motor_tau_s, f, 2 * args.ratio)
    pos_z = design_position(vel_z, f, args.ratio, "position z")
    acc_xy = GRAVITY_M_S2 * math.tan(math.radians(args.tilt_max))
    t, x = simulate_xy_step(
        plants[slow],
        rate[slow],
        att[slow].p,
        OuterGains(pos_xy.p, vel_xy.p, vel_xy.i, args.vel_max, acc_xy),
        math.radians(args.rate_max),
        filters=filters,
    )
    acc_z = GRAVITY_M_S2 * (1.0 / spec.hover_thrust_fraction - 1.0)  # full thrust above the weight
    tz, z = simulate_z_step(plants[0].motor_tau_s, OuterGains(pos_z.p, vel_z.p, vel_z.i, args.vel_up, acc_z))
    return Design(
        plants,
        rate,  # type: ignore[arg-type]
        tuple(_margins(p, g, filters) for p, g in zip(plants, rate)),  # type: ignore[arg-type]
        tuple(_bw(p, g, filters) for p, g in zip(plants, rate)),  # type: ignore[arg-type]
        att,  # type: ignore[arg-type]
        vel_xy,
        pos_xy,
        vel_z,
        pos_z,
        step_metrics(t, x, 10.0),
        step_metrics(tz, z, 10.0),
        z_gain,
    )


def _margins(plant: RatePlant, gains: PidGains, filters: LoopFilters) -> Margins:
    from mavsim_core.loop_design import rate_loop_margins

    return rate_loop_margins(plant, gains, filters.sample_hz, filters.d_cutoff_hz, filters.gyro_cutoff_hz)


def _bw(plant: RatePlant, gains: PidGains, filters: LoopFilters) -> float:
    from mavsim_core.loop_design import bandwidth_hz, freq_grid_hz

    f = freq_grid_hz(filters.sample_hz)
    return bandwidth_hz(rate_loop_response(plant, gains, f, filters)[1], f)


def gains_table(d: Design) -> dict[str, float]:
    """Parameter name -> designed value (rounded to 3 significant digits)."""
    out: dict[str, float] = {}
    for axis, g, att in zip(AXES, d.rate, d.attitude):
        out[f"MC_{axis}RATE_P"], out[f"MC_{axis}RATE_I"], out[f"MC_{axis}RATE_D"] = g.p, g.i, g.d
        out[f"MC_{axis}_P"] = att.p
    out["MPC_XY_P"], out["MPC_Z_P"] = d.pos_xy.p, d.pos_z.p
    out["MPC_XY_VEL_P_ACC"], out["MPC_XY_VEL_I_ACC"], out["MPC_XY_VEL_D_ACC"] = d.vel_xy.p, d.vel_xy.i, 0.0
    out["MPC_Z_VEL_P_ACC"], out["MPC_Z_VEL_I_ACC"], out["MPC_Z_VEL_D_ACC"] = d.vel_z.p, d.vel_z.i, 0.0
    return {k: float(f"{v:.3g}") for k, v in out.items()}


def report(spec: VehicleSpec, d: Design) -> str:
    """The printed table: per loop its gains, crossover, margins and closed-loop bandwidth; the steps."""
    lines = [
        f"{spec.name}: rate plants (effectiveness, motor lag ms): "
        + ", ".join(f"{a.lower()} {p.effectiveness:.3f} {p.motor_tau_s * 1e3:.1f}" for a, p in zip(AXES, d.plants))
        + f"; vertical {d.z_gain:.3f}",
        f"{'loop':<14}{'P':>8}{'I':>9}{'D':>7}{'cross Hz':>10}{'GM dB':>8}{'PM deg':>8}{'BW Hz':>8}{'inner/BW':>9}",
    ]
    for a, g, m, bw in zip(AXES, d.rate, d.rate_margins, d.rate_bw_hz):
        lines.append(_row(f"{a.lower()} rate", g.p, g.i, g.d, m, bw, math.nan))
    for loop in (*d.attitude, d.vel_xy, d.pos_xy, d.vel_z, d.pos_z):
        lines.append(_row(loop.name, loop.p, loop.i, 0.0, loop.margins, loop.bandwidth_hz, loop.inner_bandwidth_hz))
    for name, s in (("horizontal", d.step_xy), ("vertical (up)", d.step_z)):
        settle = "never" if math.isnan(s.settle_s) else f"{s.settle_s:.2f} s"
        lines.append(
            f"predicted {s.step_m:g} m step, {name}, feedback only: rise {s.rise_s:.2f} s, "
            f"overshoot {s.overshoot_pct:.1f} %, settle to 0.1 m {settle}"
        )
    return "\n".join(lines)


def _row(name: str, p: float, i: float, dd: float, m: Margins, bw: float, inner: float) -> str:
    ratio = "" if math.isnan(inner) else f"{inner / bw:.1f}"
    return (
        f"{name:<14}{p:>8.3g}{i:>9.3g}{dd:>7.3g}{m.crossover_hz:>10.2f}{m.gain_margin_db:>8.1f}"
        f"{m.phase_margin_deg:>8.1f}{bw:>8.2f}{ratio:>9}"
    )


def params_text(spec: VehicleSpec, values: dict[str, float], args: argparse.Namespace) -> str:
    """The gains as a QGroundControl .params block between the BEGIN/END markers."""
    head = (
        f"{BEGIN} (sitl/gain_design.py: `design-gains {spec.name}`; phase margin {args.phase_margin:g} deg, "
        f"bandwidth ratio {args.ratio:g}; rewritten by --update, edit the design rather than these lines)\n"
    )
    body = format_qgc([ParamEntry(k, v, REAL32) for k, v in values.items()])
    body = "\n".join(line for line in body.splitlines() if not line.startswith("#")) + "\n"
    return head + body + END + "\n"


def update_file(path: Path, block: str) -> None:
    """Replace the marked block of ``path`` (or append it); the rest of the file is kept as it was."""
    text = path.read_text() if path.exists() else ""
    lines = text.splitlines(keepends=True)
    start = next((k for k, line in enumerate(lines) if line.startswith(BEGIN)), None)
    end = next((k for k, line in enumerate(lines) if line.startswith(END)), None)
    if start is not None and end is not None and end > start:
        text = "".join(lines[:start]) + block + "".join(lines[end + 1 :])
    else:
        text = text + ("" if text.endswith("\n") or not text else "\n") + block
    atomic_write_text(path, text)


def build_parser() -> argparse.ArgumentParser:
    ap = argparse.ArgumentParser(prog="design-gains", description=__doc__.split("\n\n")[0])
    ap.add_argument("vehicle", type=vehicle_argument, help="vehicle name in params/vehicles or a .toml path")
    ap.add_argument("--out", type=Path, help="write the gains to this .params file (QGroundControl's format)")
    ap.add_argument("--update", action="store_true", help="rewrite the design-gains block of the vehicle's .params")
    ap.add_argument(
        "--phase-margin", type=lambda s: number_in(s, 30, 80, "--phase-margin"), default=45.0, help="deg, rate loop"
    )
    ap.add_argument(
        "--ratio", type=lambda s: number_in(s, 2, 10, "--ratio"), default=4.0, help="inner / outer bandwidth"
    )
    ap.add_argument("--gyro-cutoff", type=positive_number, default=30.0, help="IMU_GYRO_CUTOFF the FC flies with, Hz")
    ap.add_argument("--vel-max", type=positive_number, default=5.0, help="MPC_XY_VEL_MAX, m/s (predicted step)")
    ap.add_argument("--vel-up", type=positive_number, default=3.0, help="MPC_Z_VEL_MAX_UP, m/s (predicted step)")
    ap.add_argument("--tilt-max", type=lambda s: number_in(s, 5, 89, "--tilt-max"), default=35.0, help="deg")
    ap.add_argument("--rate-max", type=positive_number, default=220.0, help="MC_ROLLRATE_MAX, deg/s")
    return ap


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    spec = load_vehicle(args.vehicle)
    d = design(spec, args)
    print(report(spec, d))
    block = params_text(spec, gains_table(d), args)
    if args.out is not None:
        atomic_write_text(args.out, f"# Gains designed for {spec.name} (design-gains)\n" + block)
        print(f"wrote {args.out}")
    if args.update:
        path = vehicle_path(args.vehicle).with_suffix(".params")
        update_file(path, block)
        print(f"updated {path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
