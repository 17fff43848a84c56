"""Helpers of the end-to-end flight tests (test_e2e_flight.py, test_e2e_flight_own_stacks.py).

Waiting on a :class:`gcs.client.VehicleClient` (wall-clock timeouts only: durations the vehicle
must hold are simulated seconds), recording its messages with their vehicle time, reading its
STATUSTEXTs, and horizontal distances in metres (NED).
"""

from __future__ import annotations

import math

from gcs.client import VehicleClient, mavlink
from mavsim_core import ports

WAIT_S = 90.0  # wall seconds before giving up on any one step (a noisy 2-core machine)
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
    """Wait ``seconds`` of simulated time (truth clock); the truth time at the end, ms."""
    end = sim_ms(truth) + round(seconds * 1000)

    async def passed():
        return sim_ms(truth) >= end

    await until(passed, timeout_s, f"{seconds:g} simulated seconds", period_s=0.005)
    return sim_ms(truth)


def truth_yaw(truth) -> float:
    """The vehicle's true heading, rad from north."""
    w, x, y, z = truth.latest_state.attitude_quaternion
    return math.atan2(2 * (w * z + x * y), 1 - 2 * (y * y + z * z))


def truth_and_stack_fixtures(params: dict[str, float] | None = None):
    """Module-scoped ``truth`` (the simulator's truth port) and ``stack`` (both processes at full speed)
    fixtures on the module's free instance (the ``inst`` fixture of conftest.py): ``truth, stack =
    truth_and_stack_fixtures()`` in a test file; ``params``: flight-controller parameters applied at
    start-up (``autopilot --params``)."""
    import pytest

    from gcs.launcher import Stack
    from gcs.sim_client import SimClient

    @pytest.fixture(scope="module")
    def truth(inst):
        with SimClient(ports.sim_component_port(inst)) as listener:
            yield listener

    @pytest.fixture(scope="module")
    def stack(inst, truth, tmp_path_factory):
        args: list[str] = []
        if params:
            path = tmp_path_factory.mktemp("startup-params") / "startup.params"
            path.write_text("".join(f"{name} {value}\n" for name, value in params.items()))
            args = ["--params", str(path)]
        with Stack(instance=inst, speed="max", extra_autopilot_args=args) as s:
            yield s

    return truth, stack


def sigint_default() -> None:
    """``preexec_fn`` of a command a test stops with Ctrl-C: SIGINT's default action, whatever pytest inherited.
    A shell without job control starts background commands with SIGINT ignored (``nohup bash .ci/run &``), an
    ignored signal stays ignored across exec, and Python then installs no KeyboardInterrupt handler: the
    command would run on to its end."""
    import signal

    signal.signal(signal.SIGINT, signal.SIG_DFL)
