"""Mission items as the MAVLink mission protocol carries them, and the numbers they use.

One :class:`MissionItem` is one MISSION_ITEM_INT: a command (MAV_CMD) with its seven
parameters in a frame (MAV_FRAME), for one of the three plan types (MAV_MISSION_TYPE:
mission, geofence, rally points).  ``x``/``y`` are kept as MISSION_ITEM_INT carries them:
latitude/longitude in degE7 for global frames, metres * 1e4 for local ones; ``z`` is the
altitude in metres (AMSL for ``GLOBAL``, above home for ``GLOBAL_RELATIVE_ALT``).

The flight controller's protocol (``autopilot.mavlink.mission_protocol``), its mission runner
(``autopilot.navigation``: which imports no MAVLink library, hence the numbers written out here)
and the ground station's plan files (``gcs``) share this record.  ``tests/test_mission_items.py``
checks every number against pymavlink's ``common`` dialect.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

# MAV_MISSION_TYPE
MISSION, FENCE, RALLY, ALL_TYPES = 0, 1, 2, 255
TYPE_NAMES = {MISSION: "mission", FENCE: "fence", RALLY: "rally"}

# MAV_FRAME (the ones a mission item may use)
FRAME_GLOBAL = 0  # altitude AMSL
FRAME_LOCAL_NED = 1
FRAME_MISSION = 2  # no position: DO_* and CONDITION_* commands
FRAME_GLOBAL_RELATIVE_ALT = 3  # altitude above home
FRAME_GLOBAL_INT = 5
FRAME_GLOBAL_RELATIVE_ALT_INT = 6
FRAME_GLOBAL_TERRAIN_ALT = 10
FRAME_GLOBAL_TERRAIN_ALT_INT = 11
GLOBAL_FRAMES = frozenset({FRAME_GLOBAL, FRAME_GLOBAL_INT})
RELATIVE_FRAMES = frozenset({FRAME_GLOBAL_RELATIVE_ALT, FRAME_GLOBAL_RELATIVE_ALT_INT})
POSITION_FRAMES = GLOBAL_FRAMES | RELATIVE_FRAMES  # the altitude frames this stack flies (no terrain)

# MAV_CMD
NAV_WAYPOINT = 16
NAV_LOITER_UNLIM = 17
NAV_LOITER_TIME = 19
NAV_RETURN_TO_LAUNCH = 20
NAV_LAND = 21
NAV_TAKEOFF = 22
NAV_DELAY = 93
CONDITION_YAW = 115
DO_JUMP = 177
DO_CHANGE_SPEED = 178
DO_SET_HOME = 179
DO_LAND_START = 189
FENCE_POLYGON_INCLUSION = 5001
FENCE_POLYGON_EXCLUSION = 5002
FENCE_CIRCLE_INCLUSION = 5003
FENCE_CIRCLE_EXCLUSION = 5004
RALLY_POINT = 5100

COMMAND_NAMES = {
    NAV_WAYPOINT: "NAV_WAYPOINT", NAV_LOITER_UNLIM: "NAV_LOITER_UNLIM", NAV_LOITER_TIME: "NAV_LOITER_TIME",
    NAV_RETURN_TO_LAUNCH: "NAV_RETURN_TO_LAUNCH", NAV_LAND: "NAV_LAND", NAV_TAKEOFF: "NAV_TAKEOFF",
    NAV_DELAY: "NAV_DELAY", CONDITION_YAW: "CONDITION_YAW", DO_JUMP: "DO_JUMP", DO_CHANGE_SPEED: "DO_CHANGE_SPEED",
    DO_SET_HOME: "DO_SET_HOME", DO_LAND_START: "DO_LAND_START",
    FENCE_POLYGON_INCLUSION: "NAV_FENCE_POLYGON_VERTEX_INCLUSION",
    FENCE_POLYGON_EXCLUSION: "NAV_FENCE_POLYGON_VERTEX_EXCLUSION",
    FENCE_CIRCLE_INCLUSION: "NAV_FENCE_CIRCLE_INCLUSION", FENCE_CIRCLE_EXCLUSION: "NAV_FENCE_CIRCLE_EXCLUSION",
    RALLY_POINT: "NAV_RALLY_POINT",
}  # fmt: skip

# The commands each plan type accepts (anything else: MAV_MISSION_UNSUPPORTED at upload).
NAV_COMMANDS = frozenset(
    {NAV_WAYPOINT, NAV_LOITER_UNLIM, NAV_LOITER_TIME, NAV_RETURN_TO_LAUNCH, NAV_LAND, NAV_TAKEOFF, NAV_DELAY}
)
SUPPORTED = {
    MISSION: NAV_COMMANDS | {CONDITION_YAW, DO_JUMP, DO_CHANGE_SPEED, DO_SET_HOME, DO_LAND_START},
    FENCE: frozenset(
        {FENCE_POLYGON_INCLUSION, FENCE_POLYGON_EXCLUSION, FENCE_CIRCLE_INCLUSION, FENCE_CIRCLE_EXCLUSION}
    ),
    RALLY: frozenset({RALLY_POINT}),
}
# Commands whose x/y/z are a position (the others ignore them, whatever the frame).
POSITION_COMMANDS = (
    frozenset({NAV_WAYPOINT, NAV_LOITER_UNLIM, NAV_LOITER_TIME, NAV_LAND, NAV_TAKEOFF, DO_SET_HOME, DO_LAND_START})
    | SUPPORTED[FENCE]
    | SUPPORTED[RALLY]
)

# MAV_MISSION_RESULT
ACCEPTED, ERROR, UNSUPPORTED_FRAME, UNSUPPORTED, NO_SPACE, INVALID = 0, 1, 2, 3, 4, 5
INVALID_PARAM1 = 6  # INVALID_PARAM1 + k - 1 for param k (1..4), INVALID_PARAM5_X .. INVALID_PARAM7 = 10, 11, 12
INVALID_SEQUENCE, DENIED, OPERATION_CANCELLED = 13, 14, 15

DEG_E7 = 1e7


@dataclass(frozen=True, slots=True)
class MissionItem:
    """One MISSION_ITEM_INT (see the module docstring for the units of ``x``, ``y``, ``z``)."""

    seq: int
    frame: int
    command: int
    param1: float = 0.0
    param2: float = 0.0
    param3: float = 0.0
    param4: float = 0.0
    x: int = 0
    y: int = 0
    z: float = 0.0
    mission_type: int = MISSION
    current: int = 0
    autocontinue: int = 1

    @property
    def lat_deg(self) -> float:
        return self.x / DEG_E7

    @property
    def lon_deg(self) -> float:
        return self.y / DEG_E7

    @property
    def params(self) -> tuple[float, float, float, float]:
        return (self.param1, self.param2, self.param3, self.param4)

    def renumbered(self, seq: int) -> MissionItem:
        return replace(self, seq=seq, current=0)

    @property
    def name(self) -> str:
        return COMMAND_NAMES.get(self.command, f"MAV_CMD {self.command}")


def item_from_float(
    seq: int, frame: int, command: int, params: tuple[float, ...], x: float, y: float, z: float,
    mission_type: int = MISSION, current: int = 0, autocontinue: int = 1,
) -> MissionItem:  # fmt: skip
    """A MissionItem from a legacy MISSION_ITEM (x/y in degrees or metres); x/y NaN or infinite raise
    ValueError (the caller answers MAV_MISSION_INVALID_PARAM5_X/6_Y)."""
    scale = DEG_E7 if frame not in (FRAME_LOCAL_NED,) else 1e4
    if not (math.isfinite(x) and abs(x * scale) < 2**31):
        raise ValueError("x")
    if not (math.isfinite(y) and abs(y * scale) < 2**31):
        raise ValueError("y")
    p = tuple(params) + (0.0,) * (4 - len(params))
    return MissionItem(
        seq, frame, command, p[0], p[1], p[2], p[3], round(x * scale), round(y * scale), z, mission_type, current,
        autocontinue,
    )  # fmt: skip
