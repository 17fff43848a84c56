"""Campaign kind ``hover_step``: hover in calm air, a 10 m step North and back, hover in wind; scored from truth.

One run is one stack (``--speed max``, lockstep, the simulator's default sensor errors: IMU noise and
bias walk, GPS at 5 Hz with 120 ms latency and a wandering error) flying:

1. take off to ``ALT_M`` (5 m), settle 5 simulated seconds, hover ``hover_s`` simulated seconds in
   calm air;
2. a ``STEP_M`` (10 m) position step North (MAV_CMD_DO_REPOSITION: the navigator's trajectory to the
   new point, as a ground station's "go to" flies it), watched for ``STEP_WINDOW_S`` (25 s): rise
   time 10-90 %, overshoot, settling time (the 1 s moving average of the truth stays within
   ``SETTLE_BAND_M``, 0.1 m, of the target: NaN when it never does), the final error;
3. back to the start point, then the wind turned on (``SIM_*`` parameters over the simulator's
   MAVLink port: ``wind_m_s`` from the West, the windy scenario's turbulence and gusts scaled by
   ``wind_m_s`` / 5 m/s, so 5 is exactly ``sitl --scenario windy``), settle 10 s, hover ``hover_s``;
4. land and disarm.

Errors are truth (the simulator's LOCAL_POSITION_NED, NED metres from the start point) minus the
setpoint; ``*_ctrl_*`` is the flight controller's own tracking, its estimate minus its setpoint (its
LOCAL_POSITION_NED, NED metres from its home).  Real-time factors: simulated / wall seconds over the
windy hover (every effect on) and over the whole flight (arming to the disarm).

Grid axes: ``vehicle``, ``wind_m_s`` (0-15 m/s), ``fault`` (``none``, or ``motorN_P``: motor N at P %
thrust from the start: ``SIM_ENGINE_FAIL``/``SIM_ENGINE_MUL``), ``hover_s`` (each hover, simulated
seconds).  Cells in that order.  Randomised: ``sim_seed`` (``sitl --seed``: sensor noise, turbulence,
gusts).  A run succeeds when it flies every phase and lands; the figures say how well.
"""

from __future__ import annotations

import math
import re
import time
import tomllib
from pathlib import Path
from typing import Any

import numpy as np

import params as params_package

from ..client import VehicleClient
from ..sim_client import SimClient
from .kinds import Axis, Range, grid_cells, number_in, vehicle_name
from .plan import Run

ALT_M = 5.0
STEP_M = 10.0
STEP_WINDOW_S = 25.0
SETTLE_BAND_M = 0.1
CALM_SETTLE_S, WIND_SETTLE_S = 5.0, 10.0
WAIT_S = 120.0  # wall seconds of one wait (ready to arm, take-off, back, landing): a safety net
WIND_REF_M_S = 5.0  # the windy scenario's steady wind, which its turbulence and gusts go with
FAULT = re.compile(r"^motor([1-9])_(\d{1,3})$")


def windy_parameters(speed_m_s: float = WIND_REF_M_S) -> dict[str, float]:
    """params/scenarios/windy.toml's wind (``SIM_*``), its speeds scaled to ``speed_m_s`` from the West."""
    path = Path(params_package.__file__).resolve().parent / "scenarios" / "windy.toml"
    p = dict(tomllib.loads(path.read_text())["parameters"])
    scale = speed_m_s / p["SIM_WIND_SPD"]
    for name in ("SIM_WIND_SPD", "SIM_WIND_TURB", "SIM_GUST_SPD"):
        p[name] = float(p[name]) * scale
    return p


def fault_check(v: Any) -> str | None:
    """An axis check: ``none`` or ``motorN_P`` (motor N, 1-9, at P % thrust, 0-100)."""
    m = FAULT.match(v) if isinstance(v, str) else None
    if v == "none" or (m is not None and int(m.group(2)) <= 100):
        return None
    return f"{v!r} is not 'none' nor motorN_P (motor N at P % thrust, e.g. 'motor1_70')"


def fault_parameters(fault: str) -> dict[str, float]:
    """The simulator's ``SIM_*`` parameters of an axis value of ``fault`` (none: {})."""
    m = FAULT.match(fault)
    return {} if m is None else {"SIM_ENGINE_FAIL": int(m.group(1)), "SIM_ENGINE_MUL": int(m.group(2)) / 100.0}


def rms(a) -> float:
    a = np.asarray(a, dtype=float)
    return float(np.sqrt(np.mean(a * a))) if len(a) else math.nan


