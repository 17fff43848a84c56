"""Ground-station side of the flight controller: MAVLink over UDP, as PX4 SITL does it.

Two UDP endpoints, with the ports of PX4's multi-vehicle scheme for instance i
(:mod:`mavsim_core.ports`) unless given:

* "gcs": bound to 0.0.0.0:18570+i, telemetry to 127.0.0.1:14550, shared by every instance
  (QGroundControl listens there and shows each instance's system id as its own vehicle);
* "api": bound to 0.0.0.0:14640+i, telemetry to 127.0.0.1:14540+i (MAVSDK listens there).

Whoever talks to an endpoint becomes (also) a destination of it, so replies reach clients on
any port.  The link has no flight logic: telemetry comes from :meth:`VehicleInterface.snapshot`
through the pure builders of :mod:`autopilot.mavlink.telemetry`, commands are run with one
COMMAND_ACK each by :mod:`autopilot.mavlink.command_dispatch` through the one command table
(:mod:`autopilot.mavlink.commands`), message intervals and one-shot messages (REQUEST_MESSAGE,
AUTOPILOT_VERSION) are :mod:`autopilot.mavlink.message_requests`', parameters are served by
:mod:`autopilot.mavlink.param_service`, mission, fence and rally plans by
:mod:`autopilot.mavlink.mission_protocol`.  The link composes them: it keeps the sockets
(:mod:`autopilot.mavlink.endpoint`), the stream schedules (:mod:`autopilot.mavlink.telemetry_streams`),
TIMESYNC, STATUSTEXT, MISSION_ITEM_REACHED and the traffic tap, and hands each helper what it needs (an
endpoint, the builders, a send function, the clock), never itself.  What arrives is read by
:mod:`autopilot.mavlink.rx_drain` (every socket drained each call, a CPU-time budget for handling, commands
first past it: a flood cannot block LAND).

:meth:`GcsLink.update` (50 Hz) receives, answers and streams; :meth:`GcsLink.poll` (the other
steps) only answers what has arrived.  What one call sends to a destination goes out packed
into as few datagrams as fit MAX_DATAGRAM_BYTES, as PX4's UDP links buffer theirs.

Time: both receive the SIMULATED time (lockstep, microseconds); stream intervals are measured
in it.  Only the mission protocol's retries run on the wall clock (the client waits in it).
"""

from __future__ import annotations

import logging
from typing import Callable

from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink import commands
from autopilot.mavlink.command_dispatch import CommandDispatch
from autopilot.mavlink.endpoint import MIN_STREAM_INTERVAL_US, LinkEndpoint
from autopilot.mavlink.identity import Identity, instance_identity
from autopilot.mavlink.link_service import Handler, LinkService
from autopilot.mavlink.message_requests import EndpointCommands, MessageRequests, OneShotMessages
from autopilot.mavlink.mission_protocol import MissionService
from autopilot.mavlink.param_service import ParamService
from autopilot.mavlink.rx_drain import RxCounters, RxDrain
from autopilot.mavlink.telemetry import DEFAULT_FLIGHT_SW_VERSION
from autopilot.mavlink.telemetry_more import DEFAULT_STREAM_RATES_HZ, link_builders
from autopilot.mavlink.telemetry_streams import TelemetryStreams
from autopilot.mavlink.vehicle_interface import VehicleInterface
from mavsim_core import ports
from mavsim_core.statustext import StatustextChunker

log = logging.getLogger(__name__)


