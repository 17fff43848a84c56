"""Helpers of the end-to-end flight tests (test_e2e_flight.py, test_e2e_flight_own_stacks.py).

Waiting on a :class:`gcs.client.VehicleClient` (wall-clock timeouts only: durations the vehicle
must hold are simulated seconds), recording its messages with their vehicle time, reading its
STATUSTEXTs, and horizontal distances in metres (NED).
"""

from __future__ import annotations

import contextlib
import math
import time
from typing import Iterator, Sequence

from gcs.client import VehicleClient, mavlink
from mavsim_core import ports

WAIT_S = 90.0  # wall seconds before giving up on any one step (a noisy 2-core machine)
# The real-time factor of a stack driven by a client that acts in wall time (MAVSDK, MAVProxy, the ``gcs`` command
# line, a lossy link): such a test waits on its client, not on the simulation, so a stack at full speed would burn
# a core making simulated time nobody reads (the suite is bound by CPU: docs/testing.md), and a client's stall of
# a second is 5 simulated seconds, not 25.  Flights that assert a figure are stepped instead (SteppedFlight).
CLIENT_SPEED = 5
ON_GROUND, IN_AIR, LANDING = (
    mavlink.MAV_LANDED_STATE_ON_GROUND,
    mavlink.MAV_LANDED_STATE_IN_AIR,
    mavlink.MAV_LANDED_STATE_LANDING,
)


class Recorder:
    """Client listener: keeps selected messages with the vehicle time they arrived at."""

    def __init__(self, client: VehicleClient, types: tuple[str, ...]) -> None:
        self.client = client
        self.types = types
        self.msgs: list[tuple[float | None, object]] = []

    def __call__(self, msg) -> None:
        if msg.get_type() in self.types:
            self.msgs.append((self.client.sim_time_s(), msg))

    def __enter__(self) -> "Recorder":
        self.client.add_listener(self)
        return self

    def __exit__(self, *exc) -> None:
        self.client.remove_listener(self)

    def of(self, mtype: str) -> list:
        return [m for _, m in self.msgs if m.get_type() == mtype]


def texts_since(client: VehicleClient, index: int) -> list[str]:
    return [st.text for st in client.statustexts[index:]]


def text_time(client: VehicleClient, index: int, fragment: str) -> float:
    """Vehicle time at which the first STATUSTEXT containing ``fragment`` (after ``index``) arrived."""
    return next(st.sim_time_s for st in client.statustexts[index:] if fragment in st.text)


def truth_after(client: VehicleClient, truth, sim_time_s: float):
    """The first truth sample at or after this vehicle time (waiting for it: on a loaded machine the truth's
    UDP stream lags behind the vehicle's telemetry, so ``truth.latest()`` may still be from before)."""
    t_ms = sim_time_s * 1000.0
    client.wait_until(lambda: bool(truth.since(t_ms)), WAIT_S, f"a truth sample at or after {sim_time_s:.2f} s")
    return truth.since(t_ms)[0]


def wait_text(client: VehicleClient, index: int, fragment: str) -> None:
    client.wait_until(
        lambda: any(fragment in t for t in texts_since(client, index)), WAIT_S, f"a STATUSTEXT containing {fragment!r}"
    )


def arm(client: VehicleClient) -> None:
    client.arm(timeout_s=10).check()
    client.wait_armed(True, WAIT_S)


def wait_hovering(client: VehicleClient, alt_m: float) -> None:
    """Until the take-off is over: mode LOITER, near the altitude, not climbing."""
    client.wait_until(
        lambda: client.mode_name() == "LOITER" and client.takeoff_done(alt_m, 0.5), WAIT_S, f"hover at {alt_m:g} m"
    )


def horizontal(a, b) -> float:
    return math.hypot(a[0] - b[0], a[1] - b[1])


SIM_HOME = (47.397742, 8.545594)  # the simulator's default home: its truth NED is measured from here


def latlon(north_m: float, east_m: float) -> tuple[float, float]:
    """A point north/east of the simulator's home, degrees (spherical Earth: mm over 100 m)."""
    r = 6378137.0
    return (
        SIM_HOME[0] + math.degrees(north_m / r),
        SIM_HOME[1] + math.degrees(east_m / (r * math.cos(math.radians(SIM_HOME[0])))),
    )


def closest_approach(truth, since_ms: int, north: float, east: float) -> float:
    """The closest horizontal approach of the true vehicle (a SimClient) to a point since a time, m."""
    return min(math.hypot(s.pos_ned_m[0] - north, s.pos_ned_m[1] - east) for s in truth.since(since_ms))


