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

Reproducible (the default): the simulator starts held (``SIM_HOLD_MS`` = :data:`START_HOLD_MS`) and the
flight is driven through holds (:class:`gcs.launcher.sim_stepper.SimStepper`): commands and wind go while
held, conditions (ready, take-off done, back, landed) are read at a hold every 0.1 s of simulated time
(0.5 s while getting ready) within ``*_SIM_S`` simulated seconds, and the settles, hovers and the step's
window fly in ``SLICE_S`` (1 s) slices, their samples those up to the hold.  The same seed gives the same
figures to the last digit, whatever the machine's load; wall seconds (``WAIT_S``) only bound each wait.
``[sim_params] SIM_HOLD_MS = 0`` runs the simulator free: the flight acts when the telemetry arrives,
with the same phases and limits in wall seconds, and its figures depend on the machine's load.

Errors are truth (the simulator's LOCAL_POSITION_NED, NED metres from the start point) minus the
setpoint; ``*_ctrl_*`` is the flight controller's own tracking, its estimate minus its setpoint (its
LOCAL_POSITION_NED, NED metres from its home).  Real-time factors (wall-clock, so never reproducible):
simulated / wall seconds over the windy hover (every effect on) and over the whole flight (arming to the
disarm); flown through holds they include the holds' round trips.

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
from typing import Any, Callable, Protocol

import numpy as np

import params as params_package
from gcs.client import VehicleClient
from gcs.launcher.sim_stepper import HOLD_PARAM, SimStepper
from gcs.sim_client import SimClient, TruthSample

from .kinds import Axis, Range, grid_cells, number_in, vehicle_name
from .plan import Run

ALT_M = 5.0
STEP_M = 10.0
STEP_WINDOW_S = 25.0
SETTLE_BAND_M = 0.1
CALM_SETTLE_S, WIND_SETTLE_S = 5.0, 10.0
WAIT_S = 120.0  # wall seconds of one wait of the free-running flight (ready to arm, take-off ...): a safety net
STEP_WAIT_S = 60.0  # wall seconds of one wait of the held flight (a hold, an answer): a safety net
START_HOLD_MS = 100  # a reproducible run: the simulator holds from t = 0.1 s until the flight moves the hold
SLICE_S = 1.0  # settles, hovers and the step's window go on in slices of this many simulated seconds
READY_CHECK_EVERY_S = 0.5  # simulated seconds between checks while waiting to be ready to arm
READY_SIM_S, TAKEOFF_SIM_S, BACK_SIM_S, LAND_SIM_S = 60.0, 60.0, 60.0, 120.0  # phases' limits, simulated s
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


def sim_parameters(fault: str, campaign: dict[str, float]) -> dict[str, float]:
    """The simulator's ``SIM_*`` parameters at start: held at :data:`START_HOLD_MS` (reproducible), the
    ``fault``'s, then the campaign's ``[sim_params]`` (``SIM_HOLD_MS = 0`` there: run free)."""
    return {HOLD_PARAM: START_HOLD_MS, **fault_parameters(fault), **campaign}


def stepped(sim: dict[str, float]) -> bool:
    """Flown through holds: the simulator starts held (``SIM_HOLD_MS`` above 0 in ``sim``)."""
    return sim.get(HOLD_PARAM, 0) > 0


class Clock(Protocol):
    """How the flight moves through simulated time: :class:`~gcs.launcher.sim_stepper.SimStepper` (through holds)
    or :class:`WallClock` (a free-running simulator).  Times: simulated ms / s."""

    client: VehicleClient
    truth: SimClient

    @property
    def time_ms(self) -> int: ...

    def start(self) -> None: ...

    def advance(self, sim_s: float) -> None: ...

    def run_until(
        self, predicate: Callable[[], object], max_sim_s: float, what: str, check_every_s: float = ...
    ) -> Any: ...

    def release(self, run_free: bool = True) -> None: ...


