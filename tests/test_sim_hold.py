"""The simulator's hold (``SIM_HOLD_MS``, sitl/hold.py) in process, over real sockets.

A real :class:`sitl.lockstep.LockstepServer` on a real MuJoCo simulation runs in a thread; this test is its
flight controller (:class:`autopilot.mavlink.sim_link.SimLink`, constant motor commands) and its truth client
(:class:`gcs.sim_client.SimClient`).  Checked: the simulation stops before the sensors of the hold time, says
so with the truth at that time and SYSTEM_TIME, keeps the flight controller's link alive with HEARTBEATs and
answers its ``SIM_*`` requests; moving the hold on resumes it, 0 releases it; and holds of different wall
lengths do not change a single number of the simulation.  Also :class:`autopilot.sim_link_watch.SimLinkWatch`
with a held simulator.
"""

from __future__ import annotations

import threading
import time

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink.sim_link import SimLink
from autopilot.sim_link_watch import SimLinkWatch
from gcs.sim_client import SimClient
from sitl.hold import HOLD_PARAM, KEEPALIVE_S, WORLD_HOLD, HoldSettings, SimHold
from sitl.sim_params import SimParameters
from sitl.sim_settings import MotorSettings, SensorSettings, WindSettings

HOME = (47.397742, 8.545594, 488.0)
MOTORS = np.full(4, 0.9)  # well over hover: the vehicle climbs, so the state changes every step
WAIT_S = 20.0  # wall-clock safety net of each wait


@pytest.fixture
def world_hold():
    """The process's hold, back to "never" afterwards (other tests build servers in this process)."""
    WORLD_HOLD.hold_ms = 0
    yield WORLD_HOLD
    WORLD_HOLD.hold_ms = 0


class Rig:
    """A LockstepServer in a thread, with this test as its flight controller and its truth client."""

    def __init__(self, quad, hold_ms: int, duration_s: float) -> None:
        from sitl.lockstep import LockstepServer
        from sitl.simulation import Simulation

        WORLD_HOLD.hold_ms = hold_ms
        self.truth = SimClient(0)
        self.server = LockstepServer(
            Simulation(quad, HOME, seed=3), 0, ("127.0.0.1", self.truth.sock.getsockname()[1]), None
        )
        self.thread = threading.Thread(target=self.server.run, args=(duration_s,), daemon=True)
        self.thread.start()
        self.fc = SimLink("127.0.0.1", self.server.listener.getsockname()[1], sysid=1)
        self.fc.connect(handshake_timeout_s=WAIT_S)
        self.sensor_times: list[int] = []
        self.heartbeats = 0
        self.held_at_ms = -1  # the latest HEARTBEAT's custom_mode: the hold time
        self.other: list = []

    def fly_until(self, stop) -> None:
        """Answer every HIL_SENSOR with MOTORS until ``stop()`` (checked between messages)."""
        deadline = time.monotonic() + WAIT_S
        while not stop():
            assert time.monotonic() < deadline, "the simulator stopped answering"
            for m in self.fc.receive(timeout_s=0.05) or []:
                if m.get_type() == "HIL_SENSOR":
                    self.sensor_times.append(m.time_usec)
                    self.fc.send_actuators(m.time_usec, MOTORS, True)
                elif m.get_type() == "HEARTBEAT":
                    self.heartbeats += 1
                    self.held_at_ms = m.custom_mode
                else:
                    self.other.append(m)

    def close(self) -> None:
        self.fc.close()
        self.thread.join(WAIT_S)
        self.server.close()
        self.truth.close()


def test_the_hold_stops_before_the_sensors_of_its_time_and_keeps_serving(quad, world_hold):
    rig = Rig(quad, hold_ms=200, duration_s=0.6)
    try:
        rig.fly_until(lambda: rig.truth.held_ms is not None)
        assert rig.truth.wait_held(200, WAIT_S) == 200
        assert rig.truth.at(200, within_ms=0) is not None  # the truth at the hold time came before the report
        assert max(rig.sensor_times) == 196_000  # the flight controller's last step: 4 ms before the hold
        end = time.monotonic() + 3 * KEEPALIVE_S
        rig.fly_until(lambda: time.monotonic() > end)
        assert max(rig.sensor_times) == 196_000 and rig.heartbeats >= 2  # held: HEARTBEATs, no sensors
        assert rig.held_at_ms == 200
        # the flight controller's SIM_* requests on the lockstep link are answered while held
        read = mavlink.MAVLink_param_request_read_message(1, 51, HOLD_PARAM.encode(), -1)
        answer = rig.fc.request(read, lambda m: m.get_type() == "PARAM_VALUE", timeout_s=WAIT_S)
        assert answer is not None and answer.param_value == 200.0
        assert rig.truth.get(HOLD_PARAM) == 200  # and the UDP component's
        rig.truth.set(HOLD_PARAM, 300)  # on to 0.3 s
        rig.fly_until(lambda: (rig.truth.held_ms or 0) >= 300)
        assert max(rig.sensor_times) == 296_000 and rig.server.hold.holds == 2
        rig.truth.set(HOLD_PARAM, 0)  # released: runs to its end (0.6 s) without holding again
        rig.fly_until(lambda: not rig.thread.is_alive())
        assert max(rig.sensor_times) == 596_000 and rig.server.hold.holds == 2
        assert sorted(set(rig.sensor_times)) == list(range(0, 600_000, 4000))  # every step once, none skipped
    finally:
        rig.close()