async def until(predicate, timeout_s: float, what: str, period_s: float = 0.1) -> None:
    """Await ``predicate()`` (a coroutine function) until it is true; AssertionError after ``timeout_s``."""
    import asyncio

    async def loop():
        while not await predicate():
            await asyncio.sleep(period_s)

    try:
        await asyncio.wait_for(loop(), timeout_s)
    except asyncio.TimeoutError:
        raise AssertionError(f"timed out waiting for {what}") from None


async def wait_armable(tel, timeout_s: float, what: str = "health: position, home, armable") -> None:
    """Wait until MAVSDK's Telemetry ``tel`` reports a global position, a home position and armable."""

    async def ready():
        h = await tel.health()
        return h.is_global_position_ok and h.is_home_position_ok and h.is_armable

    await until(ready, timeout_s, what)


def sim_ms(truth) -> int:
    """The truth stream's latest simulated time, ms (0 before the first sample)."""
    s = truth.latest()
    return s.time_ms if s is not None else 0


async def sim_sleep(truth, seconds: float, timeout_s: float = 120.0) -> int:
    """Wait ``seconds`` of simulated time (truth clock) from now; the truth time at the end, ms.  "Now" is the
    truth once its reader has caught up (``SimClient.caught_up``): on a loaded machine its latest sample can be
    seconds behind the vehicle, and a wait counted from it ended before a command just sent had any effect (a
    flake hunt read a cruise speed of 0.006 m/s "8 s" into a 150 m leg)."""
    import asyncio

    start = await asyncio.get_running_loop().run_in_executor(None, truth.caught_up, timeout_s)
    end = start + round(seconds * 1000)

    async def passed():
        return sim_ms(truth) >= end

    await until(passed, timeout_s, f"{seconds:g} simulated seconds", period_s=0.005)
    return sim_ms(truth)


def truth_yaw(truth) -> float:
    """The vehicle's true heading, rad from north."""
    w, x, y, z = truth.latest_state.attitude_quaternion
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def startup_params_args(params: dict[str, float] | None, tmp_path_factory) -> list[str]:
    """``autopilot --params FILE`` arguments applying ``params`` at start-up (a file in pytest's temp dir)."""
    if not params:
        return []
    path = tmp_path_factory.mktemp("startup-params") / "startup.params"
    path.write_text("".join(f"{name} {value}\n" for name, value in params.items()))
    return ["--params", str(path)]


def truth_and_stack_fixtures(params: dict[str, float] | None = None, flight_logs: bool = False):
    """Module-scoped ``truth`` (the simulator's truth port) and ``stack`` (both processes at CLIENT_SPEED)
    fixtures on the module's free instance (the ``inst`` fixture of conftest.py): ``truth, stack =
    truth_and_stack_fixtures()`` in a test file; ``params``: flight-controller parameters applied at
    start-up (``autopilot --params``); ``flight_logs``: the stack writes its flight logs (.ulg, .tlog,
    .truth.npy), for a file that reads them (off, they cost the stack 5-8 % of its CPU in flight)."""
    import pytest

    from gcs.launcher import Stack
    from gcs.sim_client import SimClient

    @pytest.fixture(scope="module")
    def truth(inst):
        with SimClient(ports.sim_component_port(inst)) as listener:
            yield listener

    @pytest.fixture(scope="module")
    def stack(inst, truth, tmp_path_factory):
        args = startup_params_args(params, tmp_path_factory)
        with Stack(instance=inst, speed=CLIENT_SPEED, extra_autopilot_args=args, flight_logs=flight_logs) as s:
            yield s

    return truth, stack


