"""Flight modes with PX4's numbers: custom_mode = main << 16 | sub << 24."""

from __future__ import annotations

from enum import Enum

from pymavlink.dialects.v20 import common as mavlink


class Mode(Enum):
    MANUAL = (1, 0)
    ALTCTL = (2, 0)
    POSCTL = (3, 0)
    AUTO_READY = (4, 1)
    AUTO_TAKEOFF = (4, 2)
    AUTO_LOITER = (4, 3)
    AUTO_MISSION = (4, 4)
    AUTO_RTL = (4, 5)
    AUTO_LAND = (4, 6)
    AUTO_PRECLAND = (4, 9)
    ACRO = (5, 0)
    OFFBOARD = (6, 0)
    STABILIZED = (7, 0)

    @property
    def custom_mode(self) -> int:
        main, sub = self.value
        return main << 16 | sub << 24

    @property
    def label(self) -> str:
        return self.name.replace("AUTO_", "AUTO.")

    @classmethod
    def from_custom_mode(cls, custom_mode: int) -> "Mode | None":
        main = (custom_mode >> 16) & 0xFF
        sub = (custom_mode >> 24) & 0xFF
        for m in cls:
            if m.value == (main, sub):
                return m
        if main == 4 and sub == 0:  # PX4 treats AUTO without a sub-mode as AUTO.LOITER
            return cls.AUTO_LOITER
        return None

    def base_mode_flags(self, armed: bool) -> int:
        """MAV_MODE_FLAG bits as PX4 sets them for this mode."""
        f = mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | mavlink.MAV_MODE_FLAG_STABILIZE_ENABLED
        if armed:
            f |= mavlink.MAV_MODE_FLAG_SAFETY_ARMED
        if self.value[0] in (1, 2, 3, 5, 7):
            f |= mavlink.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
        if self.value[0] in (3, 4, 6):
            f |= mavlink.MAV_MODE_FLAG_GUIDED_ENABLED
        if self.value[0] == 4:
            f |= mavlink.MAV_MODE_FLAG_AUTO_ENABLED
        return f


# Modes this flight controller can fly today (no RC input yet: POSCTL holds position).
AVAILABLE = {Mode.POSCTL, Mode.AUTO_TAKEOFF, Mode.AUTO_LOITER, Mode.AUTO_RTL, Mode.AUTO_LAND}