def _fly(quad, holds_ms: list[int], hold_wall_s: float) -> dict[int, tuple]:
    """Run to 0.5 s through ``holds_ms``, each held ``hold_wall_s`` of wall time; the truth every 20 ms."""
    rig = Rig(quad, hold_ms=holds_ms[0] if holds_ms else 0, duration_s=0.5)
    try:
        for k, hold in enumerate(holds_ms):
            rig.fly_until(lambda: (rig.truth.held_ms or 0) >= hold)
            time.sleep(hold_wall_s)
            rig.truth.set(HOLD_PARAM, holds_ms[k + 1] if k + 1 < len(holds_ms) else 0)
        rig.fly_until(lambda: not rig.thread.is_alive())
        time.sleep(0.1)  # the last truth datagrams
        return {t: (s.pos_ned_m, s.vel_ned_m_s) for t, s in rig.truth.positions.items()}
    finally:
        rig.close()


def test_holds_of_any_length_leave_the_simulation_unchanged(quad, world_hold):
    free = _fly(quad, [], 0.0)
    held = _fly(quad, [100, 240, 380], 0.3)
    assert set(range(0, 500, 20)) <= set(free)  # 50 Hz truth up to the end
    assert -free[480][0][2] > -free[0][0][2] + 0.01  # the vehicle climbed: the state changed along the way
    assert all(held[t] == free[t] for t in free)  # bit for bit


def test_the_hold_parameter_is_one_int32_of_the_world():
    params = SimParameters(WindSettings(), SensorSettings(), MotorSettings())
    p = params.param(HOLD_PARAM)
    assert p.type == "INT32" and p.unit == "ms" and (p.min, p.max) == (0, 2**23 - 1)
    assert params.names()[-1] == HOLD_PARAM and p.owner is WORLD_HOLD  # every vehicle's list holds the world
    own = HoldSettings()
    assert SimParameters(WindSettings(), SensorSettings(), MotorSettings(), hold=own).param(HOLD_PARAM).owner is own
    hold = SimHold(own)
    assert not hold.reached(10**9)  # 0: never
    own.hold_ms = 100
    assert not hold.reached(96_000) and hold.reached(100_000) and hold.reached(104_000)


def test_sim_link_watch_takes_held_heartbeats_for_alive_and_their_silence_for_lost():
    w = SimLinkWatch(loss_timeout_s=1.0)
    w.on_sensor(196_000, 10.0)
    assert not w.on_held(10.1) and w.held
    for wall in (10.5, 11.0, 11.5, 12.0):  # a long hold, heartbeats every 0.5 s: alive
        assert not w.check(wall, closed=False)
        w.on_held(wall)
    assert w.link_time_us(12.0) == 196_000  # the ground link's time stays at the latest sensor time
    assert w.check(13.1, closed=False) and w.lost and not w.held  # the heartbeats stopped: lost
    assert w.on_held(13.5) and not w.lost  # a held simulator regains the link
    assert not w.on_sensor(200_000, 14.0) and not w.held
    w.on_held(14.1)
    assert w.check(14.2, closed=True) and not w.held  # a closed link is lost, held or not


def test_the_truth_reader_catches_up_before_a_wait_of_simulated_time_starts(free_instance):
    """``SimClient.caught_up``: the latest truth once everything that had arrived is read, not the sample the
    reader happened to be at (on a loaded machine seconds of simulated time behind: e2e_flight_helpers.sim_sleep
    counts from it).  Truth queued in the socket while the reader is stopped, then one call: the last time."""
    import socket

    from mavsim_core import ports

    port = ports.sim_component_port(free_instance())
    with SimClient(port) as truth:
        truth._stop.set()  # the reader stops after its current wait: the datagrams below queue in the socket
        truth.thread.join(timeout=2)
        mav = mavlink.MAVLink(None, 1, 51)
        with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
            for t_ms in range(0, 3000, 20):
                packet = mavlink.MAVLink_local_position_ned_message(t_ms, 0, 0, -5, 0, 0, 0).pack(mav)
                s.sendto(packet, ("127.0.0.1", port))
        assert truth.latest() is None
        truth._stop.clear()
        truth.thread = threading.Thread(target=truth._run, daemon=True)
        truth.thread.start()
        assert truth.caught_up(timeout_s=10) == 2980


def test_a_simulator_waiting_for_its_camera_is_alive_and_not_held():
    """A frame held back by a loaded machine: the simulator's "busy" HEARTBEATs (MAV_STATE_ACTIVE, every 0.2 s while
    the companion's answer is waited for: sitl/companion.py) keep the link up without a hold, so the flight
    controller's ground link keeps the simulated clock and the flight goes on as it would have."""
    w = SimLinkWatch(loss_timeout_s=1.0)
    w.on_sensor(196_000, 10.0)
    for wall in (10.2, 10.4, 10.6, 10.8, 11.0, 11.2, 11.4):  # a 1.4 s wait for one frame
        assert not w.check(wall, closed=False)
        w.on_busy(wall)
    assert not w.lost and not w.held and w.link_time_us(11.4) == 196_000
    assert w.check(12.5, closed=False) and w.lost  # silence, busy or not: lost


def test_the_companion_says_it_is_alive_while_a_frame_is_waited_for():
    """sitl.companion_workers.ThreadWorker.answer: the keepalive every BUSY_KEEPALIVE_S until the worker answers."""
    import queue
    import threading
    from collections import deque

    from sitl.companion import BUSY_KEEPALIVE_S
    from sitl.companion_workers import ThreadWorker

    calls = []
    waiter = ThreadWorker.__new__(ThreadWorker)  # only answer: no renderer, no thread
    answer: queue.Queue = queue.Queue(maxsize=1)
    waiter._answers, waiter._free = deque([answer]), deque()
    threading.Timer(3.5 * BUSY_KEEPALIVE_S, lambda: answer.put(("copy", "frame"))).start()
    assert waiter.answer(lambda: calls.append(1), BUSY_KEEPALIVE_S) == "frame"
    assert len(calls) >= 3  # (a slower machine only adds calls)
