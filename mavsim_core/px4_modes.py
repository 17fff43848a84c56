"""PX4's flight modes: numbers, HEARTBEAT ``custom_mode`` encoding, flags and names.

PX4 packs its mode as ``custom_mode = main_mode << 16 | sub_mode << 24``
(``px4_custom_mode.h``).  Sub-modes are only meaningful for AUTO (main mode 4);
for the other main modes the sub-mode byte is ignored when decoding.

:class:`Mode` is what the flight controller flies; the name table (:data:`MODES`,
:func:`lookup_mode`) is what a ground station types.  Canonical names are the short
ones a pilot types (``LOITER``, ``MISSION``, ``RTL``); PX4's own spellings
(``AUTO.LOITER``, ``AUTO.RTL``, ...) and a few common aliases (``HOLD``,
``POSITION``, ...) are accepted, case-insensitively.
"""

from __future__ import annotations

from enum import Enum
from typing import NamedTuple

# MAV_MODE_FLAG bits (MAVLink common.xml), written out so that the flight tasks and the
# topics that carry a Mode import no MAVLink library (tests/test_core_modes.py checks them).
MAV_MODE_FLAG_CUSTOM_MODE_ENABLED = 1
MAV_MODE_FLAG_AUTO_ENABLED = 4
MAV_MODE_FLAG_GUIDED_ENABLED = 8
MAV_MODE_FLAG_STABILIZE_ENABLED = 16
MAV_MODE_FLAG_MANUAL_INPUT_ENABLED = 64
MAV_MODE_FLAG_SAFETY_ARMED = 128


class Px4Mode(NamedTuple):
    """One PX4 mode: canonical name, PX4 display name, main and sub mode numbers."""

    name: str
    px4_name: str
    main: int
    sub: int

    @property
    def custom_mode(self) -> int:
        """The HEARTBEAT custom_mode value for this mode."""
        return encode_custom_mode(self.main, self.sub)


# PX4 main modes (px4_custom_mode.h: PX4_CUSTOM_MAIN_MODE_*)
MAIN_MANUAL, MAIN_ALTCTL, MAIN_POSCTL, MAIN_AUTO, MAIN_ACRO, MAIN_OFFBOARD, MAIN_STABILIZED = 1, 2, 3, 4, 5, 6, 7

# PX4 AUTO sub modes (PX4_CUSTOM_SUB_MODE_AUTO_*)
SUB_AUTO_READY, SUB_AUTO_TAKEOFF, SUB_AUTO_LOITER, SUB_AUTO_MISSION, SUB_AUTO_RTL, SUB_AUTO_LAND = 1, 2, 3, 4, 5, 6
SUB_AUTO_FOLLOW_TARGET = 8  # PX4_CUSTOM_SUB_MODE_AUTO_FOLLOW_TARGET (MAVSDK FollowMe)
SUB_AUTO_PRECLAND = 9
SUB_POSCTL_ORBIT = 1  # PX4_CUSTOM_SUB_MODE_POSCTL_ORBIT: PX4 reports its orbit (DO_ORBIT) as POSCTL + this


class Mode(Enum):
    """PX4's modes as (main, sub) numbers; the one mode table of the stack."""

    MANUAL = (MAIN_MANUAL, 0)
    ALTCTL = (MAIN_ALTCTL, 0)
    POSCTL = (MAIN_POSCTL, 0)
    POSCTL_ORBIT = (MAIN_POSCTL, SUB_POSCTL_ORBIT)  # entered by DO_ORBIT only
    AUTO_READY = (MAIN_AUTO, SUB_AUTO_READY)
    AUTO_TAKEOFF = (MAIN_AUTO, SUB_AUTO_TAKEOFF)
    AUTO_LOITER = (MAIN_AUTO, SUB_AUTO_LOITER)
    AUTO_MISSION = (MAIN_AUTO, SUB_AUTO_MISSION)
    AUTO_RTL = (MAIN_AUTO, SUB_AUTO_RTL)
    AUTO_LAND = (MAIN_AUTO, SUB_AUTO_LAND)
    AUTO_FOLLOW_TARGET = (MAIN_AUTO, SUB_AUTO_FOLLOW_TARGET)
    AUTO_PRECLAND = (MAIN_AUTO, SUB_AUTO_PRECLAND)
    ACRO = (MAIN_ACRO, 0)
    OFFBOARD = (MAIN_OFFBOARD, 0)
    STABILIZED = (MAIN_STABILIZED, 0)

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
        if main == 4 and sub == 0:  # PX4's commander enters AUTO.MISSION for AUTO without a sub-mode
            return cls.AUTO_MISSION
        return None

    def base_mode_flags(self, armed: bool) -> int:
        """MAV_MODE_FLAG bits as PX4 sets them for this mode."""
        f = MAV_MODE_FLAG_CUSTOM_MODE_ENABLED | MAV_MODE_FLAG_STABILIZE_ENABLED
        if armed:
            f |= MAV_MODE_FLAG_SAFETY_ARMED
        if self.value[0] in (1, 2, 3, 5, 7):
            f |= MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
        if self.value[0] in (3, 4, 6):
            f |= MAV_MODE_FLAG_GUIDED_ENABLED
        if self.value[0] == 4:
            f |= MAV_MODE_FLAG_AUTO_ENABLED
        return f


