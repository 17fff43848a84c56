"""The link's own requests: messages sent once when asked, and message intervals, on the asking endpoint.

* :class:`OneShotMessages`: MAV_CMD_REQUEST_MESSAGE's answers (PARAM_VALUE by index, MESSAGE_INTERVAL, a
  service's message from ``requestable``, any message the link streams) and AUTOPILOT_VERSION;
* :class:`EndpointCommands`: the link's rows of the command table (:class:`commands.LinkCommands`) on the
  endpoint a command came in on;
* :class:`MessageRequests`, a :class:`~autopilot.mavlink.link_service.LinkService` the link adds to itself:

  * MAV_CMD_GET_MESSAGE_INTERVAL (param1: the message id): MESSAGE_INTERVAL on the asking endpoint with
    that endpoint's interval (µs; -1 off; 0 a message the link cannot stream, acknowledged
    MAV_RESULT_UNSUPPORTED), as REQUEST_MESSAGE 244 does with param2;
  * the older one-message requests PX4 still answers, each the same as REQUEST_MESSAGE of its message:
    MAV_CMD_REQUEST_PROTOCOL_VERSION (PROTOCOL_VERSION, 300) and MAV_CMD_REQUEST_FLIGHT_INFORMATION
    (FLIGHT_INFORMATION, 264).

Each takes what it answers from explicitly (the parameter service, the telemetry streams, the identity, the
simulated time), never the link.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Callable

from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink.endpoint import LinkEndpoint
from autopilot.mavlink.identity import Identity, autopilot_version
from autopilot.mavlink.link_service import Handler, ServiceCommand
from autopilot.mavlink.protocol_version import MAVLINK_MSG_ID_PROTOCOL_VERSION

if TYPE_CHECKING:
    from autopilot.mavlink.param_service import ParamService
    from autopilot.mavlink.telemetry_streams import TelemetryStreams

# (severity, text, endpoint name or None: both) -> a STATUSTEXT (GcsLink.send_statustext)
Say = Callable[[int, str, "str | None"], None]


class OneShotMessages:
    """The messages the link sends once when asked, on the asking endpoint; ``now_us()`` is the simulated time.

    ``requestable``: message id -> ``send(endpoint)`` -> MAV_RESULT, a service's messages (e.g.
    COMPONENT_METADATA), asked before the streamed ones."""

    def __init__(
        self, params: ParamService, streams: TelemetryStreams, identity: Identity, now_us: Callable[[], int]
    ) -> None:
        self._params, self._streams, self._identity, self._now_us = params, streams, identity, now_us
        self.requestable: dict[int, Callable[[LinkEndpoint], int]] = {}

    def request(self, ep: LinkEndpoint, msg_id: int, param2: float) -> int:
        """MAV_CMD_REQUEST_MESSAGE: send the message once on ``ep`` (``param2``: PARAM_VALUE's index,
        MESSAGE_INTERVAL's message id); any message the link streams (telemetry_more.link_builders)."""
        if msg_id == mavlink.MAVLINK_MSG_ID_PARAM_VALUE:
            return self._params.request_message(ep, param2)
        if msg_id == mavlink.MAVLINK_MSG_ID_MESSAGE_INTERVAL:
            return ep.report_interval(param2)
        if msg_id in self.requestable:  # a service's message
            return self.requestable[msg_id](ep)
        builder = self._streams.builders.get(msg_id)
        if builder is None:
            return mavlink.MAV_RESULT_UNSUPPORTED
        msg = builder(self._streams.snapshot(), self._now_us())
        if msg is None:  # e.g. HOME_POSITION before home is set
            return mavlink.MAV_RESULT_TEMPORARILY_REJECTED
        ep.send(msg)
        return mavlink.MAV_RESULT_ACCEPTED

    def autopilot_version(self, ep: LinkEndpoint) -> int:
        ep.send(autopilot_version(self._identity))
        return mavlink.MAV_RESULT_ACCEPTED


class EndpointCommands:
    """The link's own commands (:class:`commands.LinkCommands`) on the endpoint a command came in on, at
    simulated time ``now_us``; ``say`` sends a STATUSTEXT."""

    def __init__(self, messages: OneShotMessages, ep: LinkEndpoint, now_us: int, say: Say) -> None:
        self.messages, self.ep, self.now_us, self._say = messages, ep, now_us, say

    def set_message_interval(self, msg_id: int, interval_us: int) -> int:
        return self.ep.set_interval(msg_id, interval_us, self.now_us)

    def request_message(self, msg_id: int, param2: float) -> int:
        return self.messages.request(self.ep, msg_id, param2)

    def send_autopilot_version(self) -> int:
        return self.messages.autopilot_version(self.ep)

    def say(self, severity: int, text: str) -> None:
        """A STATUSTEXT on this endpoint (why a command of the link's was refused)."""
        self._say(severity, text, self.ep.name)


class MessageRequests:
    """The link service of GET_MESSAGE_INTERVAL and the older one-message requests (see the module docstring)."""

    def __init__(self, messages: OneShotMessages) -> None:
        self.messages = messages

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
        return self.messages.request(ep, msg_id, 0.0)
