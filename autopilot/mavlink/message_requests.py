"""The link's own message requests besides the command table's (SET_MESSAGE_INTERVAL, REQUEST_MESSAGE).

A :class:`~autopilot.mavlink.link_service.LinkService` the link adds to itself:

* MAV_CMD_GET_MESSAGE_INTERVAL (param1: the message id): MESSAGE_INTERVAL on the asking endpoint with
  that endpoint's interval (µs; -1 off; 0 a message the link cannot stream, acknowledged
  MAV_RESULT_UNSUPPORTED), as REQUEST_MESSAGE 244 does with param2;
* the older one-message requests PX4 still answers, each the same as REQUEST_MESSAGE of its message:
  MAV_CMD_REQUEST_PROTOCOL_VERSION (PROTOCOL_VERSION, 300) and MAV_CMD_REQUEST_FLIGHT_INFORMATION
  (FLIGHT_INFORMATION, 264).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink.endpoint import EndpointCommands, LinkEndpoint
from autopilot.mavlink.link_service import Handler, ServiceCommand
from autopilot.mavlink.protocol_version import MAVLINK_MSG_ID_PROTOCOL_VERSION

if TYPE_CHECKING:
    from autopilot.mavlink.link import GcsLink


class MessageRequests:
    """See the module docstring."""

    def __init__(self, link: GcsLink) -> None:
        self.link = link

    def handlers(self) -> dict[str, Handler]:
        return {}

    def commands(self) -> dict[int, ServiceCommand]:
        return {
            mavlink.MAV_CMD_GET_MESSAGE_INTERVAL: lambda ep, p, frame: ep.report_interval(p[0]),
            mavlink.MAV_CMD_REQUEST_PROTOCOL_VERSION: lambda ep, p, frame: self._request(
                ep, MAVLINK_MSG_ID_PROTOCOL_VERSION
            ),
            mavlink.MAV_CMD_REQUEST_FLIGHT_INFORMATION: lambda ep, p, frame: self._request(
                ep, mavlink.MAVLINK_MSG_ID_FLIGHT_INFORMATION
            ),
        }

    def update(self, now_us: int) -> None:
        pass

    def _request(self, ep: LinkEndpoint, msg_id: int) -> int:
        return EndpointCommands(self.link, ep).request_message(msg_id, 0.0)