def hover_errors(truth: SimClient, client: VehicleClient, target: np.ndarray, seconds: float, target_est: np.ndarray):
    """Over ``seconds`` of simulated time: truth minus ``target`` (N x 3, NED m), the real-time factor, and the
    flight controller's own tracking error (its estimate minus ``target_est``, its frame; M x 3)."""
    client.pump(0.05)
    t0 = truth.latest().time_ms
    est: list[tuple[float, float, float]] = []

    def listener(m) -> None:
        if m.get_type() == "LOCAL_POSITION_NED":
            est.append((m.x, m.y, m.z))

    client.add_listener(listener)
    wall0 = time.monotonic()
    while truth.latest().time_ms - t0 < seconds * 1000:
        client.pump(0.05)
    wall = time.monotonic() - wall0
    client.remove_listener(listener)
    samples = [s for s in truth.since(t0) if s.time_ms <= t0 + seconds * 1000]
    err = np.array([np.array(s.pos_ned_m) - target for s in samples]).reshape(-1, 3)
    ctrl = np.array(est) - target_est if est else np.zeros((0, 3))
    return err, seconds / wall, ctrl


def step_figures(t: np.ndarray, north: np.ndarray, step_m: float) -> dict[str, float]:
    """A step's figures from its response: ``t`` s since the command, ``north`` m moved since then.

    Rise: 10 % to 90 % of ``step_m``; overshoot: % beyond it; settle: the time after which the 1 s
    moving average stays within ``SETTLE_BAND_M`` of it (NaN: still outside at the end); final error, m.
    """
    frac = north / step_m
    rise = t[np.argmax(frac >= 0.9)] - t[np.argmax(frac >= 0.1)] if (frac >= 0.9).any() else math.nan
    k = max(1, int(round(1.0 / np.median(np.diff(t))))) if len(t) > 1 else 1
    smooth = np.convolve(north, np.ones(k) / k, mode="same")
    outside = np.abs(smooth - step_m) > SETTLE_BAND_M
    outside[-k // 2 :] = outside[-k // 2 - 1]  # the edge of the window has no full average
    if not outside.any():
        settle = float(t[0])
    elif outside[-1]:
        settle = math.nan
    else:
        settle = float(t[np.nonzero(outside)[0][-1] + 1])
    return {
        "step_rise_s": float(rise),
        "step_overshoot_pct": max(0.0, float((north.max() - step_m) / step_m * 100)),
        "step_settle_s": settle,
        "step_final_err_m": float(abs(north[-1] - step_m)),
    }


def step_response(
    truth: SimClient, client: VehicleClient, hold: np.ndarray, hold_local: np.ndarray
) -> dict[str, float]:
    """Command a ``STEP_M`` North step from the hold point and score the North response over ``STEP_WINDOW_S``:
    the truth's, from where it was when the step was commanded, and (``step_ctrl_*``) the flight controller's
    own estimate's against the point it was sent.  ``hold``: m NED from home (the frame of ``goto_ned``);
    ``hold_local``: the same point in the flight controller's LOCAL_POSITION_NED frame (from its estimator's
    origin, which is not home)."""
    client.pump(0.05)
    t0 = truth.latest().time_ms
    north0 = truth.latest().pos_ned_m[0]
    start_est = client.latest("LOCAL_POSITION_NED")
    est: list[tuple[float, float]] = []

    def listener(m) -> None:
        if m.get_type() == "LOCAL_POSITION_NED":
            est.append(((m.time_boot_ms - start_est.time_boot_ms) / 1000.0, m.x - start_est.x))

    step_m = hold_local[0] + STEP_M - start_est.x  # what the vehicle has to fly, by its estimate
    client.add_listener(listener)
    client.goto_ned(hold[0] + STEP_M, hold[1], hold[2]).check()
    while truth.latest().time_ms - t0 < STEP_WINDOW_S * 1000:
        client.pump(0.05)
    client.remove_listener(listener)
    s = [x for x in truth.since(t0) if x.time_ms <= t0 + STEP_WINDOW_S * 1000]
    t = np.array([x.time_ms - t0 for x in s]) / 1000.0
    out = step_figures(t, np.array([x.pos_ned_m[0] for x in s]) - north0, step_m)
    e = np.array([x for x in est if x[0] <= STEP_WINDOW_S]).reshape(-1, 2)
    own = step_figures(e[:, 0], e[:, 1], step_m)
    out.update({"step_ctrl_settle_s": own["step_settle_s"], "step_ctrl_overshoot_pct": own["step_overshoot_pct"]})
    return out


def _hover(prefix: str, err: np.ndarray, ctrl: np.ndarray) -> dict[str, float]:
    h = np.hypot(err[:, 0], err[:, 1])
    return {
        f"{prefix}_h_rms_m": rms(h),
        f"{prefix}_v_rms_m": rms(err[:, 2]),
        f"{prefix}_ctrl_h_rms_m": rms(np.hypot(ctrl[:, 0], ctrl[:, 1])),
        f"{prefix}_h_max_m": float(h.max()) if len(h) else math.nan,
    }


def fly_hover_step(client: VehicleClient, truth: SimClient, hover_s: float, wind_m_s: float) -> dict[str, Any]:
    """The flight of the module docstring on a started stack, ready to arm; its figures."""
    start = np.array(truth.latest().pos_ned_m)
    wall0, sim0 = time.monotonic(), client.sim_time_s()
    client.arm().check()
    client.takeoff(client.home().alt_amsl_m + ALT_M).check()
    client.wait_until(lambda: client.takeoff_done(ALT_M), WAIT_S, f"take-off to {ALT_M:g} m")
    client.wait_sim_time(CALM_SETTLE_S)
    hold = np.array([0.0, 0.0, -ALT_M])  # where the take-off holds: m NED from home, the frame of goto_ned
    target = start + hold  # truth's frame: from the start point
    # The estimator's home is where it armed, in its LOCAL_POSITION_NED frame (from its origin, the first
    # GPS fix): tenths of a metre from the origin as the GPS error wanders.  Commands are relative to home.
    home = client.latest("HOME_POSITION")
    hold_local = np.array([home.x, home.y, home.z]) + hold
    err, _, ctrl = hover_errors(truth, client, target, hover_s, hold_local)
    out: dict[str, Any] = _hover("calm", err, ctrl)
    out.update(step_response(truth, client, hold, hold_local))
    client.goto_ned(*hold).check()
    client.wait_until(lambda: client.arrived(hold[0], hold[1], 0.3, 0.3), WAIT_S, "back")
    for name, value in windy_parameters(wind_m_s).items():
        truth.set(name, value)
    client.wait_sim_time(WIND_SETTLE_S)
    err, rtf_wind, ctrl = hover_errors(truth, client, target, hover_s, hold_local)
    out.update(_hover("wind", err, ctrl), rtf_wind=rtf_wind)
    client.land().check()
    client.wait_until(client.landed_and_disarmed, WAIT_S + 60, "landed and disarmed")
    out["sim_s"] = client.sim_time_s() - sim0
    out["wall_s"] = time.monotonic() - wall0
    out["real_time_factor"] = out["sim_s"] / out["wall_s"]
    out["success"] = True
    return out


class HoverStepKind:
    """See the module docstring."""

    name = "hover_step"
    axes = (
        Axis("vehicle", ("quad_x", "firefly"), vehicle_name, "vehicle file names"),
        Axis("wind_m_s", (WIND_REF_M_S,), number_in(0.0, 15.0), "wind of the second hover, m/s from the West"),
        Axis("fault", ("none",), fault_check, "none, or motorN_P: motor N at P % thrust from the start"),
        Axis("hover_s", (30.0,), number_in(1.0, 600.0), "each hover, simulated seconds"),
    )
    ranges = (Range("sim_seed", (0, 999_999), True, (0, 2**31 - 1), "simulator seed (sitl --seed)"),)
    figures = (
        "success",
        "calm_h_rms_m",
        "calm_v_rms_m",
        "calm_h_max_m",
        "calm_ctrl_h_rms_m",
        "step_rise_s",
        "step_overshoot_pct",
        "step_settle_s",
        "step_final_err_m",
        "step_ctrl_settle_s",
        "step_ctrl_overshoot_pct",
        "wind_h_rms_m",
        "wind_v_rms_m",
        "wind_h_max_m",
        "wind_ctrl_h_rms_m",
        "rtf_wind",
        "sim_s",
        "wall_s",
        "real_time_factor",
    )
    error_figure = "wind_h_rms_m"
    time_figure = "step_settle_s"
    time_header = "settle"

    def cells(self, grid: dict[str, tuple]) -> list[dict[str, Any]]:
        return grid_cells(grid, ("vehicle", "wind_m_s", "fault", "hover_s"))

    def label(self, cell: dict[str, Any]) -> str:
        fault = "" if cell["fault"] == "none" else f" {cell['fault']}"
        return f"{cell['vehicle']} wind {cell['wind_m_s']:g} m/s{fault} hover {cell['hover_s']:g} s"

    def fly(self, run: Run, ctx) -> dict[str, Any]:
        """One flight on the run's own stack (``ctx``: :class:`gcs.campaign.runs.RunContext`)."""
        from mavsim_core import ports

        sim = {**fault_parameters(run.axes["fault"]), **ctx.settings.sim_params}
        stack = ctx.stack(run.axes["vehicle"], int(run.draws["sim_seed"]), sim_args(sim))
        stack.start()
        with SimClient(ports.sim_component_port(ctx.instance)) as truth:
            client = ctx.client(timeout_s=60.0)
            client.wait_until(client.prearm_ok, WAIT_S, "ready to arm")
            truth.wait_connected()
            return fly_hover_step(client, truth, float(run.axes["hover_s"]), float(run.axes["wind_m_s"]))


def sim_args(params: dict[str, float]) -> list[str]:
    """``sitl --param NAME=VALUE`` arguments of ``params``."""
    return [a for name, value in params.items() for a in ("--param", f"{name}={value:g}")]


KIND = HoverStepKind()
