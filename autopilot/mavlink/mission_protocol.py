"""The MAVLink mission protocol (mission, geofence and rally plans) on the ground-station link.

Upload: the client sends MISSION_COUNT, the vehicle asks for each item in turn with
MISSION_REQUEST_INT (MISSION_REQUEST once a client answers with legacy MISSION_ITEMs), checks
each item as it arrives and ends with MISSION_ACK.  The new plan replaces the old one only
when every item has arrived and the whole plan passed its checks: a transfer that fails or
stalls leaves the previous plan as it was.  Download: MISSION_REQUEST_LIST is answered with
MISSION_COUNT, each MISSION_REQUEST_INT / MISSION_REQUEST with the item.  Also
MISSION_CLEAR_ALL (MAV_MISSION_TYPE_ALL clears the three) and MISSION_SET_CURRENT (answered
with MISSION_CURRENT, as PX4 does).

One upload at a time: another client (system, component) starting one meanwhile gets
MAV_MISSION_DENIED; the same client sending MISSION_COUNT again restarts its own.  A request
that gets no item within :data:`RETRY_S` is sent again, up to :data:`MAX_RETRIES` times; then
the transfer ends with MAV_MISSION_OPERATION_CANCELLED.  An item arriving after the transfer
has completed (the client missed our ACK) is answered with the same ACK again.

Time: the retries run on the wall clock (``clock``, :func:`time.monotonic` by default), not on
the simulated time of the rest of the link, because the client on the other side waits in wall
time.  The plans themselves are the vehicle's (:class:`PlanHolder`); this module only moves and
checks items.  pymavlink 2.4.50's ``common`` dialect has no opaque plan ids (``opaque_id``), so
none are sent.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from typing import Callable, Protocol

from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink.endpoint import LinkEndpoint
from autopilot.navigation.mission_checks import MAX_ITEMS
from mavsim_core import mission_items as mi
from mavsim_core.mission_items import MissionItem
from mavsim_core.mission_messages import item_from_message, item_message

RETRY_S = 0.25  # wall seconds without the requested item before the request is sent again
# For one item; then the upload ends with MAV_MISSION_OPERATION_CANCELLED: 5 s of silence, as PX4's mission manager
# (its protocol timeout 5 s, its retry 250 ms).  It was 8 (2 s): a ground station on a loaded machine, behind a
# lossy link, stalled that long and lost an upload PX4 would have finished (tests/test_e2e_mission_clients.py).
MAX_RETRIES = 20
PLAN_TYPES = (mi.MISSION, mi.FENCE, mi.RALLY)


class PlanHolder(Protocol):
    """What the protocol needs from the vehicle: the stored plans and their checks."""

    def plan(self, mission_type: int) -> list[MissionItem]:
        """The stored plan of this type (a copy or an immutable list)."""

    def check_item(self, item: MissionItem) -> tuple[int, str]:
        """One arriving item: (MAV_MISSION_RESULT, reason)."""

    def replace_plan(self, mission_type: int, items: list[MissionItem]) -> tuple[int, str]:
        """Store a complete plan (checked as a whole first): (MAV_MISSION_RESULT, reason); not
        ACCEPTED means the old plan stays."""

    def set_mission_current(self, seq: int) -> tuple[bool, str]:
        """Make ``seq`` the current mission item: (done, reason if not)."""


@dataclass
class _Upload:
    ep: LinkEndpoint
    peer: tuple[int, int]  # (system, component) of the client
    mission_type: int
    count: int
    items: list[MissionItem] = field(default_factory=list)
    legacy: bool = False  # the client sends MISSION_ITEM: ask with MISSION_REQUEST
    sent_at: float = 0.0
    retries: int = 0


class MissionService:
    """The mission protocol of one link (both endpoints); call :meth:`update` every link update."""

    def __init__(
        self,
        plans: PlanHolder,
        say: Callable[[int, str], None],
        sysid: int,
        compid: int,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.plans = plans
        self.say = say
        self.sysid, self.compid = sysid, compid
        self.clock = clock
        self.upload: _Upload | None = None
        # The latest completed upload: (peer, type, count, result), to answer a repeated last item.
        self._completed: tuple[tuple[int, int], int, int, int] | None = None
        self.on_current_changed: Callable[[], None] = lambda: None  # the link sends MISSION_CURRENT

    def handlers(self) -> dict[str, Callable[[LinkEndpoint, mavlink.MAVLink_message], None]]:
        """Message type -> handler (the link calls them only for messages addressed to it)."""
        return {
            "MISSION_REQUEST_LIST": self.on_request_list,
            "MISSION_REQUEST_INT": lambda ep, msg: self.on_request(ep, msg, as_int=True),
            "MISSION_REQUEST": lambda ep, msg: self.on_request(ep, msg, as_int=False),
            "MISSION_COUNT": self.on_count,
            "MISSION_ITEM_INT": lambda ep, msg: self.on_item(ep, msg, legacy=False),
            "MISSION_ITEM": lambda ep, msg: self.on_item(ep, msg, legacy=True),
            "MISSION_CLEAR_ALL": self.on_clear_all,
            "MISSION_SET_CURRENT": self.on_set_current,
            "MISSION_ACK": lambda ep, msg: None,  # the end of a download: nothing to do
        }

    # ------------------------------------------------------------------ download

    def on_request_list(self, ep: LinkEndpoint, msg: mavlink.MAVLink_message) -> None:
        if msg.mission_type not in PLAN_TYPES:
            return self._ack(ep, msg, mavlink.MAV_MISSION_UNSUPPORTED, msg.mission_type)
        count = len(self.plans.plan(msg.mission_type))
        ep.send(
            mavlink.MAVLink_mission_count_message(msg.get_srcSystem(), msg.get_srcComponent(), count, msg.mission_type)
        )

    def on_request(self, ep: LinkEndpoint, msg: mavlink.MAVLink_message, as_int: bool) -> None:
        if msg.mission_type not in PLAN_TYPES:
            return self._ack(ep, msg, mavlink.MAV_MISSION_UNSUPPORTED, msg.mission_type)
        plan = self.plans.plan(msg.mission_type)
        if not 0 <= msg.seq < len(plan):
            return self._ack(ep, msg, mavlink.MAV_MISSION_INVALID_SEQUENCE, msg.mission_type)
        ep.send(item_message(plan[msg.seq], msg.get_srcSystem(), msg.get_srcComponent(), as_int))

    # ------------------------------------------------------------------ upload

    def on_count(self, ep: LinkEndpoint, msg: mavlink.MAVLink_message) -> None:
        mtype = msg.mission_type
        up = self.upload
        if up is not None and not self._same_client(up, ep, msg):
            self.say(mavlink.MAV_SEVERITY_WARNING, "Mission upload denied: another upload is in progress")
            return self._ack(ep, msg, mavlink.MAV_MISSION_DENIED, mtype)
        if mtype not in PLAN_TYPES:
            return self._ack(ep, msg, mavlink.MAV_MISSION_UNSUPPORTED, mtype)
        if msg.count > MAX_ITEMS:
            self.say(mavlink.MAV_SEVERITY_CRITICAL, f"Mission upload refused: {msg.count} items, at most {MAX_ITEMS}")
            return self._ack(ep, msg, mavlink.MAV_MISSION_NO_SPACE, mtype)
        self.upload = None
        peer = (msg.get_srcSystem(), msg.get_srcComponent())
        if msg.count == 0:
            result = self._store(mtype, [])
            self._completed = (peer, mtype, 0, result)
            return self._ack(ep, msg, result, mtype)
        self.upload = _Upload(ep, peer, mtype, msg.count)
        self._completed = None
        self._request_next()

    def on_item(self, ep: LinkEndpoint, msg: mavlink.MAVLink_message, legacy: bool) -> None:
        up = self.upload
        peer = (msg.get_srcSystem(), msg.get_srcComponent())
        if up is None or not self._same_client(up, ep, msg):
            done = self._completed
            if done is not None and done[:2] == (peer, msg.mission_type) and msg.seq == done[2] - 1:
                self._ack(ep, msg, done[3], msg.mission_type)  # our ACK was lost: say it again
            return
        if msg.mission_type != up.mission_type:
            return self._fail(mavlink.MAV_MISSION_INVALID, f"item {msg.seq} has mission type {msg.mission_type}")
        up.legacy = legacy
        if msg.seq != len(up.items):
            return self._request_next()  # a duplicate or one ahead: ask for the one we need
        try:
            item = item_from_message(msg, legacy)
        except ValueError as exc:
            code = mavlink.MAV_MISSION_INVALID_PARAM5_X if str(exc) == "x" else mavlink.MAV_MISSION_INVALID_PARAM6_Y
            return self._fail(code, f"item {msg.seq}: {'latitude' if str(exc) == 'x' else 'longitude'} not valid")
        result, reason = self.plans.check_item(item)
        if result != mavlink.MAV_MISSION_ACCEPTED:
            return self._fail(result, reason)
        if reason:  # accepted with a note (a fence circle of radius 0: ignored)
            self.say(mavlink.MAV_SEVERITY_WARNING, f"{mi.TYPE_NAMES[up.mission_type].capitalize()} {reason}")
        up.items.append(item)
        up.retries = 0  # progress: the retry budget is per item
        if len(up.items) < up.count:
            return self._request_next()
        self.upload = None
        result = self._store(up.mission_type, up.items)
        self._completed = (up.peer, up.mission_type, up.count, result)
        self._send_ack(up, result)

    def _store(self, mtype: int, items: list[MissionItem]) -> int:
        result, reason = self.plans.replace_plan(mtype, items)
        kind = mi.TYPE_NAMES[mtype]
        if result == mavlink.MAV_MISSION_ACCEPTED:
            self.say(mavlink.MAV_SEVERITY_INFO, f"{kind.capitalize()} plan: {len(items)} items stored")
            self.on_current_changed()
        else:
            self.say(mavlink.MAV_SEVERITY_CRITICAL, f"{kind.capitalize()} upload refused: {reason}")
        return result

    def _fail(self, result: int, reason: str) -> None:
        up = self.upload
        assert up is not None
        self.upload = None
        self._completed = (up.peer, up.mission_type, up.count, result)
        self.say(
            mavlink.MAV_SEVERITY_CRITICAL, f"{mi.TYPE_NAMES[up.mission_type].capitalize()} upload refused: {reason}"
        )
        self._send_ack(up, result)

    def _request_next(self) -> None:
        up = self.upload
        assert up is not None
        seq = len(up.items)
        sysid, compid = up.peer
        if up.legacy:
            msg = mavlink.MAVLink_mission_request_message(sysid, compid, seq, up.mission_type)
        else:
            msg = mavlink.MAVLink_mission_request_int_message(sysid, compid, seq, up.mission_type)
        up.ep.send(msg)
        up.sent_at = self.clock()

    def update(self) -> None:
        """Re-send a request that went unanswered; end a transfer that stalled."""
        up = self.upload
        if up is None or self.clock() - up.sent_at < RETRY_S:
            return
        up.retries += 1
        if up.retries > MAX_RETRIES:
            self.upload = None
            self.say(mavlink.MAV_SEVERITY_CRITICAL, f"{mi.TYPE_NAMES[up.mission_type].capitalize()} upload timed out")
            self._send_ack(up, mavlink.MAV_MISSION_OPERATION_CANCELLED)
            return
        self._request_next()

    # ------------------------------------------------------------------ clear, current

    def on_clear_all(self, ep: LinkEndpoint, msg: mavlink.MAVLink_message) -> None:
        types = PLAN_TYPES if msg.mission_type == mi.ALL_TYPES else (msg.mission_type,)
        if any(t not in PLAN_TYPES for t in types):
            return self._ack(ep, msg, mavlink.MAV_MISSION_UNSUPPORTED, msg.mission_type)
        result = mavlink.MAV_MISSION_ACCEPTED
        for t in types:
            if self.plans.plan(t):
                r = self._store(t, [])
                result = r if result == mavlink.MAV_MISSION_ACCEPTED else result
        self._ack(ep, msg, result, msg.mission_type)

    def on_set_current(self, ep: LinkEndpoint, msg: mavlink.MAVLink_message) -> None:
        done, reason = self.plans.set_mission_current(msg.seq)
        if not done:
            self.say(mavlink.MAV_SEVERITY_CRITICAL, f"Set current mission item denied: {reason}")
        self.on_current_changed()  # MISSION_CURRENT is the answer either way (PX4)

    # ------------------------------------------------------------------ helpers

    def _same_client(self, up: _Upload, ep: LinkEndpoint, msg: mavlink.MAVLink_message) -> bool:
        return ep is up.ep and (msg.get_srcSystem(), msg.get_srcComponent()) == up.peer

    def _ack(self, ep: LinkEndpoint, msg: mavlink.MAVLink_message, result: int, mtype: int) -> None:
        ep.send(mavlink.MAVLink_mission_ack_message(msg.get_srcSystem(), msg.get_srcComponent(), result, mtype))

    def _send_ack(self, up: _Upload, result: int) -> None:
        up.ep.send(mavlink.MAVLink_mission_ack_message(up.peer[0], up.peer[1], result, up.mission_type))
