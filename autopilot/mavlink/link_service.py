"""What a protocol served on the ground-station link provides, besides telemetry and the command table.

A service (the log protocol, MAVLink FTP, message signing, failure injection, follow-me input, ...)
is added to the link once at start-up (:meth:`autopilot.mavlink.link.GcsLink.add_service`) and
gives the link three things:

* ``handlers()``: MAVLink message type -> ``handler(endpoint, msg)``; the link calls it only for
  messages addressed to this system and component (or broadcast, or with no target fields);
* ``commands()``: MAV_CMD number -> ``command(endpoint, params, frame)`` returning a MAV_RESULT;
  the link sends the one COMMAND_ACK; these rows come before the command table's
  (:mod:`autopilot.mavlink.commands`);
* ``update(now_us)``: called in every link update (50 Hz of simulated time) and every poll that
  found something, for work that spans calls (a file sent in bursts, a timeout).

Replies go out through the endpoint the request came in on (``endpoint.send(msg)``), so they
reach the client that asked on whatever port it uses.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Callable, Protocol

from pymavlink.dialects.v20 import common as mavlink

if TYPE_CHECKING:
    from autopilot.mavlink.endpoint import LinkEndpoint

Handler = Callable[["LinkEndpoint", mavlink.MAVLink_message], None]
# (endpoint, the command's seven params (param1..param7, x/y as given), frame) -> MAV_RESULT
ServiceCommand = Callable[["LinkEndpoint", tuple, int], int]


class LinkService(Protocol):
    """A protocol the link serves (see the module docstring)."""

    def handlers(self) -> dict[str, Handler]: ...

    def commands(self) -> dict[int, ServiceCommand]: ...

    def update(self, now_us: int) -> None: ...
