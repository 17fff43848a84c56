"""Benchmark: heading changes in a hover and after a translation, both vehicles: overshoot and settling time.

For each vehicle (``quad_x``, ``firefly``) one stack runs (``--speed max``, lockstep, the simulator's
default sensor errors), flown through the simulator's holds (gcs/launcher/sim_stepper.py: the same
``--seed`` gives the same figures whatever the machine's load):

1. take off to 5 m and settle;
2. heading steps in the hover (``--steps``, degrees from the heading held: the default 90, -90, 150,
   -150), each a MAV_CMD_DO_REPOSITION with NaN position and altitude and only a new yaw, as MAVSDK's
   ``goto_location`` keeps the point and QGroundControl's heading control sends it;
3. a go-to right after a translation: 10 m North (heading kept) and, on arrival, 10 m East with a
   heading 90 degrees to the right (DO_REPOSITION with a position and a yaw).

Each is watched ``--window`` simulated seconds after the turn at MPC_YAWRAUTO_MAX would end, on the
simulator's true heading (HIL_STATE_QUATERNION at 50 Hz): the overshoot past the commanded heading
(degrees), the settling time from the command until the heading stays within 3 degrees of it, and that
time minus the ideal turn time (the turn at MPC_YAWRAUTO_MAX, PX4's yaw rate of automatic modes).
Issue 36's target: overshoot <= 3 degrees and settled <= 1 s after the ideal turn has ended.  ``plan``
is the turn the flight controller plans when it also limits the yaw acceleration (MPC_YAWRAUTO_ACC,
where the flight controller has it): speeding up and slowing down add MPC_YAWRAUTO_MAX / _ACC.  ``tilt``
and ``sink``: the most the vehicle tilted, and sank below its height at the command, meanwhile (from the
truth: a heading change should neither rock it nor lose height).

Usage: ``python benchmarks/heading_benchmark.py [--vehicles quad_x firefly] [--steps 90 -90 150 -150] [--seed N]
[-i N] [--window S] [--fc-param NAME=VALUE] [--keep-logs DIR]``
"""

from __future__ import annotations

import dataclasses
import math
import sys
import tempfile
from dataclasses import dataclass
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parents[1]))

from gcs.client import VehicleClient, mavlink  # noqa: E402
from gcs.launcher import Stack  # noqa: E402
from gcs.launcher.sim_stepper import SimStepper  # noqa: E402
from gcs.sim_client import SimClient  # noqa: E402
from mavsim_core import ports  # noqa: E402

from _cli import add_instance, parser  # noqa: E402
from _progress import Progress  # noqa: E402

ALT_M = 5.0
LEG_M = 10.0  # the translation before the go-to, and the go-to's own leg, m
SETTLE_BAND_DEG = 3.0
RATE_SPAN_S = 0.1  # the peak rate is the fastest mean rate over this much simulated time
OVERSHOOT_MAX_DEG, LATE_MAX_S = 3.0, 1.0  # issue 36's target
START_HOLD_MS = 100
WAIT_S = 120.0  # wall seconds of any one wait (a safety net)
NAN = math.nan


@dataclass(frozen=True)
class Step:
    """One heading change's figures (degrees, seconds of simulated time)."""

    name: str
    turn_deg: float  # signed: positive clockwise seen from above
    overshoot_deg: float  # how far past the commanded heading the vehicle went (0: never past it)
    settle_s: float  # from the command until the heading stays within SETTLE_BAND_DEG (NaN: not in the window)
    ideal_s: float  # the turn at MPC_YAWRAUTO_MAX
    peak_rate_deg_s: float  # the fastest the true heading turned
    plan_s: float = NAN  # the turn at MPC_YAWRAUTO_MAX speeding up and slowing down at MPC_YAWRAUTO_ACC
    tilt_max_deg: float = NAN  # the most the vehicle tilted meanwhile (a heading change should not rock it)
    sink_m: float = NAN  # the most it sank below its height at the command

    @property
    def late_s(self) -> float:
        return self.settle_s - self.ideal_s

    @property
    def ok(self) -> bool:
        return self.overshoot_deg <= OVERSHOOT_MAX_DEG and self.late_s <= LATE_MAX_S  # (NaN: False)