# Names a pilot types: the short name (LOITER), PX4's display name (AUTO.LOITER).
MODES: tuple[Px4Mode, ...] = tuple(Px4Mode(m.name.removeprefix("AUTO_"), m.label, *m.value) for m in Mode)

_ALIASES: dict[str, str] = {
    "HOLD": "LOITER",
    "AUTO.HOLD": "LOITER",
    "POSITION": "POSCTL",
    "ORBIT": "POSCTL_ORBIT",
    "ALTITUDE": "ALTCTL",
    "STABILIZE": "STABILIZED",
    "RETURN": "RTL",
    "AUTO.RETURN": "RTL",
    "AUTO.PRECISION_LAND": "PRECLAND",
    "FOLLOW_ME": "FOLLOW_TARGET",
    "FOLLOW": "FOLLOW_TARGET",
    "AUTO.FOLLOW_ME": "FOLLOW_TARGET",
}

_BY_NAME: dict[str, Px4Mode] = {}
for _m in MODES:
    _BY_NAME[_m.name] = _m
    _BY_NAME[_m.px4_name] = _m
for _alias, _target in _ALIASES.items():
    _BY_NAME[_alias] = _BY_NAME[_target]
_BY_MAIN_SUB: dict[tuple[int, int], Px4Mode] = {(m.main, m.sub): m for m in MODES}


class UnknownModeError(ValueError):
    """A mode name that is not in the table."""


def mode_names() -> list[str]:
    """Canonical mode names, in table order."""
    return [m.name for m in MODES]


def lookup_mode(name: str) -> Px4Mode:
    """Find a mode by canonical name, PX4 spelling or alias (case-insensitive)."""
    key = name.strip().upper().replace("-", "_")
    try:
        return _BY_NAME[key]
    except KeyError:
        raise UnknownModeError(
            f"unknown mode {name!r}; known: {', '.join(mode_names())} "
            f"(PX4 spellings such as AUTO.LOITER and HOLD are accepted too)"
        ) from None


def encode_custom_mode(main: int, sub: int = 0) -> int:
    """PX4 custom_mode from main and sub mode numbers."""
    return (int(main) & 0xFF) << 16 | (int(sub) & 0xFF) << 24


def decode_custom_mode(custom_mode: int) -> tuple[int, int]:
    """(main, sub) mode numbers from a PX4 custom_mode."""
    return (int(custom_mode) >> 16) & 0xFF, (int(custom_mode) >> 24) & 0xFF


def mode_from_custom_mode(custom_mode: int) -> Px4Mode | None:
    """The table entry for a custom_mode, or None if it is not a known PX4 mode."""
    main, sub = decode_custom_mode(custom_mode)
    exact = _BY_MAIN_SUB.get((main, sub))  # e.g. POSCTL_ORBIT
    if exact is not None or main == MAIN_AUTO:
        return exact
    return _BY_MAIN_SUB.get((main, 0))  # other sub-modes of a non-AUTO main mode: the main mode


def custom_mode_to_name(custom_mode: int) -> str:
    """Canonical name of a custom_mode; ``UNKNOWN(main.sub)`` if not in the table."""
    mode = mode_from_custom_mode(custom_mode)
    if mode is not None:
        return mode.name
    main, sub = decode_custom_mode(custom_mode)
    return f"UNKNOWN({main}.{sub})"


def name_to_custom_mode(name: str) -> int:
    """custom_mode for a mode name (any accepted spelling)."""
    return lookup_mode(name).custom_mode


def same_mode(a: str, b: str) -> bool:
    """True if two accepted spellings name the same mode (``HOLD`` == ``AUTO.LOITER``)."""
    return lookup_mode(a) == lookup_mode(b)