def sigint_default() -> None:
    """``preexec_fn`` of a command a test stops with Ctrl-C: SIGINT's default action, whatever pytest inherited.
    A shell without job control starts background commands with SIGINT ignored (``nohup bash .ci/run &``), an
    ignored signal stays ignored across exec, and Python then installs no KeyboardInterrupt handler: the
    command would run on to its end."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_DFL)


# ---------------------------------------------------------------------------------------------
# Flights in simulated time (issue 33): a test that asserts a figure of a flight (a drift, a sink, a
# speed, an error) flies it through the simulator's holds (gcs/launcher/sim_stepper.py), so each command
# takes effect at a chosen simulated time and the figure is the same on a busy machine and a quiet one.

START_HOLD_MS = 100  # the simulator starts held at t = 0.1 s, until the test moves the hold


def record_figure(name: str, value: float, limit: float, *, below: bool = True, unit: str = "") -> None:
    """Assert a figure of a flight against its limit (``value < limit``, or ``>`` with ``below=False``), print
    it, and record it for the flake hunt (``benchmarks/flake_hunt.py`` sets ``E2E_FIGURES`` to a file: one JSON
    line per figure, with the test's node id).  docs/testing.md lists every figure, its spread and its limit."""
    import json
    import os

    test = os.environ.get("PYTEST_CURRENT_TEST", "?").rsplit(" ", 1)[0]
    print(f"FIGURE {name} = {value:.4g} {unit} (limit {'<' if below else '>'} {limit:g})")
    path = os.environ.get("E2E_FIGURES")
    if path:
        line = json.dumps({"test": test, "name": name, "value": value, "limit": limit, "below": below, "unit": unit})
        with open(path, "a") as f:  # one write of one line: workers appending at once do not interleave
            f.write(line + "\n")
    ok = value < limit if below else value > limit
    assert ok, f"{name} = {value:.3f} {unit}, limit {'<' if below else '>'} {limit:g} {unit}"


class SteppedFlight:
    """A vehicle flown in simulated time: its link, the truth, and the stepper that moves the hold.

    ``wait(s)`` lets ``s`` simulated seconds pass; ``until(predicate, max_s, what)`` advances in slices of
    ``every_s`` until ``predicate()`` is true (read only while held); commands are sent between two slices and
    take effect from the next step.  A limit passed in simulated time fails the same way in every run
    (:class:`gcs.launcher.sim_stepper.SimTimeout`); wall time only bounds each slice (a dead process).
    """

    def __init__(self, client: VehicleClient, truth, stepper, stack=None, then_free: bool = False) -> None:
        self.client, self.truth, self.step, self.stack = client, truth, stepper, stack
        self.then_free = then_free  # the flight controller ages inputs on both clocks (stepped_flight)
        self.free = False  # the hold lifted for good (:meth:`run_free`)

    def run_free(self) -> None:
        """Lift the hold for good: the simulation runs on at full speed, for the tests of a file that come after
        its stepped flights and drive clients in wall time (MAVSDK, the ``gcs`` command line)."""
        assert self.then_free, "a stack that runs free later is started with then_free (its inputs' clock)"
        self.step.release(run_free=True)
        self.free = True

    def _check_held(self) -> None:
        assert not self.free, "a stepped flight after the hold was lifted (run_free): the file's order"

    @property
    def now_s(self) -> float:
        """The simulated time of the current hold, s."""
        return self.step.time_s

    @property
    def now_ms(self) -> int:
        return self.step.time_ms

    def wait(self, seconds: float) -> None:
        self._check_held()
        self.step.advance(seconds)

    def until(self, predicate, max_s: float, what: str, every_s: float = 0.1, paced: bool = False):
        """Advance until ``predicate()``; its value.  ``paced``: the simulation never ahead of the wall clock (from
        the call), for a client inside the flight that sends on the wall clock (a ``gcs fly`` process's sticks):
        each of its messages then arrives within its period of simulated time too."""
        self._check_held()
        if paced:
            wall0, sim0, ready = time.monotonic(), self.now_s, predicate

            def predicate():
                value = ready()
                if not value:
                    time.sleep(max(0.0, wall0 + (self.now_s - sim0) - time.monotonic()))
                return value

        return self.step.run_until(predicate, max_s, what, check_every_s=every_s)

    def mode_is(self, name: str, max_s: float = 5.0) -> None:
        """Until the vehicle reports mode ``name`` (PX4's name: LOITER, OFFBOARD, POSCTL ...)."""
        self.until(lambda: self.client.mode_name() == name, max_s, f"mode {name}")

    def text_seen(self, index: int, fragment: str, max_s: float = 5.0, every_s: float = 0.1) -> None:
        """Until a STATUSTEXT containing ``fragment`` has come (after the first ``index``)."""
        seen = lambda: any(fragment in t for t in texts_since(self.client, index))  # noqa: E731
        self.until(seen, max_s, f"a STATUSTEXT with {fragment!r}", every_s)

    def truth_now(self):
        """The true vehicle at the current hold (arrived before the simulator's "held" report)."""
        return self.truth.at(self.now_ms, within_ms=0)

    def truth_since(self, time_ms: int):
        """The truth samples from ``time_ms`` to the current hold (later ones are not part of this flight yet)."""
        return [s for s in self.truth.since(time_ms) if s.time_ms <= self.now_ms]

    def ready(self, max_s: float = 60.0) -> None:
        """Until the vehicle, disarmed, may be armed and has a home, by a SYS_STATUS sent after the call (the one
        before may be from before a disarm, when the pre-arm bit still read armed's "ready")."""
        c, fresh = self.client, []

        def listener(msg) -> None:
            if msg.get_type() == "SYS_STATUS":
                fresh.append(msg)

        c.add_listener(listener)
        try:
            ok = lambda: bool(fresh) and not c.armed() and c.prearm_ok() and c.home() is not None  # noqa: E731
            self.until(ok, max_s, "ready to arm", 0.5)
        finally:
            c.remove_listener(listener)

    def take_off(self, alt_m: float, settle_s: float = 2.0, max_s: float = 60.0):
        """Arm, take off to ``alt_m`` above home (unless already holding there), settle; the truth then."""
        client = self.client
        if not (client.armed() and client.mode_name() == "LOITER"):
            self.ready()
            client.arm(timeout_s=10).check()
            client.takeoff(client.home().alt_amsl_m + alt_m, timeout_s=10).check()
        self.until(lambda: client.mode_name() == "LOITER" and client.takeoff_done(alt_m), max_s, f"hover at {alt_m} m")
        self.wait(settle_s)
        return self.truth_now()

    def land(self, max_s: float = 60.0) -> None:
        self.client.land(timeout_s=10).check()
        self.until(self.client.landed_and_disarmed, max_s, "landed and disarmed", 0.25)

    def set_sim(self, name: str, value: float) -> float:
        """Set a simulator parameter between two steps (it acts from the next); the simulated time, s."""
        self.truth.set(name, value)
        return self.now_s


def sim_seed() -> int | None:
    """The simulator's seed for the flights in simulated time: ``E2E_SEED`` if set (the flake hunt's
    ``--seeds`` sets it, to see each figure's spread over the sensors' noise), else the simulator's default."""
    import os

    value = os.environ.get("E2E_SEED")
    return int(value) if value else None


@contextlib.contextmanager
def stepped_flight(
    inst: int,
    vehicle: str = "quad_x",
    sim_args: Sequence[str] = (),
    fc_args: Sequence[str] = (),
    then_free: bool = False,
) -> Iterator[SteppedFlight]:
    """A :class:`SteppedFlight` of ``vehicle`` on instance ``inst``: both processes at full speed, the simulator
    held from :data:`START_HOLD_MS`; ``sim_args``, ``fc_args``: more ``sitl`` (``--scenario``, ``--param``) and
    ``autopilot`` (``--params``) arguments.  The flight controller ages the test's inputs (sticks, setpoints,
    targets, HEARTBEATs) on simulated time alone (``--input-clock sim``): when one is lost is the same in every
    run.  ``then_free``: the file lifts the hold later (:meth:`SteppedFlight.run_free`) for clients that send on
    the wall clock, so the flight controller keeps its default (an input is lost once silent on both clocks)."""
    from gcs.launcher import Stack
    from gcs.launcher.sim_stepper import SimStepper
    from gcs.sim_client import SimClient

    args = [*sim_args, "--param", f"SIM_HOLD_MS={START_HOLD_MS}"]
    clock = [] if then_free else ["--input-clock", "sim"]
    with (
        SimClient(ports.sim_component_port(inst)) as truth,
        Stack(inst, "max", vehicle, args, [*fc_args, *clock], seed=sim_seed(), flight_logs=False) as stack,
        VehicleClient(stack.gcs_url, timeout_s=WAIT_S, idle=stack.check_alive) as client,
    ):
        stepper = SimStepper(client, truth, timeout_s=WAIT_S)
        stepper.start()
        yield SteppedFlight(client, truth, stepper, stack, then_free)


def stepped_flight_fixture(
    params: dict[str, float] | None = None,
    sim_params: dict[str, float] | None = None,
    vehicle: str = "quad_x",
    scope: str = "module",
    then_free: bool = False,
):
    """A ``flight`` fixture (:class:`SteppedFlight`, :func:`stepped_flight`) for a module, on its instance
    (``inst``), or for a class (``scope``), on a free instance of its own; ``params``: flight-controller
    parameters at start-up (``autopilot --params``), ``sim_params``: the simulator's (``sitl --param``);
    ``then_free``: see :func:`stepped_flight`."""
    import pytest

    @pytest.fixture(scope=scope)
    def flight(request, free_instance, tmp_path_factory):
        fc_args = startup_params_args(params, tmp_path_factory)
        sim_args = [a for name, value in (sim_params or {}).items() for a in ("--param", f"{name}={value:g}")]
        instance = request.getfixturevalue("inst") if scope == "module" else free_instance()  # a module's: ``inst``
        with stepped_flight(instance, vehicle, sim_args, fc_args, then_free) as f:
            yield f

    return flight
