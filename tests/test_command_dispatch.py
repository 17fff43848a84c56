"""The link's command dispatch on its own (autopilot/mavlink/command_dispatch.py): no socket, no GcsLink.

Exactly one COMMAND_ACK per command, to its sender: a failing handler is FAILED, a COMMAND_LONG retransmitted
(confirmation > 0) after it was carried out gets the first answer again without running twice, a service's
command comes before the table, the link's own rows run on the endpoint the command came in on, SET_MODE for
another system is left alone.
"""

from __future__ import annotations

from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink.command_dispatch import CommandDispatch
from autopilot.mavlink.command_fields import command_long_params

GCS = (255, 190)  # the sender's (sysid, compid)


class Endpoint:
    """What the dispatch needs of an endpoint: it sends the ACK there."""

    def __init__(self) -> None:
        self.sent: list[mavlink.MAVLink_message] = []

    def send(self, msg: mavlink.MAVLink_message) -> None:
        self.sent.append(msg)


class Vehicle:
    """Counts the commands it runs; answers with ``result`` (or raises)."""

    def __init__(self, result: int = mavlink.MAV_RESULT_ACCEPTED, fail: bool = False) -> None:
        self.result, self.fail, self.commands, self.modes = result, fail, [], []

    def handle_command(self, command: int, params: tuple, frame: int) -> int:
        self.commands.append(command)
        if self.fail:
            raise RuntimeError("handler bug")
        return self.result

    def handle_set_mode(self, base_mode: int, custom_mode: int) -> int:
        self.modes.append(custom_mode)
        return mavlink.MAV_RESULT_ACCEPTED


class LinkCommands:
    def __init__(self, ep: Endpoint) -> None:
        self.ep = ep

    def set_message_interval(self, msg_id: int, interval_us: int) -> int:
        return mavlink.MAV_RESULT_ACCEPTED

    def request_message(self, msg_id: int, param2: float) -> int:
        return mavlink.MAV_RESULT_TEMPORARILY_REJECTED

    def send_autopilot_version(self) -> int:
        return mavlink.MAV_RESULT_ACCEPTED

    def say(self, severity: int, text: str) -> None:
        pass


def received(msg: mavlink.MAVLink_message) -> mavlink.MAVLink_message:
    """``msg`` as the link receives it from the ground station GCS (its header's source set)."""
    mav = mavlink.MAVLink(None, *GCS)
    return mav.decode(bytearray(msg.pack(mav)))


def command_long(command: int, confirmation: int = 0, p1: float = 0.0) -> mavlink.MAVLink_message:
    return received(mavlink.MAVLink_command_long_message(1, 1, command, confirmation, p1, 0, 0, 0, 0, 0, 0))


def run(dispatch: CommandDispatch, ep: Endpoint, msg: mavlink.MAVLink_message) -> None:
    dispatch.run(ep, msg, command_long_params(msg), mavlink.MAV_FRAME_GLOBAL)  # type: ignore[arg-type]


def acks(ep: Endpoint) -> list[tuple[int, int, int, int]]:
    return [(m.command, m.result, m.target_system, m.target_component) for m in ep.sent]


def test_one_ack_to_the_sender_and_failed_when_the_handler_raises():
    ep, vehicle = Endpoint(), Vehicle(fail=True)
    dispatch = CommandDispatch(1, vehicle, LinkCommands)
    run(dispatch, ep, command_long(mavlink.MAV_CMD_NAV_LAND))
    assert acks(ep) == [(mavlink.MAV_CMD_NAV_LAND, mavlink.MAV_RESULT_FAILED, *GCS)]
    assert dispatch.source == GCS


def test_a_retransmission_gets_the_first_answer_without_running_again():
    ep, vehicle = Endpoint(), Vehicle(result=mavlink.MAV_RESULT_DENIED)
    dispatch = CommandDispatch(1, vehicle, LinkCommands)
    run(dispatch, ep, command_long(mavlink.MAV_CMD_NAV_TAKEOFF))
    vehicle.result = mavlink.MAV_RESULT_ACCEPTED  # the vehicle would answer otherwise now
    run(dispatch, ep, command_long(mavlink.MAV_CMD_NAV_TAKEOFF, confirmation=1))
    assert vehicle.commands == [mavlink.MAV_CMD_NAV_TAKEOFF]
    assert [a[1] for a in acks(ep)] == [mavlink.MAV_RESULT_DENIED, mavlink.MAV_RESULT_DENIED]
    run(dispatch, ep, command_long(mavlink.MAV_CMD_NAV_TAKEOFF))  # a first transmission again: carried out
    assert vehicle.commands == [mavlink.MAV_CMD_NAV_TAKEOFF] * 2 and acks(ep)[-1][1] == mavlink.MAV_RESULT_ACCEPTED


def test_service_commands_first_then_the_link_rows_on_the_endpoint():
    ep, vehicle = Endpoint(), Vehicle()
    dispatch = CommandDispatch(1, vehicle, LinkCommands)
    dispatch.service_commands[mavlink.MAV_CMD_NAV_LAND] = lambda e, p, frame: mavlink.MAV_RESULT_IN_PROGRESS
    run(dispatch, ep, command_long(mavlink.MAV_CMD_NAV_LAND))
    run(dispatch, ep, command_long(mavlink.MAV_CMD_REQUEST_MESSAGE, p1=mavlink.MAVLINK_MSG_ID_HOME_POSITION))
    assert vehicle.commands == []
    assert [a[1] for a in acks(ep)] == [mavlink.MAV_RESULT_IN_PROGRESS, mavlink.MAV_RESULT_TEMPORARILY_REJECTED]


def test_set_mode_acknowledged_for_us_ignored_for_another_system():
    ep, vehicle = Endpoint(), Vehicle()
    dispatch = CommandDispatch(1, vehicle, LinkCommands)
    custom = 4 << 16 | 3 << 24  # AUTO.LOITER
    dispatch.set_mode(ep, received(mavlink.MAVLink_set_mode_message(2, 1, custom)))  # type: ignore[arg-type]
    assert ep.sent == [] and vehicle.modes == []
    dispatch.set_mode(ep, received(mavlink.MAVLink_set_mode_message(1, 1, custom)))  # type: ignore[arg-type]
    assert acks(ep) == [(mavlink.MAV_CMD_DO_SET_MODE, mavlink.MAV_RESULT_ACCEPTED, *GCS)]
    assert vehicle.modes == [custom]
