"""The onboard payload link: a MAVLink camera beside the flight controller, forwarded to the ground stations.

PX4 SITL opens a third MAVLink link for payloads (its ``px4-rc.mavlink``: local UDP 14280+N, remote 14030+N,
forwarding on) and the simulated camera talks to it as component 100 of the vehicle's system.  The flight
controller is a router between that link and the ground-station links, so QGroundControl and MAVSDK find the
camera through the one connection they have to the vehicle:

* every good packet from the payload link goes, byte for byte (its system, component, sequence and any
  signature kept), to both ground-station endpoints;
* a message from a ground station addressed to another component of this system (``target_component`` not
  ours; 0 counts, since broadcasts are for everyone), and every HEARTBEAT, goes to the payload link.  A message
  for another component only is not handled here as well (:meth:`PayloadLink.route` returns True).

A camera is present while its HEARTBEAT (MAV_TYPE_CAMERA) has been heard within CAMERA_TIMEOUT_US of simulated
time.  Without one, a camera command (capture, video, camera information) addressed to component 100 or to all
components gets MAV_RESULT_UNSUPPORTED from the flight controller and one STATUSTEXT saying there is no camera;
with one, the flight controller leaves a broadcast camera command to the camera, so a client gets one answer.
"""

from __future__ import annotations

from typing import Callable

from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink.endpoint import LinkEndpoint
from autopilot.mavlink.link_service import Handler, ServiceCommand
from mavsim_core import ports
from mavsim_core.mavlink_udp import UdpEndpoint

CAMERA_COMPID = mavlink.MAV_COMP_ID_CAMERA  # 100
CAMERA_TIMEOUT_US = 3_000_000  # a camera unheard this long (simulated time) is gone, as MAVSDK times components out
READ_MAX = 64  # datagrams read from the payload link per update
CAMERA_REQUESTS = frozenset(  # requests for a camera's information (not actions)
    (
        mavlink.MAV_CMD_REQUEST_CAMERA_INFORMATION,
        mavlink.MAV_CMD_REQUEST_CAMERA_SETTINGS,
        mavlink.MAV_CMD_REQUEST_STORAGE_INFORMATION,
        mavlink.MAV_CMD_REQUEST_CAMERA_CAPTURE_STATUS,
        mavlink.MAV_CMD_REQUEST_VIDEO_STREAM_INFORMATION,
        mavlink.MAV_CMD_REQUEST_VIDEO_STREAM_STATUS,
    )
)
# The camera protocol's commands ([MAV] common.xml): what a client sends a camera, the requests and the actions
CAMERA_COMMANDS = CAMERA_REQUESTS | {
    mavlink.MAV_CMD_IMAGE_START_CAPTURE,
    mavlink.MAV_CMD_IMAGE_STOP_CAPTURE,
    mavlink.MAV_CMD_VIDEO_START_CAPTURE,
    mavlink.MAV_CMD_VIDEO_STOP_CAPTURE,
    mavlink.MAV_CMD_VIDEO_START_STREAMING,
    mavlink.MAV_CMD_VIDEO_STOP_STREAMING,
    mavlink.MAV_CMD_SET_CAMERA_MODE,
    mavlink.MAV_CMD_SET_CAMERA_ZOOM,
    mavlink.MAV_CMD_SET_CAMERA_FOCUS,
    mavlink.MAV_CMD_STORAGE_FORMAT,
    mavlink.MAV_CMD_RESET_CAMERA_SETTINGS,
}
NO_CAMERA = "No camera on this vehicle"  # (a STATUSTEXT: one chunk)


