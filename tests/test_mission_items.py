"""The mission numbers written out in mavsim_core/mission_items.py are MAVLink's (pymavlink's common dialect)."""

from __future__ import annotations

import math

import pytest
from pymavlink.dialects.v20 import common as mavlink

from mavsim_core import mission_items as mi


def test_commands_frames_types_and_results_are_mavlinks():
    for value, name in mi.COMMAND_NAMES.items():
        assert getattr(mavlink, f"MAV_CMD_{name}") == value, name
    frames = {
        "GLOBAL": mi.FRAME_GLOBAL, "LOCAL_NED": mi.FRAME_LOCAL_NED, "MISSION": mi.FRAME_MISSION,
        "GLOBAL_RELATIVE_ALT": mi.FRAME_GLOBAL_RELATIVE_ALT, "GLOBAL_INT": mi.FRAME_GLOBAL_INT,
        "GLOBAL_RELATIVE_ALT_INT": mi.FRAME_GLOBAL_RELATIVE_ALT_INT, "GLOBAL_TERRAIN_ALT": mi.FRAME_GLOBAL_TERRAIN_ALT,
        "GLOBAL_TERRAIN_ALT_INT": mi.FRAME_GLOBAL_TERRAIN_ALT_INT,
    }  # fmt: skip
    for name, value in frames.items():
        assert getattr(mavlink, f"MAV_FRAME_{name}") == value, name
    assert (mi.MISSION, mi.FENCE, mi.RALLY, mi.ALL_TYPES) == (
        mavlink.MAV_MISSION_TYPE_MISSION, mavlink.MAV_MISSION_TYPE_FENCE, mavlink.MAV_MISSION_TYPE_RALLY,
        mavlink.MAV_MISSION_TYPE_ALL,
    )  # fmt: skip
    results = {
        "ACCEPTED": mi.ACCEPTED, "ERROR": mi.ERROR, "UNSUPPORTED_FRAME": mi.UNSUPPORTED_FRAME,
        "UNSUPPORTED": mi.UNSUPPORTED, "NO_SPACE": mi.NO_SPACE, "INVALID": mi.INVALID,
        "INVALID_PARAM1": mi.INVALID_PARAM1, "INVALID_PARAM5_X": mi.INVALID_PARAM1 + 4,
        "INVALID_PARAM7": mi.INVALID_PARAM1 + 6, "INVALID_SEQUENCE": mi.INVALID_SEQUENCE, "DENIED": mi.DENIED,
        "OPERATION_CANCELLED": mi.OPERATION_CANCELLED,
    }  # fmt: skip
    for name, value in results.items():
        assert getattr(mavlink, f"MAV_MISSION_{name}") == value, name


def test_legacy_float_items_become_int_items_and_bad_coordinates_are_named():
    item = mi.item_from_float(3, mi.FRAME_GLOBAL_RELATIVE_ALT, mi.NAV_WAYPOINT, (1, 2), 47.3977421, 8.5455939, 5.0)
    assert (item.x, item.y, item.params) == (473977421, 85455939, (1.0, 2.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="x"):
        mi.item_from_float(0, 3, 16, (), math.nan, 8.5, 5.0)
    with pytest.raises(ValueError, match="y"):
        mi.item_from_float(0, 3, 16, (), 47.0, 1e10, 5.0)
