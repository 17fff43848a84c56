"""The protocols the ground-station link serves besides telemetry, commands, parameters and plans.

Called once by the process (``autopilot/__main__.py``) after the link, the flight controller and
the simulator link exist; each service is a :class:`autopilot.mavlink.link_service.LinkService`.
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from autopilot.flight_controller import FlightController
    from autopilot.flight_recorder import FlightRecorder
    from autopilot.mavlink.link import GcsLink
    from autopilot.mavlink.sim_link import SimLink


def add_link_services(
    link: GcsLink, fc: FlightController, sim: SimLink, args: argparse.Namespace, recorder: FlightRecorder | None = None
) -> None:
    """Add every service to ``link`` (``args``: the process's parsed command line; ``recorder``: the flight
    logs being written, None without)."""
    from pathlib import Path

    # Parameters (--state-dir): every change is on the disk before the PARAM_VALUE that acknowledges it
    # (autopilot/param_storage.py); None: nothing is saved.
    link.param_service.persist = fc.commander.param_saver

    from autopilot.mavlink.log_service import LogService

    # The log protocol: the ULogs in --log-dir (none with --no-log, or if the directory could not be made).
    log_dir = None if args.no_log or recorder is None else Path(args.log_dir)
    link.add_service(LogService(log_dir, args.instance, lambda: recorder.writing if recorder is not None else None))

    from autopilot.mavlink.file_services import file_services

    # MAVLink FTP, read-only (/log: the same directory; /component_metadata) and COMPONENT_METADATA.
    files = file_services(fc.params, log_dir, fc.spec.name, lambda: link.now_us)
    link.add_service(files.ftp)
    link.requestable.update(files.requestable)

    from autopilot.mavlink.follow_target_input import FollowTargetInput

    # FOLLOW_TARGET (MAVSDK FollowMe, the ground vehicle's broadcast) -> the target AUTO.FOLLOW_TARGET follows.
    link.add_service(FollowTargetInput(fc.commander.inputs, lambda: link.now_us, link.send_statustext))

    from autopilot.mavlink.failure_injection import FailureInjection, SimParamBridge

    # MAV_CMD_INJECT_FAILURE (SYS_FAILURE_EN): the simulator's SIM_* faults, set over the simulator link.
    link.add_service(FailureInjection(fc.params, SimParamBridge(sim), len(fc.spec.rotors), link.send_statustext))

    from autopilot.mavlink.signing import SigningService
    from autopilot.signing_storage import signing_file

    # MAVLink 2 signing: SETUP_SIGNING sets the key of both endpoints, kept in --state-dir (docs/security.md).
    key_file = signing_file(args.state_dir, fc.spec.name, args.instance) if args.state_dir else None
    what = f"{fc.spec.name} instance {args.instance}"
    link.add_service(SigningService(link.endpoints, link.sysid, link.compid, link.send_statustext, key_file, what=what))

    from autopilot.mavlink.gimbal_manager import GimbalManager

    # Gimbal protocol v2: the gimbal manager, its device on the simulator link (advertised once it reports); it
    # publishes the device's reach to the commander (a precision landing's view cone, PLD_CAM_REACH -1).
    def broadcast_as(msg, compid: int) -> None:
        for ep in link.endpoints:
            ep.send_as(msg, compid)

    gimbal = GimbalManager(
        fc.params, lambda: fc.commander.status, sim.queue, broadcast_as, link.send_statustext,
        lambda: link.command_source, (link.sysid, link.compid), fc.commander.inputs.on_gimbal_reach,
    )  # fmt: skip
    link.add_service(gimbal)
    link.requestable.update(gimbal.requestable())
    sim.device_handlers.update(gimbal.device_handlers())
    sim.device_steps.append(gimbal.control_step)

    from autopilot.mavlink.payload_link import PayloadLink

    # The onboard payload link (PX4's 14280+N <-> 14030+N): the simulated camera (component 100), forwarded both ways.
    payload = PayloadLink(
        link.endpoints, link.sysid, link.compid, args.instance, link.send_statustext,
        args.payload_local_port, args.camera_port,
    )  # fmt: skip
    link.add_service(payload)
    link.router = payload.route