def wrap_deg(a: float) -> float:
    return (a + 180.0) % 360.0 - 180.0


def tilt_deg(state) -> float:
    """The true tilt of a HIL_STATE_QUATERNION (body down axis from the vertical), degrees."""
    _, x, y, _ = state.attitude_quaternion
    return math.degrees(math.acos(max(-1.0, min(1.0, 1.0 - 2.0 * (x * x + y * y)))))


def yaw_deg(state) -> float:
    """The true heading of a HIL_STATE_QUATERNION, degrees from north."""
    w, x, y, z = state.attitude_quaternion
    return math.degrees(math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z)))


def plan_s(turn_deg: float, rate_deg_s: float, acc_deg_s2: float) -> float:
    """How long a turn of ``turn_deg`` takes at most ``rate_deg_s``, speeding up and slowing down at ``acc_deg_s2``
    (NaN: no acceleration limit known)."""
    turn = abs(turn_deg)
    if turn >= rate_deg_s * rate_deg_s / acc_deg_s2:
        return turn / rate_deg_s + rate_deg_s / acc_deg_s2
    return 2.0 * math.sqrt(turn / acc_deg_s2)


def score(
    name: str,
    times_s: list[float],
    yaws_deg: list[float],
    target_deg: float,
    turn_deg: float,
    rate_deg_s: float,
    acc_deg_s2: float = NAN,
) -> Step:
    """A step's figures from the true heading sampled at ``times_s`` (seconds since the command)."""
    sign = 1.0 if turn_deg >= 0 else -1.0
    errs = [wrap_deg(y - target_deg) for y in yaws_deg]  # heading minus the commanded one
    overshoot = max([0.0] + [sign * e for e in errs])
    settle = NAN
    for t, e in zip(reversed(times_s), reversed(errs)):
        if abs(e) > SETTLE_BAND_DEG:
            break
        settle = t
    rates, k = [], 0  # over spans of at least RATE_SPAN_S (the holds add samples milliseconds apart)
    for j, t in enumerate(times_s):
        if t - times_s[k] >= RATE_SPAN_S:
            rates.append(abs(wrap_deg(yaws_deg[j] - yaws_deg[k])) / (t - times_s[k]))
            k = j
    ideal, plan = abs(turn_deg) / rate_deg_s, plan_s(turn_deg, rate_deg_s, acc_deg_s2)
    return Step(name, turn_deg, overshoot, settle, ideal, max(rates, default=NAN), plan)