class PayloadLink:
    """The payload link's socket and the routing both ways (a :class:`~autopilot.mavlink.link_service.LinkService`;
    :meth:`route` is the ground-station link's ``router``)."""

    def __init__(
        self,
        gcs_endpoints: tuple[LinkEndpoint, ...],
        sysid: int,
        compid: int,
        instance: int,
        send_statustext: Callable[[int, str], None],
        local_port: int | None = None,
        camera_port: int | None = None,
    ) -> None:
        local = ports.payload_local_port(instance) if local_port is None else local_port
        remote = ports.camera_port(instance) if camera_port is None else camera_port
        self.ep = UdpEndpoint("payload link", ("0.0.0.0", local), ("127.0.0.1", remote), sysid, compid)
        self.gcs_endpoints, self.sysid, self.compid = gcs_endpoints, sysid, compid
        self._statustext = send_statustext
        self._now_us = 0
        self.cameras: dict[int, int] = {}  # component id -> simulated time (µs) its HEARTBEAT was last heard
        self.forwarded_up = self.forwarded_down = self.rx_damaged = 0

    # -- the LinkService protocol
    def handlers(self) -> dict[str, Handler]:
        return {}

    def commands(self) -> dict[int, ServiceCommand]:
        """Camera commands addressed to the flight controller, or to all components while no camera is present
        (:meth:`route` keeps those for the camera otherwise): refused (:meth:`_no_camera`)."""
        return {cmd: self._refusal(cmd) for cmd in CAMERA_COMMANDS}

    def _refusal(self, command: int) -> ServiceCommand:
        """The handler of ``command`` that refuses it (:meth:`_no_camera`)."""
        return lambda _ep, _params, _frame: self._no_camera(command)

    def update(self, now_us: int) -> None:
        """What the payload link sent since the last call, forwarded to the ground stations."""
        self._now_us = now_us
        for _ in range(READ_MAX):
            got = self.ep.recv()
            if got is None:
                break
            msgs, damaged = self.ep.incoming(*got)
            self.rx_damaged += damaged
            for msg in msgs:
                if msg.get_type() == "HEARTBEAT" and msg.type == mavlink.MAV_TYPE_CAMERA:
                    self.cameras[msg.get_srcComponent()] = now_us
                packet = bytes(msg.get_msgbuf())
                for gep in self.gcs_endpoints:
                    gep.write(packet)
                self.forwarded_up += 1

    # -- ground station -> payload
    def camera_present(self) -> bool:
        return any(self._now_us - t <= CAMERA_TIMEOUT_US for t in self.cameras.values())

    def route(self, ep: LinkEndpoint, msg: mavlink.MAVLink_message) -> bool:
        """Forward ``msg`` (from a ground station on ``ep``) to the payload link if it is for another component of
        this system or a HEARTBEAT; True if it was for another component only (the link then leaves it)."""
        target_sys = getattr(msg, "target_system", None)
        target_comp = getattr(msg, "target_component", None)
        heartbeat = msg.get_type() == "HEARTBEAT"
        if not heartbeat and (target_comp is None or target_sys not in (0, self.sysid) or target_comp == self.compid):
            return False
        camera = self.camera_present()
        if camera or heartbeat or target_comp not in (0, CAMERA_COMPID):
            self.ep.send_datagram(bytes(msg.get_msgbuf()))
            self.forwarded_down += 1
        if heartbeat:  # (a ground station's: the link keeps its data-link watch on it)
            return False
        if target_comp == 0:  # a broadcast: ours too, but a camera command is the camera's when there is one
            return camera and _command(msg) in CAMERA_COMMANDS
        if target_comp == CAMERA_COMPID and not camera and _command(msg) is not None:
            self._refuse(ep, msg)
        return True

    def _refuse(self, ep: LinkEndpoint, msg: mavlink.MAVLink_message) -> None:
        """A command for a camera that is not there: MAV_RESULT_UNSUPPORTED (from the flight controller, which
        routes for it) and, unless it asked for information, the reason."""
        src = msg.get_srcSystem(), msg.get_srcComponent()
        ep.send(mavlink.MAVLink_command_ack_message(msg.command, mavlink.MAV_RESULT_UNSUPPORTED, 0, 0, *src))
        self._say_why(msg.command)

    def _no_camera(self, command: int) -> int:
        """A camera command the flight controller runs itself (to it, or to all with no camera present): it has
        no camera of its own (PX4 answers so too).  An action (a capture, a video) says why; a request for a
        camera's information is how clients look for cameras, so it is refused quietly."""
        self._say_why(command)
        return mavlink.MAV_RESULT_UNSUPPORTED

    def _say_why(self, command: int) -> None:
        """The STATUSTEXT of a refused camera command, unless it only asked for information."""
        if command not in CAMERA_REQUESTS and command != mavlink.MAV_CMD_REQUEST_MESSAGE:
            self._statustext(mavlink.MAV_SEVERITY_WARNING, NO_CAMERA)

    def close(self) -> None:
        self.ep.close()


def _command(msg: mavlink.MAVLink_message) -> int | None:
    """The command number of a COMMAND_LONG or COMMAND_INT, else None."""
    return msg.command if msg.get_type() in ("COMMAND_LONG", "COMMAND_INT") else None