class WallClock:
    """A free-running simulator (``SIM_HOLD_MS`` 0) behind :class:`SimStepper`'s calls: each waits in wall time
    (``WAIT_S``, its simulated-time limits unused) while the telemetry arrives, so its results vary with the
    machine's load.  The simulated time is the latest truth's."""

    def __init__(self, client: VehicleClient, truth: SimClient) -> None:
        self.client, self.truth = client, truth

    @property
    def time_ms(self) -> int:
        """The latest truth sample's simulated time, ms (0 before the first)."""
        latest = self.truth.latest()
        return 0 if latest is None else latest.time_ms

    def start(self) -> None:
        """Wait for the simulator's first truth sample."""
        self.truth.wait_connected(WAIT_S)
        self.client.wait_until(lambda: self.truth.latest() is not None, WAIT_S, "the simulator's truth")

    def advance(self, sim_s: float) -> None:
        """Receive until the truth is ``sim_s`` simulated seconds later."""
        end_ms = self.time_ms + round(sim_s * 1000)
        self.client.wait_until(lambda: self.time_ms >= end_ms, WAIT_S, f"{sim_s:g} s of simulated time")

    def run_until(
        self, predicate: Callable[[], object], max_sim_s: float, what: str, check_every_s: float = 0.0
    ) -> Any:
        """Receive until ``predicate()`` is truthy (``WAIT_S`` wall seconds; ``max_sim_s`` unused); its value."""
        return self.client.wait_until(predicate, WAIT_S, what)

    def release(self, run_free: bool = True) -> None:
        """Nothing to release."""


def fly_for(clock: Clock, sim_s: float) -> int:
    """Let ``sim_s`` simulated seconds pass, in slices of at most ``SLICE_S``; the end time, simulated ms."""
    end_ms = clock.time_ms + round(sim_s * 1000)
    while clock.time_ms < end_ms:
        clock.advance(min(SLICE_S, (end_ms - clock.time_ms) / 1000.0))
    return end_ms


def truth_at(truth: SimClient, time_ms: int) -> TruthSample:
    """The truth sample at exactly ``time_ms`` (simulated ms); RuntimeError if it never arrived."""
    sample = truth.at(time_ms, within_ms=0)
    if sample is None:
        raise RuntimeError(f"no truth at t = {time_ms / 1000:g} s")
    return sample


def truth_window(truth: SimClient, t0_ms: int, end_ms: int) -> list[TruthSample]:
    """The truth samples from ``t0_ms`` to ``end_ms`` (simulated ms, both included), in time order."""
    return [s for s in truth.since(t0_ms) if s.time_ms <= end_ms]


def rms(a) -> float:
    a = np.asarray(a, dtype=float)
    return float(np.sqrt(np.mean(a * a))) if len(a) else math.nan


def hover_errors(clock: Clock, target: np.ndarray, seconds: float, target_est: np.ndarray):
    """Over ``seconds`` of simulated time from now: truth minus ``target`` (N x 3, NED m), the real-time factor
    (simulated / wall seconds), and the flight controller's own tracking error (its estimate minus
    ``target_est``, its frame; M x 3, the LOCAL_POSITION_NED it sent meanwhile)."""
    t0 = clock.time_ms
    est: list[tuple[float, float, float]] = []

    def listener(m) -> None:
        if m.get_type() == "LOCAL_POSITION_NED":
            est.append((m.x, m.y, m.z))

    clock.client.add_listener(listener)
    wall0 = time.monotonic()
    try:
        end_ms = fly_for(clock, seconds)
    finally:
        clock.client.remove_listener(listener)
    wall = time.monotonic() - wall0
    samples = truth_window(clock.truth, t0, end_ms)
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


def step_response(clock: Clock, hold: np.ndarray, hold_local: np.ndarray) -> dict[str, float]:
    """Command a ``STEP_M`` North step from the hold point and score the North response over ``STEP_WINDOW_S``
    (simulated s): the truth's, from where it was when the step was commanded, and (``step_ctrl_*``) the flight
    controller's own estimate's against the point it was sent.  ``hold``: m NED from home (the frame of
    ``goto_ned``); ``hold_local``: the same point in the flight controller's LOCAL_POSITION_NED frame (from its
    estimator's origin, which is not home)."""
    client, truth = clock.client, clock.truth
    t0 = clock.time_ms
    north0 = truth_at(truth, t0).pos_ned_m[0]
    start_est = client.latest("LOCAL_POSITION_NED")
    est: list[tuple[float, float]] = []

    def listener(m) -> None:
        if m.get_type() == "LOCAL_POSITION_NED":
            est.append(((m.time_boot_ms - start_est.time_boot_ms) / 1000.0, m.x - start_est.x))

    step_m = hold_local[0] + STEP_M - start_est.x  # what the vehicle has to fly, by its estimate
    client.add_listener(listener)
    try:
        client.goto_ned(hold[0] + STEP_M, hold[1], hold[2]).check()
        end_ms = fly_for(clock, STEP_WINDOW_S)
    finally:
        client.remove_listener(listener)
    s = truth_window(truth, t0, end_ms)
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