class Flight:
    """One vehicle's stack, flown through holds."""

    def __init__(self, client: VehicleClient, truth: SimClient, stepper: SimStepper, window_s: float) -> None:
        self.client, self.truth, self.step, self.window_s = client, truth, stepper, window_s
        self.rate_deg_s, self.acc_deg_s2 = NAN, NAN  # MPC_YAWRAUTO_MAX and _ACC, read after the take-off

    def take_off(self) -> None:
        c, step = self.client, self.step
        step.run_until(lambda: c.prearm_ok() and c.home() is not None and not c.armed(), 120, "ready to arm", 0.5)
        c.arm(timeout_s=10).check()
        c.takeoff(c.home().alt_amsl_m + ALT_M, timeout_s=10).check()
        step.run_until(lambda: c.mode_name() == "LOITER" and c.takeoff_done(ALT_M), 60, "take-off")
        step.advance(5.0)
        self.rate_deg_s = float(c.param_get("MPC_YAWRAUTO_MAX"))
        try:
            self.acc_deg_s2 = float(c.param_get("MPC_YAWRAUTO_ACC", timeout_s=3.0))
        except Exception:  # noqa: BLE001 - a flight controller from before the acceleration limit
            self.acc_deg_s2 = NAN

    def heading_now(self) -> float:
        return yaw_deg(self.truth.state_at(self.step.time_ms, within_ms=20))

    def watch(self, name: str, target_deg: float, turn_deg: float) -> Step:
        """The true heading from now (the command just acknowledged) for the ideal turn plus the window."""
        t0 = self.step.time_ms
        self.step.advance(abs(turn_deg) / self.rate_deg_s + self.window_s)
        ms = sorted(t for t in list(self.truth.states) if t0 <= t <= self.step.time_ms)
        yaws = [yaw_deg(self.truth.states[t]) for t in ms]
        times = [(t - t0) / 1000.0 for t in ms]
        step = score(name, times, yaws, target_deg, turn_deg, self.rate_deg_s, self.acc_deg_s2)
        tilt = max(tilt_deg(self.truth.states[t]) for t in ms)
        downs = [s.pos_ned_m[2] for s in self.truth.since(t0) if s.time_ms <= self.step.time_ms]
        return dataclasses.replace(step, tilt_max_deg=tilt, sink_m=max(downs) - downs[0])

    def heading_step(self, turn_deg: float) -> Step:
        """DO_REPOSITION with NaN position and altitude and a yaw ``turn_deg`` from the heading held."""
        target = wrap_deg(self.heading_now() + turn_deg)
        self.client.command_long(
            mavlink.MAV_CMD_DO_REPOSITION, -1, mavlink.MAV_DO_REPOSITION_FLAGS_CHANGE_MODE, 0,
            math.radians(target), NAN, NAN, NAN, timeout_s=10,
        ).check()  # fmt: skip
        return self.watch(f"hover {turn_deg:+.0f}", target, turn_deg)

    def goto_after_translation(self) -> Step:
        """10 m North with the heading kept, then at once 10 m East turning 90 degrees right."""
        c, step = self.client, self.step
        c.goto_ned(LEG_M, 0.0, -ALT_M, timeout_s=10).check()
        step.run_until(lambda: c.arrived(LEG_M, 0.0, 0.3, 0.3), 60, "the translation's end")
        target = wrap_deg(self.heading_now() + 90.0)
        c.goto_ned(LEG_M, LEG_M, -ALT_M, yaw_deg=target, timeout_s=10).check()
        return self.watch("goto +90 after 10 m", target, 90.0)


def fly(vehicle: str, args, fc_args: list[str], progress: Progress) -> tuple[list[Step], float, float]:
    """The vehicle's steps, and its MPC_YAWRAUTO_MAX (deg/s) and MPC_YAWRAUTO_ACC (deg/s^2; NaN: none)."""
    sim_args = ["--param", f"SIM_HOLD_MS={START_HOLD_MS}"]
    log_dir = args.keep_logs / vehicle if args.keep_logs else None
    with (
        SimClient(ports.sim_component_port(args.instance)) as truth,
        Stack(
            args.instance, "max", vehicle, sim_args, [*fc_args, "--input-clock", "sim"], seed=args.seed,
            flight_logs=log_dir is not None, log_dir=log_dir,
        ) as stack,
        VehicleClient(stack.gcs_url, timeout_s=WAIT_S, idle=stack.check_alive) as client,
    ):  # fmt: skip
        stepper = SimStepper(client, truth, timeout_s=WAIT_S)
        stepper.start()
        f = Flight(client, truth, stepper, args.window)
        progress.phase("take-off")
        f.take_off()
        steps = []
        for turn in args.steps:
            progress.done(phase=f"heading {turn:+g}")
            steps.append(f.heading_step(turn))
        progress.done(phase="go-to after a translation")
        steps.append(f.goto_after_translation())
        progress.done()
        return steps, f.rate_deg_s, f.acc_deg_s2


def late_text(s: Step) -> str:
    return "never" if math.isnan(s.settle_s) else f"{s.late_s:+.2f}s"


