"""Mission items to and from the MAVLink messages that carry them (MISSION_ITEM_INT, legacy MISSION_ITEM).

Shared by the flight controller's mission protocol (``autopilot.mavlink.mission_protocol``) and the
ground station's (``gcs.mission_transfer``).  Kept apart from :mod:`mavsim_core.mission_items`, which
the navigation code imports and which must not reach pymavlink.  Units: MISSION_ITEM_INT x/y degE7
(local frames m * 1e4), MISSION_ITEM x/y degrees (m), z metres.
"""

from __future__ import annotations

from pymavlink.dialects.v20 import common as mavlink

from mavsim_core import mission_items as mi
from mavsim_core.mission_items import MissionItem, item_from_float


def item_message(item: MissionItem, sysid: int, compid: int, as_int: bool = True) -> mavlink.MAVLink_message:
    """MISSION_ITEM_INT to (sysid, compid), or (``as_int`` False) the legacy MISSION_ITEM with x/y in degrees."""
    x: float = item.x
    y: float = item.y
    cls = mavlink.MAVLink_mission_item_int_message
    if not as_int:
        scale = 1e4 if item.frame == mi.FRAME_LOCAL_NED else mi.DEG_E7
        x, y, cls = item.x / scale, item.y / scale, mavlink.MAVLink_mission_item_message
    return cls(
        sysid, compid, item.seq, item.frame, item.command, item.current, item.autocontinue,
        item.param1, item.param2, item.param3, item.param4, x, y, item.z, item.mission_type,
    )  # fmt: skip


def item_from_message(msg: mavlink.MAVLink_message, legacy: bool = False) -> MissionItem:
    """MISSION_ITEM_INT or MISSION_ITEM as a MissionItem; ValueError("x"/"y") for a coordinate that
    cannot be one."""
    params = (msg.param1, msg.param2, msg.param3, msg.param4)
    if legacy:
        return item_from_float(
            msg.seq, msg.frame, msg.command, params, msg.x, msg.y, msg.z, msg.mission_type, msg.current,
            msg.autocontinue,
        )  # fmt: skip
    return MissionItem(
        msg.seq, msg.frame, msg.command, *params, msg.x, msg.y, msg.z, msg.mission_type, msg.current, msg.autocontinue
    )