def fly_hover_step(
    client: VehicleClient, truth: SimClient, hover_s: float, wind_m_s: float, held: bool = True
) -> dict[str, Any]:
    """The flight of the module docstring on a started stack; its figures.  ``held``: the simulator was started
    held (``SIM_HOLD_MS``; :func:`stepped`) and the flight goes through holds; else it waits in wall time."""
    clock: Clock = SimStepper(client, truth, timeout_s=STEP_WAIT_S) if held else WallClock(client, truth)
    clock.start()
    try:
        ready = lambda: client.prearm_ok() and client.home() is not None  # noqa: E731
        clock.run_until(ready, READY_SIM_S, "ready to arm", check_every_s=READY_CHECK_EVERY_S)
        return _fly(clock, hover_s, wind_m_s)
    finally:
        clock.release(run_free=False)  # held until the stack stops: nothing left to simulate


def _home_altitude(client: VehicleClient) -> float:
    """Home's altitude, m AMSL (the ready-to-arm condition waited for home)."""
    home = client.home()
    if home is None:
        raise RuntimeError("no home position")
    return home.alt_amsl_m


def _fly(clock: Clock, hover_s: float, wind_m_s: float) -> dict[str, Any]:
    """:func:`fly_hover_step` from ready to arm to the disarm."""
    client, truth = clock.client, clock.truth
    start = np.array(truth_at(truth, clock.time_ms).pos_ned_m)
    wall0, sim0_ms = time.monotonic(), clock.time_ms
    takeoff_amsl_m = _home_altitude(client) + ALT_M
    client.arm().check()
    client.takeoff(takeoff_amsl_m).check()
    clock.run_until(lambda: client.takeoff_done(ALT_M), TAKEOFF_SIM_S, f"take-off to {ALT_M:g} m")
    fly_for(clock, CALM_SETTLE_S)
    hold = np.array([0.0, 0.0, -ALT_M])  # where the take-off holds: m NED from home, the frame of goto_ned
    target = start + hold  # truth's frame: from the start point
    # The estimator's home is where it armed, in its LOCAL_POSITION_NED frame (from its origin, the first
    # GPS fix): tenths of a metre from the origin as the GPS error wanders.  Commands are relative to home.
    home = client.latest("HOME_POSITION")
    hold_local = np.array([home.x, home.y, home.z]) + hold
    err, _, ctrl = hover_errors(clock, target, hover_s, hold_local)
    out: dict[str, Any] = _hover("calm", err, ctrl)
    out.update(step_response(clock, hold, hold_local))
    client.goto_ned(*hold).check()
    clock.run_until(lambda: client.arrived(hold[0], hold[1], 0.3, 0.3), BACK_SIM_S, "back")
    for name, value in windy_parameters(wind_m_s).items():
        truth.set(name, value)
    fly_for(clock, WIND_SETTLE_S)
    err, rtf_wind, ctrl = hover_errors(clock, target, hover_s, hold_local)
    out.update(_hover("wind", err, ctrl), rtf_wind=rtf_wind)
    client.land().check()
    clock.run_until(client.landed_and_disarmed, LAND_SIM_S, "landed and disarmed")
    out["sim_s"] = (clock.time_ms - sim0_ms) / 1000.0
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
        """One flight on the run's own stack (``ctx``: :class:`campaign.runs.RunContext`), started held
        unless the campaign's ``[sim_params]`` say ``SIM_HOLD_MS = 0`` (:func:`sim_parameters`)."""
        from mavsim_core import ports

        sim = sim_parameters(run.axes["fault"], ctx.settings.sim_params)
        stack = ctx.stack(run.axes["vehicle"], int(run.draws["sim_seed"]), sim_args(sim))
        stack.start()
        with SimClient(ports.sim_component_port(ctx.instance)) as truth:
            client = ctx.client(timeout_s=60.0)
            hover_s, wind_m_s = float(run.axes["hover_s"]), float(run.axes["wind_m_s"])
            return fly_hover_step(client, truth, hover_s, wind_m_s, held=stepped(sim))


def sim_args(params: dict[str, float]) -> list[str]:
    """``sitl --param NAME=VALUE`` arguments of ``params``."""
    return [a for name, value in params.items() for a in ("--param", f"{name}={value:g}")]


KIND = HoverStepKind()