def seconds(x: float) -> str:
    return "-" if math.isnan(x) else f"{x:.2f}s"


def main(argv: list[str] | None = None) -> int:
    ap = parser(__doc__)
    ap.add_argument(
        "--vehicles", nargs="+", default=["quad_x", "firefly"], help="vehicle file names (params/vehicles/) or paths"
    )
    ap.add_argument(
        "--steps", nargs="+", type=float, default=[90.0, -90.0, 150.0, -150.0],
        help="heading steps in the hover, degrees (positive: clockwise seen from above)",
    )  # fmt: skip
    add_instance(ap, 23)
    ap.add_argument("--seed", type=int, default=0, help="simulator seed (sensor noise)")
    ap.add_argument("--window", type=float, default=8.0, help="simulated seconds watched after the ideal turn's end")
    ap.add_argument(
        "--fc-param", action="append", default=[], metavar="NAME=VALUE",
        help="a flight-controller parameter from the start (e.g. MPC_YAWRAUTO_MAX=60), repeatable",
    )  # fmt: skip
    ap.add_argument("--keep-logs", type=Path, metavar="DIR", help="keep each flight's logs (.ulg, .tlog ...) here")
    args = ap.parse_args(argv)
    if args.keep_logs:
        args.keep_logs = args.keep_logs.resolve()
    results: dict[str, tuple[list[Step], float, float] | str] = {}
    with tempfile.TemporaryDirectory(prefix="heading-benchmark-") as tmp:
        fc_args: list[str] = []
        if args.fc_param:
            path = Path(tmp) / "benchmark.params"
            path.write_text("".join(p.replace("=", " ", 1) + "\n" for p in args.fc_param))
            fc_args = ["--params", str(path)]
        with Progress(len(args.vehicles) * (len(args.steps) + 2), "step") as progress:
            for vehicle in args.vehicles:
                progress.label(vehicle)
                try:
                    results[vehicle] = fly(vehicle, args, fc_args, progress)
                except Exception as exc:  # noqa: BLE001 - reported in the table, the other vehicle still flies
                    results[vehicle] = f"{type(exc).__name__}: {exc}"
    if args.fc_param:
        print("settings: " + " ".join(args.fc_param))
    print(
        f"true heading (50 Hz) after each command; settle = until within {SETTLE_BAND_DEG:g} deg for good; "
        f"late = settle - ideal turn at MPC_YAWRAUTO_MAX; target: overshoot <= {OVERSHOOT_MAX_DEG:g} deg, "
        f"late <= {LATE_MAX_S:g} s"
    )
    print(
        f"{'vehicle':9} {'step':20} {'overshoot':>9} {'settle':>7} {'ideal':>6} {'late':>7} {'plan':>6} "
        f"{'peak rate':>10} {'tilt':>5} {'sink':>6}  ok"
    )
    ok = True
    for vehicle, result in results.items():
        if isinstance(result, str):
            print(f"{vehicle:9} FAILED: {result}")
            ok = False
            continue
        steps, rate, acc = result
        for s in steps:
            ok = ok and s.ok
            settle = "never" if math.isnan(s.settle_s) else seconds(s.settle_s)
            print(
                f"{vehicle:9} {s.name:20} {s.overshoot_deg:7.1f}deg {settle:>7} "
                f"{s.ideal_s:5.2f}s {late_text(s):>7} {seconds(s.plan_s):>6} {s.peak_rate_deg_s:6.0f}deg/s "
                f"{s.tilt_max_deg:4.0f}d {s.sink_m:5.2f}m  "
                f"{'yes' if s.ok else 'NO'}"
            )
        acc_text = "none" if math.isnan(acc) else f"{acc:g} deg/s^2"
        print(f"{vehicle:9} MPC_YAWRAUTO_MAX {rate:g} deg/s, MPC_YAWRAUTO_ACC {acc_text}")
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
