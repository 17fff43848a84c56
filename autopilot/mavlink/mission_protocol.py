"""The MAVLink mission protocol, as far as it exists today: an empty mission.

Missions are not flown yet; these answers make sure a client never waits for one:
MISSION_REQUEST_LIST gets MISSION_COUNT 0 (any mission type), MISSION_CLEAR_ALL is
accepted, and an upload (MISSION_COUNT) is accepted only when empty.  The link calls
these only for messages addressed to this system and component.
"""

from __future__ import annotations

from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink.endpoint import LinkEndpoint


def on_mission_request_list(ep: LinkEndpoint, msg: mavlink.MAVLink_message) -> None:
    ep.send(mavlink.MAVLink_mission_count_message(msg.get_srcSystem(), msg.get_srcComponent(), 0, msg.mission_type))


def on_mission_clear_all(ep: LinkEndpoint, msg: mavlink.MAVLink_message) -> None:
    _mission_ack(ep, msg, mavlink.MAV_MISSION_ACCEPTED)


def on_mission_count(ep: LinkEndpoint, msg: mavlink.MAVLink_message) -> None:
    _mission_ack(ep, msg, mavlink.MAV_MISSION_ACCEPTED if msg.count == 0 else mavlink.MAV_MISSION_UNSUPPORTED)


def _mission_ack(ep: LinkEndpoint, msg: mavlink.MAVLink_message, result: int) -> None:
    ep.send(mavlink.MAVLink_mission_ack_message(msg.get_srcSystem(), msg.get_srcComponent(), result, msg.mission_type))


# Message type -> handler.
HANDLERS = {
    "MISSION_REQUEST_LIST": on_mission_request_list,
    "MISSION_CLEAR_ALL": on_mission_clear_all,
    "MISSION_COUNT": on_mission_count,
}
