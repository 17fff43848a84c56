"""One command in, exactly one COMMAND_ACK out: how the link runs COMMAND_LONG, COMMAND_INT and SET_MODE.

A command (:class:`CommandDispatch.run`) goes, in this order, to:

* the retransmission check (:mod:`autopilot.mavlink.command_retries`): a COMMAND_LONG resent with
  ``confirmation`` > 0 after the first was carried out gets that first answer again, and nothing else happens;
* a link service's command (:mod:`autopilot.mavlink.link_service`), which comes before the table;
* the command table (:func:`autopilot.mavlink.commands.run`): the link's own rows on the endpoint it came in on
  (``link_commands(endpoint)``), every other command to the vehicle.

A handler that raises is answered MAV_RESULT_FAILED.  The ACK goes to the sender through the endpoint the
command came in on; DO_AUTOTUNE_ENABLE's carries the run's progress (per cent).  While a command runs,
:attr:`CommandDispatch.source` is its sender (services read it: who configures the gimbal).
SET_MODE (QGroundControl) is acknowledged the same way, as PX4 does, with the message id as the command.
"""

from __future__ import annotations

import logging
from typing import Any, Callable

from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink import commands
from autopilot.mavlink.autotune_command import autotune_progress
from autopilot.mavlink.command_retries import RetransmittedCommands
from autopilot.mavlink.endpoint import LinkEndpoint
from autopilot.mavlink.link_service import ServiceCommand

log = logging.getLogger(__name__)


class CommandDispatch:
    """Runs the commands addressed to system ``sysid`` on ``vehicle`` (a VehicleInterface), the link's own on
    ``link_commands(endpoint)`` (a :class:`commands.LinkCommands`); ``service_commands`` is filled by the link
    as services are added."""

    def __init__(self, sysid: int, vehicle: Any, link_commands: Callable[[LinkEndpoint], commands.LinkCommands]):
        self.sysid, self.vehicle, self._link_commands = sysid, vehicle, link_commands
        self.service_commands: dict[int, ServiceCommand] = {}
        self.source: tuple[int, int] = (0, 0)  # (sysid, compid) of the command being run, for services
        self._retransmitted = RetransmittedCommands()  # COMMAND_LONG resent with confirmation > 0 (command_retries)

    def run(self, ep: LinkEndpoint, msg: mavlink.MAVLink_message, params: commands.Params, frame: int) -> None:
        """Execute a command through the command table and send exactly one COMMAND_ACK."""
        command = msg.command
        sender, long = (msg.get_srcSystem(), msg.get_srcComponent()), msg.get_type() == "COMMAND_LONG"
        earlier = self._retransmitted.earlier_result(sender, command, params, msg.confirmation) if long else None
        if earlier is not None:  # a copy of a command carried out, its ACK lost: that answer again, nothing else
            _ack(ep, msg, command, earlier)
            return
        self.source = sender
        try:
            service = self.service_commands.get(command)
            if service is not None:
                result = int(service(ep, params, frame))
            else:
                result = commands.run(command, params, frame, self._link_commands(ep), self.vehicle)
        except Exception:
            log.exception("gcs_link: command %d failed", command)
            result = mavlink.MAV_RESULT_FAILED
        if long:
            self._retransmitted.carried_out(sender, command, params, result)
        autotune = command == mavlink.MAV_CMD_DO_AUTOTUNE_ENABLE  # its ACK carries the run's progress (per cent)
        _ack(ep, msg, command, result, autotune_progress(self.vehicle) if autotune else 0)

    def set_mode(self, ep: LinkEndpoint, msg: mavlink.MAVLink_message) -> None:
        """SET_MODE for our system (or all): the vehicle's answer as a COMMAND_ACK."""
        if msg.target_system not in (0, self.sysid):
            return
        try:
            result = int(self.vehicle.handle_set_mode(msg.base_mode, msg.custom_mode))
        except Exception:
            log.exception("gcs_link: SET_MODE failed")
            result = mavlink.MAV_RESULT_FAILED
        _ack(ep, msg, mavlink.MAV_CMD_DO_SET_MODE, result)  # PX4 runs SET_MODE as DO_SET_MODE, and acks that


def _ack(ep: LinkEndpoint, msg: mavlink.MAVLink_message, command: int, result: int, progress: int = 0) -> None:
    src = (msg.get_srcSystem(), msg.get_srcComponent())
    ep.send(mavlink.MAVLink_command_ack_message(command, result, progress, 0, *src))
