"""A GcsLink on loopback UDP for tests: a stub vehicle behind it, pymavlink clients in front.

Shared by tests/test_gcs_link_telemetry.py, test_gcs_link_commands.py and test_gcs_link_params.py;
their fixture ``make_harness`` (conftest.py) makes :class:`Harness` objects and closes them.  The
link runs on simulated time: :meth:`Harness.pump` calls ``link.update(t_us)`` itself (t in
microseconds, one 250 Hz step per call) and drains the client sockets after each call.
"""

from __future__ import annotations

import dataclasses
import math
import os
import time

import numpy as np

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from autopilot.commander.mission_control import Plans  # noqa: E402
from autopilot.mavlink.link import GcsLink  # noqa: E402
from autopilot.param_catalogue import default_store  # noqa: E402
from autopilot.parameters import ParamDef, ParameterStore, ParamType  # noqa: E402
from autopilot.topics import (  # noqa: E402
    BatteryState,
    GpsSample,
    HomePosition,
    LandedState,
    TelemetrySnapshot,
    VehicleEstimate,
)
from mavsim_core import ports
from mavsim_core.mission_items import MissionItem  # noqa: E402
from mavsim_core.px4_modes import Mode  # noqa: E402

ORIGIN = (47.397742, 8.545594, 488.0)  # the estimate's origin (lat deg, lon deg, alt m AMSL), also home
CUSTOM_MODE_POSCTL = 3 << 16
BASE_MODE = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_SAFETY_ARMED
DT_US = 4000  # 250 Hz control loop
GCS_SYS, GCS_COMP = 255, 190


def make_snapshot(*, with_estimate: bool = True) -> TelemetrySnapshot:
    yaw = math.pi / 2
    q = np.array([math.cos(yaw / 2), 0.0, 0.0, math.sin(yaw / 2)])
    estimate = VehicleEstimate(
        timestamp_us=0,
        q_wxyz=q,
        rate_frd_rad_s=np.array([0.01, -0.02, 0.03]),
        accel_ned_m_s2=np.zeros(3),
        pos_ned_m=np.array([10.0, 20.0, -5.0]),
        vel_ned_m_s=np.array([1.0, 2.0, -0.5]),
        attitude_valid=True,
        position_valid=True,
        origin_lat_deg=ORIGIN[0],
        origin_lon_deg=ORIGIN[1],
        origin_alt_amsl_m=ORIGIN[2],
    )
    gps = GpsSample(
        timestamp_us=0, fix_type=3, lat_deg=47.3978, lon_deg=8.5458, alt_amsl_m=493.0,
        vel_ned_m_s=np.array([1.0, 0.0, 0.0]), eph_m=0.8, epv_m=1.2, satellites=12,
    )  # fmt: skip
    home = HomePosition(lat_deg=ORIGIN[0], lon_deg=ORIGIN[1], alt_amsl_m=ORIGIN[2], pos_ned_m=np.zeros(3), yaw_rad=0.0)
    return TelemetrySnapshot(
        timestamp_us=0,
        mav_type=mavlink.MAV_TYPE_QUADROTOR,
        armed=True,
        base_mode=BASE_MODE,
        custom_mode=CUSTOM_MODE_POSCTL,
        system_status=mavlink.MAV_STATE_ACTIVE,
        landed_state=LandedState.IN_AIR,
        estimate=estimate if with_estimate else None,
        gps=gps if with_estimate else None,
        home=home if with_estimate else None,
        battery=BatteryState(voltage_v=16.0, current_a=5.0, remaining_frac=0.75, cell_count=4),
        throttle_frac=0.42,
        sensors_present=0x2F,
        sensors_enabled=0x2F,
        sensors_health=0x2F,
        prearm_ok=True,
    )


def make_params(extra: int = 0) -> ParameterStore:
    defs = [
        ParamDef("MPC_XY_P", ParamType.REAL32, 0.95, 0.0, 2.0, "", "position P gain"),
        ParamDef("SYS_AUTOSTART", ParamType.INT32, 4001, 0, 9_999_999, "", "airframe"),
        ParamDef("TST_INT", ParamType.INT32, -1, -10_000_000, 10_000_000, "", "test integer"),
    ]
    defs += [ParamDef(f"TST_P{i:03d}", ParamType.REAL32, i * 0.5, 0.0, 1000.0, "", "filler") for i in range(extra)]
    return ParameterStore({d.name: d for d in defs})


