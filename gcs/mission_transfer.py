"""The ground station's side of the MAVLink mission protocol: upload and download one plan type.

Upload: MISSION_COUNT, then each MISSION_REQUEST_INT (or legacy MISSION_REQUEST) answered with the
requested item, until the vehicle's MISSION_ACK.  Download: MISSION_REQUEST_LIST, MISSION_COUNT,
then MISSION_REQUEST_INT for each item and a final MISSION_ACK.  As the protocol says, the side that
waits re-sends after a timeout (:data:`RETRY_S` wall seconds, :data:`RETRIES` times): here the
MISSION_COUNT until the first request, then the latest item (its answer, or the final ACK, was
lost), so a lossy link only slows a transfer down.  Mission types: 0 mission, 1 fence, 2 rally
(:mod:`mavsim_core.mission_items`); items are MISSION_ITEM_INT (degE7, metres).
"""

from __future__ import annotations

import time

from pymavlink.dialects.v20 import common as mavlink

from gcs.connection import Connection
from gcs.errors import NoAnswer
from mavsim_core import mission_items as mi
from mavsim_core.mission_items import MissionItem
from mavsim_core.mission_messages import item_from_message, item_message

RETRY_S = 0.5  # wall seconds without an answer before asking again
RETRIES = 10


class MissionRefused(RuntimeError):
    """The vehicle answered a transfer with a MISSION_ACK error."""

    def __init__(self, mission_type: int, result: int, reason: str | None) -> None:
        self.result = result
        name = (
            mavlink.enums["MAV_MISSION_RESULT"][result].name
            if result in mavlink.enums["MAV_MISSION_RESULT"]
            else result
        )
        why = f": {reason}" if reason else ""
        super().__init__(f"{mi.TYPE_NAMES.get(mission_type, mission_type)} upload refused ({name}){why}")


def upload(c: Connection, items: list[MissionItem], mission_type: int) -> None:
    """Upload ``items`` as the vehicle's plan of ``mission_type`` (0 items clears it).

    Raises :class:`MissionRefused` on an error ACK (the vehicle keeps its old plan) and
    :class:`NoAnswer` (a GcsTimeout) when the vehicle stops answering."""
    mav = c.conn.mav
    items = [it.renumbered(k) for k, it in enumerate(items)]
    texts_before = len(c.statustexts)
    c.drain()
    mav.mission_count_send(c.target_system, c.target_component, len(items), mission_type)
    tries, started, last_sent = 0, False, None
    deadline = time.monotonic() + c.timeout_s + RETRY_S * RETRIES
    while time.monotonic() < deadline:
        msg = c.recv(
            ("MISSION_REQUEST_INT", "MISSION_REQUEST", "MISSION_ACK"), RETRY_S,
            condition=lambda m: m.mission_type == mission_type,
        )  # fmt: skip
        if msg is None:
            tries += 1
            if tries > RETRIES:
                break
            if not started:  # our MISSION_COUNT was lost
                mav.mission_count_send(c.target_system, c.target_component, len(items), mission_type)
            elif last_sent is not None:  # our item, or the vehicle's next request or ACK, was lost
                mav.send(item_message(items[last_sent], c.target_system, c.target_component))
            continue
        if msg.get_type() == "MISSION_ACK":
            if msg.type != mavlink.MAV_MISSION_ACCEPTED:
                raise MissionRefused(mission_type, msg.type, c.reason_since(texts_before))
            return
        tries, started = 0, True
        if 0 <= msg.seq < len(items):
            mav.send(item_message(items[msg.seq], c.target_system, c.target_component))
            last_sent = msg.seq
    raise NoAnswer(f"{mi.TYPE_NAMES.get(mission_type)} upload: the vehicle stopped answering")


def download(c: Connection, mission_type: int) -> list[MissionItem]:
    """The vehicle's plan of ``mission_type``; :class:`NoAnswer` (a GcsTimeout) when it does not answer."""
    mav = c.conn.mav
    c.drain()
    count = None
    for _ in range(RETRIES):
        mav.mission_request_list_send(c.target_system, c.target_component, mission_type)
        msg = c.recv("MISSION_COUNT", RETRY_S, condition=lambda m: m.mission_type == mission_type)
        if msg is not None:
            count = msg.count
            break
    if count is None:
        raise NoAnswer(f"{mi.TYPE_NAMES.get(mission_type)} download: no MISSION_COUNT")
    items: list[MissionItem] = []
    while len(items) < count:
        for _ in range(RETRIES):
            mav.mission_request_int_send(c.target_system, c.target_component, len(items), mission_type)
            msg = c.recv(
                "MISSION_ITEM_INT", RETRY_S,
                condition=lambda m: m.mission_type == mission_type and m.seq == len(items),
            )  # fmt: skip
            if msg is not None:
                items.append(item_from_message(msg))
                break
        else:
            raise NoAnswer(f"{mi.TYPE_NAMES.get(mission_type)} download: item {len(items)} never came")
    mav.mission_ack_send(c.target_system, c.target_component, mavlink.MAV_MISSION_ACCEPTED, mission_type)
    return items
