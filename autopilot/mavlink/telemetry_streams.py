"""The link's telemetry streams: which message is due on which endpoint, built once per link update.

:class:`TelemetryStreams` holds the vehicle's snapshot of the current link update (fetched at most
once), the messages already built in it (one build serves every endpoint), and what HOME_POSITION
and MISSION_CURRENT last said, so a change goes out at once rather than at the stream's next slot.
Times are the simulated clock's (µs); the endpoints (:class:`~autopilot.mavlink.endpoint.LinkEndpoint`)
keep each stream's interval and next due time.
"""

from __future__ import annotations

import logging

from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink import telemetry_more
from autopilot.mavlink.endpoint import LinkEndpoint
from autopilot.mavlink.telemetry import Builder
from autopilot.mavlink.vehicle_interface import VehicleInterface
from autopilot.topics import TelemetrySnapshot
from mavsim_core.sim_api_codec import CRC_LEN, HEADER_LEN, MessageLayout, numeric_layout

log = logging.getLogger(__name__)


class TelemetryStreams:
    """Snapshot, build cache and change detection of the link's streams (see the module docstring).

    ``builders``: message id -> builder, every message the link streams or sends on request
    (:func:`autopilot.mavlink.telemetry_more.link_builders`).  ``tx_build_errors`` counts stream
    messages that could not be built (a bug in a snapshot?).
    """

    def __init__(
        self, vehicle: VehicleInterface, endpoints: list[LinkEndpoint], builders: dict[int, Builder] | None = None
    ) -> None:
        self.vehicle = vehicle
        self.endpoints = endpoints
        self.builders = builders if builders is not None else dict(telemetry_more.BUILDERS)
        self.now_us = 0
        self.tx_build_errors = 0
        self._build_failures: set[int] = set()
        self._snap: TelemetrySnapshot | None = None
        self._built: dict[int, mavlink.MAVLink_message | None] = {}  # messages of the current update
        # (layout, payload) of the messages of the current update packed by a first endpoint: the next ones frame
        # the same payload (LinkEndpoint.send_payload) instead of packing the message again
        self._packed: dict[int, tuple[MessageLayout, bytes]] = {}
        self._reported: dict[int, object] = {}  # what HOME_POSITION and MISSION_CURRENT last said
        self._rescheduled = False  # due_now() moved a stream during send_due()

    def begin(self, now_us: int) -> None:
        """A new link update (or poll) at ``now_us``: the snapshot and built messages are stale."""
        self.now_us = now_us
        self._snap = None
        self._built.clear()
        self._packed.clear()

    def snapshot(self) -> TelemetrySnapshot:
        """The vehicle's snapshot, fetched at most once per update."""
        if self._snap is None:
            self._snap = self.vehicle.snapshot()
            self._check_changes(self._snap)
        return self._snap

    def due_now(self, mid: int) -> None:
        """Message ``mid`` goes out on every endpoint in this update, not at its stream's next slot."""
        for ep in self.endpoints:
            stream = ep.streams.get(mid)
            if stream is not None and stream.interval_us > 0:
                stream.next_due_us = min(stream.next_due_us, self.now_us)
                ep.next_due_us = min(ep.next_due_us, self.now_us)
                self._rescheduled = True

    def _check_changes(self, snap: TelemetrySnapshot) -> None:
        """A new or moved home, a new current mission item, total or state: out at once (as PX4 sends
        them), not at the stream's next slot."""
        h, m = snap.home, snap.mission
        keys = {
            mavlink.MAVLINK_MSG_ID_HOME_POSITION: None if h is None else (h.lat_deg, h.lon_deg, h.alt_amsl_m),
            mavlink.MAVLINK_MSG_ID_MISSION_CURRENT: (m.seq, m.total, int(m.state), m.in_mission_mode),
        }
        for mid, key in keys.items():
            if key != self._reported.get(mid):
                self._reported[mid] = key
                if key is not None:
                    self.due_now(mid)

    def restart(self, now_us: int) -> None:
        """The simulated clock went backwards: every stream is due at ``now_us``."""
        for ep in self.endpoints:
            for s in ep.streams.values():
                s.next_due_us = now_us
            ep.refresh_next_due()

    def send_due(self, ep: LinkEndpoint, now_us: int) -> None:
        """Send on ``ep`` every stream that is due at ``now_us`` and schedule its next one (no bursts)."""
        self._rescheduled = False
        next_due = 2**63  # the earliest next_due_us of the enabled streams (LinkEndpoint.refresh_next_due)
        for mid, stream in ep.streams.items():
            interval = stream.interval_us
            if interval <= 0:
                continue
            due = stream.next_due_us
            if now_us >= due:
                due += interval
                if due <= now_us:  # fell behind (first call, time jump): no bursts
                    due = now_us + interval
                stream.next_due_us = due
                msg = self.build(mid, now_us)
                if msg is not None:
                    self._send(ep, mid, msg)
            if due < next_due:
                next_due = due
        if self._rescheduled:  # the snapshot moved a stream already passed (due_now): count it too
            ep.refresh_next_due()
        else:
            ep.next_due_us = next_due

    def _send(self, ep: LinkEndpoint, mid: int, msg: mavlink.MAVLink_message) -> None:
        """``ep.send(msg)``, framing the payload another endpoint packed in this update if there is one."""
        packed = self._packed.get(mid)
        if packed is not None and not ep.signing.sign_outgoing:
            ep.send_payload(*packed)
            return
        packet = ep.send(msg)
        layout = numeric_layout(type(msg))
        if packet is not None and layout is not None:  # packed by its layout, unsigned: header, payload, CRC
            self._packed[mid] = (layout, packet[HEADER_LEN:-CRC_LEN])

    def build(self, mid: int, now_us: int) -> mavlink.MAVLink_message | None:
        """A stream message from the current snapshot, or None if there is nothing to report.

        Built once per update and packed for each endpoint that streams it."""
        if mid in self._built:
            return self._built[mid]
        try:
            msg = self._built[mid] = self.builders[mid](self.snapshot(), now_us)
            return msg
        except Exception:
            if mid not in self._build_failures:  # one report per message, not one per iteration
                self._build_failures.add(mid)
                log.exception("gcs_link: cannot build message %d", mid)
            self.tx_build_errors += 1
            return None