class GcsLink:
    """MAVLink ground-station link of the flight controller (PX4 SITL identity and ports).

    Construct it once, call :meth:`update` every control iteration with the simulated
    time, :meth:`close` at exit.  Counters: ``rx_errors`` (damaged input, failed
    handlers), ``rx_messages`` (good messages handled), ``rx_dropped`` and ``rx_foreign`` (datagrams
    dropped unparsed: no time left, addressed to other systems), ``tx_errors`` (failed sends).
    """

    def __init__(
        self,
        vehicle: VehicleInterface,
        instance: int = 0,
        sysid: int = 1,
        compid: int = 1,
        gcs_port: int | None = None,
        api_port: int | None = None,
        local_gcs_port: int | None = None,
        local_api_port: int | None = None,
        *,
        remote_host: str = "127.0.0.1",
        bind_host: str = "0.0.0.0",
        stream_rates_hz: dict[int, float] | None = None,
        flight_sw_version: int = DEFAULT_FLIGHT_SW_VERSION,
        middleware_sw_version: int = 0,
        os_sw_version: int = 0,
        board_version: int = 0,
        flight_custom_version: bytes | None = None,
        vendor_id: int = 0,
        product_id: int = 0,
        uid: int | None = None,
        uid2: bytes | None = None,
    ) -> None:
        """
        Ports not given are those of ``instance`` (:mod:`mavsim_core.ports`); ``sysid`` is as given.
        ``stream_rates_hz``: message id -> rate (Hz of simulated time) for the streams on
        both endpoints, replacing :data:`DEFAULT_STREAM_RATES_HZ` entries (0 disables); any message
        of :func:`telemetry_more.link_builders` (off unless a default or given).
        The AUTOPILOT_VERSION fields are reported as given; ``flight_custom_version`` defaults to the running
        code's git commit, ``uid`` and ``uid2`` to non-zero values derived from instance and sysid
        (:mod:`autopilot.mavlink.identity`).
        """
        self.vehicle = vehicle
        self.sysid = sysid
        self.compid = compid
        self.instance = instance
        self.identity: Identity = instance_identity(
            instance, sysid, flight_sw_version=flight_sw_version, middleware_sw_version=middleware_sw_version,
            os_sw_version=os_sw_version, board_version=board_version, flight_custom_version=flight_custom_version,
            vendor_id=vendor_id, product_id=product_id, uid=uid, uid2=uid2,
        )  # fmt: skip
        builders = link_builders(self.identity, sysid)
        unknown = set(stream_rates_hz or {}) - set(builders)
        if unknown:
            raise ValueError(f"gcs_link cannot stream message ids {sorted(unknown)}; streams: {sorted(builders)}")
        rates = {mid: 0.0 for mid in builders} | DEFAULT_STREAM_RATES_HZ | (stream_rates_hz or {})
        intervals = {m: max(int(round(1e6 / hz)), MIN_STREAM_INTERVAL_US) if hz > 0 else -1 for m, hz in rates.items()}
        self._endpoints: list[LinkEndpoint] = []
        try:
            for name, local, remote in (
                ("gcs", local_gcs_port or ports.gcs_local_port(instance), gcs_port or ports.GCS_PORT),
                ("api", local_api_port or ports.api_local_port(instance), api_port or ports.api_port(instance)),
            ):
                self._endpoints.append(
                    LinkEndpoint(name, (bind_host, local), (remote_host, remote), sysid, compid, intervals)
                )
        except OSError:
            self.close()
            raise
        self.rx_messages = 0  # good messages handled
        # damaged input and failed handlers; dropped unparsed: no time left in a call, for other systems
        self._rx_counts = RxCounters()
        self._rx = RxDrain(sysid, self._endpoints, self._handle_datagram, self._rx_counts)
        self._now_us = 0
        self._streams = TelemetryStreams(vehicle, self._endpoints, builders)
        self._statustext = StatustextChunker()
        self._params = ParamService(vehicle.params, self.send_statustext, self._broadcast)
        self._missions = MissionService(vehicle, self.send_statustext, sysid, compid)
        self._missions.on_current_changed = lambda: self._streams.due_now(mavlink.MAVLINK_MSG_ID_MISSION_CURRENT)
        self._tap: Callable[[int, str, bool, bytes], None] | None = None
        self._services: list[LinkService] = []
        self._messages = OneShotMessages(self._params, self._streams, self.identity, lambda: self._now_us)
        self._commands = CommandDispatch(sysid, vehicle, self._link_commands)
        # Messages a service sends on MAV_CMD_REQUEST_MESSAGE (message id -> send(endpoint) -> MAV_RESULT),
        # before the streamed ones: e.g. COMPONENT_METADATA (autopilot/mavlink/component_metadata.py).
        self.requestable: dict[int, Callable[[LinkEndpoint], int]] = self._messages.requestable
        self._handlers = self._message_handlers()
        self.router: Callable[[LinkEndpoint, mavlink.MAVLink_message], bool] | None = None  # (payload_link.py)
        self.add_service(MessageRequests(self._messages))  # GET_MESSAGE_INTERVAL and the old one-message requests

    def _message_handlers(self) -> dict[str, Handler]:
        """Message type -> handler; those wrapped in _for_us only see messages addressed to this system and
        component."""
        handlers: dict[str, Handler] = {
            "HEARTBEAT": self._on_heartbeat,
            # sticks (RC) and offboard setpoints: the vehicle decodes them (vehicle_interface)
            "MANUAL_CONTROL": self._on_control,
            "SET_POSITION_TARGET_LOCAL_NED": self._on_control,
            "SET_POSITION_TARGET_GLOBAL_INT": self._on_control,
            "SET_ATTITUDE_TARGET": self._on_control,
            "PING": lambda ep, msg: None,
            "COMMAND_LONG": self._for_us(
                lambda ep, msg: self._commands.run(ep, msg, commands.command_long_params(msg), mavlink.MAV_FRAME_GLOBAL)
            ),
            "COMMAND_INT": self._for_us(
                lambda ep, msg: self._commands.run(ep, msg, commands.command_int_params(msg), msg.frame)
            ),
            "SET_MODE": self._commands.set_mode,
            "PARAM_REQUEST_LIST": self._for_us(self._params.on_request_list),
            "PARAM_REQUEST_READ": self._for_us(self._params.on_request_read),
            "PARAM_SET": self._for_us(self._params.on_set),
            "TIMESYNC": self._on_timesync,
            # a companion computer's landing target (vision): the vehicle checks the sender's system id
            "LANDING_TARGET": lambda ep, msg: self.vehicle.on_landing_target(msg, msg.get_srcSystem()),
        }
        handlers.update({name: self._for_us(h) for name, h in self._missions.handlers().items()})
        return handlers

    # ------------------------------------------------------------------ public API

    def add_service(self, service: LinkService) -> None:
        """Serve ``service`` (:mod:`autopilot.mavlink.link_service`): its messages addressed to us, its
        commands before the command table's, its ``update`` in every :meth:`update` and :meth:`poll`."""
        self._handlers.update({name: self._for_us(h) for name, h in service.handlers().items()})
        self._commands.service_commands.update(service.commands())
        self._services.append(service)

    @property
    def endpoints(self) -> tuple[LinkEndpoint, ...]:
        """The "gcs" and "api" endpoints (for services that act on both, e.g. message signing)."""
        return tuple(self._endpoints)

    @property
    def param_service(self) -> ParamService:
        """The parameter protocol (the process sets its ``persist``: changes saved before acknowledged)."""
        return self._params

    @property
    def command_source(self) -> tuple[int, int]:
        """The (sysid, compid) of the command being run (or the last one), for services."""
        return self._commands.source

    @property
    def now_us(self) -> int:
        """The simulated time (µs) of the current or last update."""
        return self._now_us

    @property
    def tx_build_errors(self) -> int:
        """Stream messages that could not be built (a bug in a snapshot?)."""
        return self._streams.tx_build_errors

    @property
    def tx_errors(self) -> int:
        return sum(ep.tx_errors for ep in self._endpoints)

    @property
    def rx_errors(self) -> int:
        """Damaged datagrams and failed handlers."""
        return self._rx_counts.rx_errors

    @rx_errors.setter
    def rx_errors(self, value: int) -> None:
        self._rx_counts.rx_errors = value

    @property
    def rx_dropped(self) -> int:
        """Datagrams for us dropped unparsed: no time left in a call (or a full backlog)."""
        return self._rx_counts.rx_dropped

    @rx_dropped.setter
    def rx_dropped(self, value: int) -> None:
        self._rx_counts.rx_dropped = value

    @property
    def rx_foreign(self) -> int:
        """Datagrams addressed to other systems only, dropped unparsed."""
        return self._rx_counts.rx_foreign

    def set_traffic_tap(self, tap: Callable[[int, str, bool, bytes], None] | None) -> None:
        """Hand every packet the link sends or receives to ``tap(now_us, endpoint, sent, packet)`` (a .tlog).

        ``now_us`` is the simulated time of the current update; ``endpoint`` is "gcs" or "api";
        received packets are the good MAVLink messages from other systems.  None removes the tap.
        """
        self._tap = tap
        for ep in self._endpoints:
            ep.tap = None if tap is None else (lambda data, name=ep.name: tap(self._now_us, name, True, data))

    def update(self, now_us: int) -> None:
        """One link iteration at simulated time ``now_us`` (µs): receive, answer, stream."""
        if now_us < self._now_us:  # simulated clock restarted: restart the schedules
            self._streams.restart(now_us)
        self._now_us = now_us
        self._streams.begin(now_us)
        for ep in self._endpoints:
            ep.begin_batch()
        try:
            self._update(now_us)
        finally:
            for ep in self._endpoints:
                ep.flush()

    def poll(self, now_us: int) -> None:
        """Answer what has arrived, without streaming: one poll(2) of both sockets when nothing came, so
        it can run every step and a mission upload moves an item a step, not an update."""
        rx = self._rx
        if not rx.backlog and not rx.sockets.poll(0):  # (rx.pending()) one poll(2) of both sockets: nothing came
            return
        self._now_us = max(self._now_us, now_us)
        self._streams.begin(self._now_us)
        for ep in self._endpoints:
            ep.begin_batch()
        try:
            self._receive(poll=True)
            self._send_events()
            for service in self._services:
                service.update(self._now_us)
        finally:
            for ep in self._endpoints:
                ep.flush()

    def serve_held(self, now_us: int) -> None:
        """While the simulator holds (``autopilot/lockstep_loop.py``): :meth:`poll`, then the parameter service,
        so a PARAM_SET is echoed, a read of a value being saved answered and a list continued during the hold
        (they would wait for the next :meth:`update`, which no step comes to run).  Nothing here streams, and
        nothing it sends changes what the vehicle does: a held run stays the same whatever the hold's length."""
        self.poll(now_us)
        for ep in self._endpoints:
            ep.begin_batch()
        try:
            self._params.update(self._endpoints)
        finally:
            for ep in self._endpoints:
                ep.flush()

    def _receive(self, poll: bool = False) -> None:
        """Drain both sockets: what is for us within a time budget, past it commands only (rx_drain)."""
        self._rx.drain(poll)

    def _send_events(self) -> None:
        """The vehicle's STATUSTEXTs and reached mission items since the last call."""
        for severity, text in self.vehicle.pop_events():
            self.send_statustext(severity, text)
        for seq in self.vehicle.pop_mission_reached():
            self._broadcast(mavlink.MAVLink_mission_item_reached_message(seq))

    def _update(self, now_us: int) -> None:
        self._receive()
        self._params.update(self._endpoints)
        self._missions.update()
        self._send_events()
        for service in self._services:
            service.update(now_us)
        for ep in self._endpoints:
            if now_us >= ep.next_due_us:
                self._streams.send_due(ep, now_us)

    def send_statustext(self, severity: int, text: str, endpoint: str | None = None) -> None:
        """Send a STATUSTEXT (MAV_SEVERITY) on both endpoints or the named one, chunked past 50 bytes."""
        for msg in self._statustext.messages(severity, text):
            for ep in self._endpoints:
                if endpoint is None or ep.name == endpoint:
                    ep.send(msg)

    def close(self) -> None:
        """Close both sockets (idempotent)."""
        if hasattr(self, "_params"):
            self._params.closed = True
        for ep in self._endpoints:
            ep.close()

    # ------------------------------------------------------------------ receiving

    def _link_commands(self, ep: LinkEndpoint) -> EndpointCommands:
        """The link's own rows of the command table, on the endpoint a command came in on."""
        return EndpointCommands(self._messages, ep, self._now_us, self.send_statustext)

    def _handle_datagram(self, ep: LinkEndpoint, data: bytes, addr: tuple[str, int]) -> None:
        msgs, damaged = ep.incoming(data, addr)
        self._rx_counts.rx_errors += damaged
        for msg in msgs:
            mtype = msg.get_type()
            if self._tap is not None and mtype != "SETUP_SIGNING":  # (a signing key stays out of the logs)
                self._tap(self._now_us, ep.name, False, bytes(msg.get_msgbuf()))
            handler = self._handlers.get(mtype)
            if self.router is not None and self.router(ep, msg) or handler is None:
                continue  # (router: forwards what is for other components of the system, True if it was only theirs)
            self.rx_messages += 1
            try:
                handler(ep, msg)
            except Exception:
                self._rx_counts.rx_errors += 1
                log.exception("gcs_link %s: error handling %s from %s", ep.name, mtype, addr)

    def _for_us(self, handler: Handler) -> Handler:
        """The handler, called only for messages addressed to our system (or broadcast) and component (or all)."""

        def checked(ep: LinkEndpoint, msg: mavlink.MAVLink_message) -> None:
            target = getattr(msg, "target_system", 0), getattr(msg, "target_component", 0)
            if target[0] in (0, self.sysid) and target[1] in (0, self.compid):
                handler(ep, msg)

        return checked

    def _on_heartbeat(self, ep: LinkEndpoint, msg: mavlink.MAVLink_message) -> None:
        """A ground station's HEARTBEAT keeps the data link alive (COM_DL_LOSS_T); others only register a peer.

        Each ground station (address, system, component) is reported once on stdout, as PX4 reports its partner."""
        if msg.type == mavlink.MAV_TYPE_GCS:
            self.vehicle.on_gcs_heartbeat(self._now_us)
            sender = ep.peers[-1] if ep.peers else None  # (a good message's sender is the latest peer)
            key = (sender, msg.get_srcSystem(), msg.get_srcComponent())
            if key not in ep.ground_stations:
                ep.ground_stations.add(key)
                host, port = sender or ("?", 0)
                print(f"INFO  [mavlink] {ep.name}: ground station {key[1]}/{key[2]} at {host}:{port}", flush=True)

    def _on_control(self, ep: LinkEndpoint, msg: mavlink.MAVLink_message) -> None:
        """MANUAL_CONTROL (target = our system) and SET_* setpoints (to us): the vehicle decodes and keeps them."""
        target = msg.target if msg.get_type() == "MANUAL_CONTROL" else msg.target_system
        if target in (0, self.sysid) and getattr(msg, "target_component", 0) in (0, self.compid):
            self.vehicle.on_control_message(msg, self._now_us)

    def _on_timesync(self, ep: LinkEndpoint, msg: mavlink.MAVLink_message) -> None:
        """Answer a request (tc1 == 0) with our clock in ns, echoing ts1."""
        if msg.tc1 == 0:
            ep.send(mavlink.MAVLink_timesync_message(self._now_us * 1000, msg.ts1))

    # ------------------------------------------------------------------ sending

    def _broadcast(self, msg: mavlink.MAVLink_message) -> None:
        for ep in self._endpoints:
            ep.send(msg)
