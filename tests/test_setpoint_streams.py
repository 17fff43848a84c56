"""The setpoint streams of GcsLink (autopilot.mavlink) that flight logs record, over real UDP.

ATTITUDE_TARGET, POSITION_TARGET_LOCAL_NED and SERVO_OUTPUT_RAW: fields, default rates in
simulated time, SET_MESSAGE_INTERVAL, none while the controllers are idle.  The link binds UDP
on a free instance (``free_instance``, tests/conftest.py).  The logs themselves are tested in
tests/test_flight_logs.py.
"""

from __future__ import annotations

import math
import os
import time
from collections import Counter

import numpy as np
import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from autopilot.mavlink.link import GcsLink  # noqa: E402
from autopilot.param_catalogue import default_store
from autopilot.topics import (  # noqa: E402
    BatteryState,
    ControlSetpoints,
    LandedState,
    TelemetrySnapshot,
)
from mavsim_core import ports
from mavsim_core.quaternion import from_euler  # noqa: E402

# --------------------------------------------------------------------------- ground-station streams


def _snapshot(control: ControlSetpoints | None) -> TelemetrySnapshot:
    return TelemetrySnapshot(
        timestamp_us=0, mav_type=mavlink.MAV_TYPE_QUADROTOR, armed=True,
        base_mode=mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_SAFETY_ARMED,
        custom_mode=4 << 16 | 3 << 24, system_status=mavlink.MAV_STATE_ACTIVE, landed_state=LandedState.IN_AIR,
        estimate=None, gps=None, home=None, battery=BatteryState(16.0, 5.0, 0.8), throttle_frac=0.5,
        sensors_present=0, sensors_enabled=0, sensors_health=0, prearm_ok=True,
        motor_outputs=(0.5, 0.6, 0.0, 1.0), control=control,
    )  # fmt: skip


class _Vehicle:
    def __init__(self, snap: TelemetrySnapshot) -> None:
        self.params = default_store()
        self.snap = snap

    def snapshot(self) -> TelemetrySnapshot:
        return self.snap

    def handle_command(self, command, params, frame) -> int:
        return mavlink.MAV_RESULT_UNSUPPORTED

    def handle_set_mode(self, base_mode, custom_mode) -> int:
        return mavlink.MAV_RESULT_DENIED

    def pop_events(self) -> list:
        return []

    def pop_mission_reached(self) -> list:
        return []


def _control_setpoints(q_sp) -> ControlSetpoints:
    """What the controllers publish in flight: a NaN down position (altitude not controlled)."""
    return ControlSetpoints(
        timestamp_us=0,
        pos_ned_m=np.array([1.0, 2.0, math.nan]),
        vel_ned_m_s=np.array([0.1, 0.2, -0.5]),
        acc_ned_m_s2=np.array([0.0, 0.3, -0.1]),
        yaw_rad=1.0,
        q_sp_wxyz=q_sp,
        rate_sp_frd_rad_s=np.array([0.2, -0.1, 0.05]),
        thrust_frac=0.57,
    )


def _run_link(link, client, t: list, seconds: float) -> list:
    """Update the link at 50 Hz of simulated time for ``seconds``; what the client received."""
    out = []
    for _ in range(int(seconds * 50)):
        t[0] += 20_000
        link.update(t[0])
        time.sleep(0.0005)
        while (m := client.recv_match(blocking=False)) is not None:
            out.append(m)
    time.sleep(0.05)
    while (m := client.recv_match(blocking=False)) is not None:
        out.append(m)
    return out


def test_link_streams_attitude_and_position_targets(free_instance):
    """ATTITUDE_TARGET, POSITION_TARGET_LOCAL_NED and SERVO_OUTPUT_RAW: fields, default rates, SET_MESSAGE_INTERVAL."""
    instance = free_instance()  # GcsLink binds UDP 14640+I, 18570+I; the client 14840+I
    q_sp = from_euler(0.1, -0.05, 1.0)
    control = _control_setpoints(q_sp)
    vehicle = _Vehicle(_snapshot(control))
    link = GcsLink(vehicle, instance=instance, gcs_port=ports.own_gcs_port(instance))
    client = mavutil.mavlink_connection(
        f"udpin:127.0.0.1:{ports.own_gcs_port(instance)}", source_system=255, source_component=190, dialect="common"
    )
    got: list = []
    t = [0]

    def run(seconds: float) -> list:
        return _run_link(link, client, t, seconds)

    try:
        got = run(2.0)
        counts = Counter(m.get_type() for m in got)
        assert 35 <= counts["ATTITUDE_TARGET"] <= 41  # 20 Hz of simulated time
        assert 18 <= counts["POSITION_TARGET_LOCAL_NED"] <= 21  # 10 Hz
        assert 8 <= counts["SERVO_OUTPUT_RAW"] <= 11  # 5 Hz
        at = next(m for m in got if m.get_type() == "ATTITUDE_TARGET")
        assert at.type_mask == 0 and at.q == pytest.approx(list(q_sp), abs=1e-6)
        assert (at.body_roll_rate, at.body_pitch_rate, at.body_yaw_rate) == pytest.approx((0.2, -0.1, 0.05))
        assert at.thrust == pytest.approx(0.57)
        pt = next(m for m in got if m.get_type() == "POSITION_TARGET_LOCAL_NED")
        assert pt.coordinate_frame == mavlink.MAV_FRAME_LOCAL_NED
        assert pt.type_mask == (
            mavlink.POSITION_TARGET_TYPEMASK_Z_IGNORE | mavlink.POSITION_TARGET_TYPEMASK_YAW_RATE_IGNORE
        )
        assert (pt.x, pt.y) == (1.0, 2.0) and math.isnan(pt.z)
        assert (pt.vx, pt.vy, pt.vz) == pytest.approx((0.1, 0.2, -0.5))
        assert (pt.afx, pt.afy, pt.afz) == pytest.approx((0.0, 0.3, -0.1)) and pt.yaw == pytest.approx(1.0)
        so = next(m for m in got if m.get_type() == "SERVO_OUTPUT_RAW")
        servos = (so.servo1_raw, so.servo2_raw, so.servo3_raw, so.servo4_raw, so.servo5_raw)
        assert servos == (1500, 1600, 1000, 2000, 0)

        # SET_MESSAGE_INTERVAL works for them as for every stream: 50 Hz, then off.
        position_target = mavlink.MAVLINK_MSG_ID_POSITION_TARGET_LOCAL_NED
        client.mav.command_long_send(1, 1, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0, position_target, 20_000, *[0] * 5)
        client.mav.command_long_send(
            1, 1, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, 0, mavlink.MAVLINK_MSG_ID_ATTITUDE_TARGET, -1, 0, 0, 0, 0, 0
        )
        time.sleep(0.05)
        got = run(0.1)
        acks = [m for m in got if m.get_type() == "COMMAND_ACK"]
        assert [a.result for a in acks] == [mavlink.MAV_RESULT_ACCEPTED] * 2
        got = run(2.0)
        counts = Counter(m.get_type() for m in got)
        assert counts["ATTITUDE_TARGET"] == 0 and 95 <= counts["POSITION_TARGET_LOCAL_NED"] <= 101

        vehicle.snap = _snapshot(None)  # controllers idle (disarmed): no targets at all
        counts = Counter(m.get_type() for m in run(1.0))
        assert counts["POSITION_TARGET_LOCAL_NED"] == 0 and counts["HEARTBEAT"] >= 1
    finally:
        client.close()
        link.close()