class StubVehicle:
    """VehicleInterface for tests: fixed snapshot, records commands, chosen results."""

    def __init__(self, params: ParameterStore | None = None, snapshot: TelemetrySnapshot | None = None) -> None:
        self.params = params if params is not None else make_params()
        self.snap = snapshot if snapshot is not None else make_snapshot()
        self.commands: list[tuple[int, tuple[float, ...], int]] = []
        self.set_modes: list[tuple[int, int]] = []
        self.results: dict[int, int] = {}  # command -> MAV_RESULT; unknown ones UNSUPPORTED
        self.events: list[tuple[int, str]] = []
        self.snapshot_calls = 0
        self.control_messages: list[tuple[str, int]] = []  # (type, simulated µs) of sticks and setpoints received
        self.gcs_heartbeats: list[int] = []
        # The real plan store of the commander (pure: no flight), so the mission protocol is tested whole.
        self.plans = Plans(default_store())

    def snapshot(self) -> TelemetrySnapshot:
        self.snapshot_calls += 1
        if self.plans.state is self.snap.mission.state and self.plans.current == self.snap.mission.seq:
            if len(self.plans.items[0]) == self.snap.mission.total:
                return self.snap
        self.snap = dataclasses.replace(self.snap, mission=self.plans.status(Mode.POSCTL))
        return self.snap

    def handle_command(self, command: int, params: tuple[float, ...], frame: int) -> int:
        self.commands.append((command, params, frame))
        return self.results.get(command, mavlink.MAV_RESULT_UNSUPPORTED)

    def handle_set_mode(self, base_mode: int, custom_mode: int) -> int:
        self.set_modes.append((base_mode, custom_mode))
        return mavlink.MAV_RESULT_ACCEPTED

    def pop_events(self) -> list[tuple[int, str]]:
        events, self.events = self.events, []
        return events

    def on_landing_target(self, msg, src_sysid: int) -> None:
        pass

    def on_control_message(self, msg, now_us: int) -> None:
        self.control_messages.append((msg.get_type(), now_us))

    def on_gcs_heartbeat(self, now_us: int) -> None:
        self.gcs_heartbeats.append(now_us)

    def plan(self, mission_type: int) -> list[MissionItem]:
        return self.plans.plan(mission_type)

    def check_item(self, item: MissionItem) -> tuple[int, str]:
        return self.plans.check_item(item, self.snap.home)

    def replace_plan(self, mission_type: int, items: list[MissionItem]) -> tuple[int, str]:
        return self.plans.replace(mission_type, items, mission_active=False)

    def set_mission_current(self, seq: int) -> tuple[bool, str]:
        return self.plans.set_current(seq)

    def pop_mission_reached(self) -> list[int]:
        out, self.plans.reached = self.plans.reached, []
        return out


class Harness:
    """A GcsLink, its stub vehicle, simulated time and ground-station clients."""

    def __init__(self, instance: int, vehicle: StubVehicle | None = None) -> None:
        self.instance = instance
        self.vehicle = vehicle if vehicle is not None else StubVehicle()
        self.link = GcsLink(self.vehicle, instance=instance, gcs_port=ports.own_gcs_port(instance))
        self.t_us = 0
        self.updates = 0
        self.clients: dict[str, mavutil.mavfile] = {}

    def client(self, endpoint: str = "gcs") -> mavutil.mavfile:
        if endpoint not in self.clients:
            port = ports.own_gcs_port(self.instance) if endpoint == "gcs" else ports.api_port(self.instance)
            self.clients[endpoint] = mavutil.mavlink_connection(
                f"udpin:127.0.0.1:{port}", source_system=GCS_SYS, source_component=GCS_COMP, dialect="common"
            )
        return self.clients[endpoint]

    def pump(self, sim_s: float, until=None, wall_timeout_s: float = 120.0) -> dict[str, list]:
        """Run update() for ``sim_s`` simulated seconds (or until ``until(msg)``); return received messages.

        ``wall_timeout_s`` is a safety net only, and running into it fails the test: cut short quietly (it was
        5 s), a pump on a loaded machine returned fewer simulated seconds than asked for, and the counts and
        idle times read from it depended on the load (flake hunt, 2026-12-02: 4 ALTITUDE in "10 s", an FTP
        session not yet idle)."""
        got: dict[str, list] = {name: [] for name in self.clients}
        end_us = self.t_us + int(sim_s * 1e6)
        wall_end = time.monotonic() + wall_timeout_s
        while self.t_us < end_us:
            if time.monotonic() > wall_end:
                raise AssertionError(f"pump: {sim_s} simulated s not run within {wall_timeout_s} wall s")
            self.t_us += DT_US
            self.link.update(self.t_us)
            self.updates += 1
            done = False
            for name, c in self.clients.items():
                while (m := c.recv_match(blocking=False)) is not None:
                    got[name].append(m)
                    done = done or (until is not None and until(m))
            if done:
                break
        return got

    def connect(self, endpoint: str = "gcs") -> mavutil.mavfile:
        """Client that has heard from the link, so it knows where to send."""
        c = self.client(endpoint)
        got = self.pump(2.0, until=lambda m: m.get_type() == "HEARTBEAT")
        assert any(m.get_type() == "HEARTBEAT" for m in got[endpoint])
        return c

    def close(self) -> None:
        for c in self.clients.values():
            c.close()
        self.link.close()


def of_type(msgs: list, mtype: str) -> list:
    return [m for m in msgs if m.get_type() == mtype]


def acks(msgs: list, command: int) -> list:
    return [m for m in of_type(msgs, "COMMAND_ACK") if m.command == command]


def command_long(client, command: int, *params: float, target_system: int = 1, target_component: int = 1) -> None:
    p = list(params) + [0.0] * (7 - len(params))
    client.mav.command_long_send(target_system, target_component, command, 0, *p)
