"""PX4 flight-mode names and their HEARTBEAT ``custom_mode`` encoding.

PX4 packs its mode as ``custom_mode = main_mode << 16 | sub_mode << 24``
(``px4_custom_mode.h``).  Sub-modes are only meaningful for AUTO (main mode 4);
for the other main modes the sub-mode byte is ignored when decoding.

Canonical names are the short ones a pilot types (``LOITER``, ``MISSION``,
``RTL``); PX4's own spellings (``AUTO.LOITER``, ``AUTO.RTL``, ...) and a few
common aliases (``HOLD``, ``POSITION``, ...) are accepted, case-insensitively.
"""

from __future__ import annotations

from typing import NamedTuple


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
MAIN_MANUAL = 1
MAIN_ALTCTL = 2
MAIN_POSCTL = 3
MAIN_AUTO = 4
MAIN_ACRO = 5
MAIN_OFFBOARD = 6
MAIN_STABILIZED = 7

# PX4 AUTO sub modes (PX4_CUSTOM_SUB_MODE_AUTO_*)
SUB_AUTO_READY = 1
SUB_AUTO_TAKEOFF = 2
SUB_AUTO_LOITER = 3
SUB_AUTO_MISSION = 4
SUB_AUTO_RTL = 5
SUB_AUTO_LAND = 6
SUB_AUTO_PRECLAND = 9

MODES: tuple[Px4Mode, ...] = (
    Px4Mode("MANUAL", "MANUAL", MAIN_MANUAL, 0),
    Px4Mode("ALTCTL", "ALTCTL", MAIN_ALTCTL, 0),
    Px4Mode("POSCTL", "POSCTL", MAIN_POSCTL, 0),
    Px4Mode("READY", "AUTO.READY", MAIN_AUTO, SUB_AUTO_READY),
    Px4Mode("TAKEOFF", "AUTO.TAKEOFF", MAIN_AUTO, SUB_AUTO_TAKEOFF),
    Px4Mode("LOITER", "AUTO.LOITER", MAIN_AUTO, SUB_AUTO_LOITER),
    Px4Mode("MISSION", "AUTO.MISSION", MAIN_AUTO, SUB_AUTO_MISSION),
    Px4Mode("RTL", "AUTO.RTL", MAIN_AUTO, SUB_AUTO_RTL),
    Px4Mode("LAND", "AUTO.LAND", MAIN_AUTO, SUB_AUTO_LAND),
    Px4Mode("PRECLAND", "AUTO.PRECLAND", MAIN_AUTO, SUB_AUTO_PRECLAND),
    Px4Mode("ACRO", "ACRO", MAIN_ACRO, 0),
    Px4Mode("OFFBOARD", "OFFBOARD", MAIN_OFFBOARD, 0),
    Px4Mode("STABILIZED", "STABILIZED", MAIN_STABILIZED, 0),
)

_ALIASES: dict[str, str] = {
    "HOLD": "LOITER",
    "AUTO.HOLD": "LOITER",
    "POSITION": "POSCTL",
    "ALTITUDE": "ALTCTL",
    "STABILIZE": "STABILIZED",
    "RETURN": "RTL",
    "AUTO.RETURN": "RTL",
    "AUTO.PRECISION_LAND": "PRECLAND",
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
    if main != MAIN_AUTO:
        sub = 0
    return _BY_MAIN_SUB.get((main, sub))


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
