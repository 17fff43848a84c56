"""The command table (autopilot.mavlink.commands): one row per MAV_CMD, one COMMAND_ACK per command.

The table's vehicle rows run on a real commander; the last test sends every command of
the table, and one it does not know, to a real :class:`GcsLink` serving a real (idle)
flight controller over loopback UDP (a free instance, ``free_instance``; the client listens on
14840 + instance), and checks that each gets exactly one COMMAND_ACK with a MAV_RESULT.
"""

from __future__ import annotations

import math
import os
import time

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from autopilot.commander import Commander  # noqa: E402
from autopilot.flight_controller import FlightController  # noqa: E402
from autopilot.mavlink import commands  # noqa: E402
from autopilot.mavlink.link import GcsLink  # noqa: E402
from autopilot.mavlink.vehicle_interface import FlightControllerVehicle  # noqa: E402
from autopilot.param_catalogue import default_store  # noqa: E402
from mavsim_core import ports
from params.vehicle import load_vehicle  # noqa: E402

MAV_RESULTS = set(mavlink.enums["MAV_RESULT"]) - {mavlink.MAV_RESULT_ENUM_END}
UNKNOWN_COMMAND = 31010  # MAV_CMD_USER_1: nothing here implements it


def _commander() -> Commander:
    return Commander(default_store(), "QUADROTOR")


def test_unknown_command_is_unsupported():
    cmd = _commander()
    for command in (UNKNOWN_COMMAND, mavlink.MAV_CMD_DO_SET_SERVO, mavlink.MAV_CMD_NAV_WAYPOINT):
        assert command not in commands.COMMANDS
        assert commands.handle_vehicle_command(cmd, command, (0.0,) * 7, 0) == mavlink.MAV_RESULT_UNSUPPORTED
    assert cmd.pop_events() == []  # nothing said about a command that does not exist
    # a link row never runs on the vehicle
    result = commands.handle_vehicle_command(cmd, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, (0.0,) * 7, 0)
    assert result == mavlink.MAV_RESULT_UNSUPPORTED


def test_table_covers_the_commands_of_px4_identity():
    expected = {
        mavlink.MAV_CMD_COMPONENT_ARM_DISARM, mavlink.MAV_CMD_NAV_TAKEOFF, mavlink.MAV_CMD_NAV_LAND,
        mavlink.MAV_CMD_NAV_RETURN_TO_LAUNCH, mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_CMD_DO_REPOSITION,
        mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAV_CMD_REQUEST_MESSAGE,
        mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, mavlink.MAV_CMD_DO_SET_MISSION_CURRENT,
        mavlink.MAV_CMD_DO_CHANGE_SPEED, mavlink.MAV_CMD_DO_SET_HOME, mavlink.MAV_CMD_GET_HOME_POSITION,
        mavlink.MAV_CMD_CONDITION_YAW, mavlink.MAV_CMD_DO_PAUSE_CONTINUE, mavlink.MAV_CMD_DO_FLIGHTTERMINATION,
        mavlink.MAV_CMD_PREFLIGHT_STORAGE, mavlink.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, mavlink.MAV_CMD_DO_MOTOR_TEST,
        mavlink.MAV_CMD_DO_ORBIT, mavlink.MAV_CMD_DO_AUTOTUNE_ENABLE, mavlink.MAV_CMD_DO_LAND_START,
    }  # fmt: skip
    assert set(commands.COMMANDS) == expected
    by_link = {c for c, row in commands.COMMANDS.items() if row.by is commands.By.LINK}
    assert by_link == {
        mavlink.MAV_CMD_SET_MESSAGE_INTERVAL,
        mavlink.MAV_CMD_REQUEST_MESSAGE,
        mavlink.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES,
        mavlink.MAV_CMD_GET_HOME_POSITION,
    }


@pytest.mark.parametrize("params", [(0.0,) * 7, (math.nan,) * 7, (1.0,) * 7, (-1.0, 21196.0, 4, 3, 0.0, 0.0, 500.0)])
def test_every_vehicle_row_returns_a_mav_result_and_says_why_when_refused(params):
    cmd = _commander()  # no estimate yet: most commands are refused
    for command, row in commands.COMMANDS.items():
        if row.by is not commands.By.VEHICLE:
            continue
        result = commands.handle_vehicle_command(cmd, command, params, mavlink.MAV_FRAME_GLOBAL)
        assert result in MAV_RESULTS, (command, params, result)
        events = cmd.pop_events()
        if result == mavlink.MAV_RESULT_DENIED:
            assert events and all(sev <= mavlink.MAV_SEVERITY_CRITICAL for sev, _ in events), (command, events)


def test_command_int_coordinates():
    msg = mavlink.MAVLink_command_int_message(
        1,
        1,
        mavlink.MAV_FRAME_GLOBAL_INT,
        mavlink.MAV_CMD_DO_REPOSITION,
        0,
        0,
        -1.0,
        0.0,
        0.0,
        math.nan,
        473977420,
        85455940,
        510.5,
    )
    p = commands.command_int_params(msg)
    assert p[4] == pytest.approx(47.397742) and p[5] == pytest.approx(8.545594) and p[6] == 510.5
    local = mavlink.MAVLink_command_int_message(
        1, 1, mavlink.MAV_FRAME_LOCAL_NED, 0, 0, 0, 0, 0, 0, 0, 125000, -5000, 3
    )
    assert commands.command_int_params(local)[4:6] == pytest.approx((12.5, -0.5))
    unused = mavlink.MAVLink_command_int_message(
        1, 1, mavlink.MAV_FRAME_GLOBAL_INT, 0, 0, 0, 0, 0, 0, 0, 2**31 - 1, 2**31 - 1, 0
    )
    assert all(math.isnan(v) for v in commands.command_int_params(unused)[4:6])


def test_every_command_gets_one_ack_over_udp(free_instance):
    instance = free_instance()
    fc = FlightController(load_vehicle("quad_x"), default_store())
    link = GcsLink(FlightControllerVehicle(fc), instance=instance, gcs_port=ports.own_gcs_port(instance))
    client = mavutil.mavlink_connection(
        f"udpin:127.0.0.1:{ports.own_gcs_port(instance)}", source_system=255, source_component=190, dialect="common"
    )
    t_us = 0
    got: list = []

    def pump(seconds: float, until=None) -> None:
        nonlocal t_us
        wall_end = time.monotonic() + 5.0
        for _ in range(int(seconds * 50)):
            t_us += 20_000
            link.update(t_us)
            time.sleep(0.001)
            while (m := client.recv_match(blocking=False)) is not None:
                got.append(m)
            if (until is not None and until()) or time.monotonic() > wall_end:
                return

    try:
        pump(2.0, until=lambda: any(m.get_type() == "HEARTBEAT" for m in got))  # the link has a peer to answer
        sent = [*commands.COMMANDS, UNKNOWN_COMMAND]
        for command in sent:
            for p in ((0.0,) * 7, (math.nan,) * 7):
                client.mav.command_long_send(1, 1, command, 0, *p)
        got.clear()
        pump(1.0, until=lambda: sum(m.get_type() == "COMMAND_ACK" for m in got) >= 2 * len(sent))
        acks = [m for m in got if m.get_type() == "COMMAND_ACK"]
        assert sorted(a.command for a in acks) == sorted(sent * 2)
        assert all(a.result in MAV_RESULTS and a.result != mavlink.MAV_RESULT_FAILED for a in acks)
        unknown = [a.result for a in acks if a.command == UNKNOWN_COMMAND]
        assert unknown == [mavlink.MAV_RESULT_UNSUPPORTED] * 2
    finally:
        client.close()
        link.close()
