"""PX4's mode table in the shared core (mavsim_core.px4_modes): numbers, flags and names."""

from __future__ import annotations

from pymavlink.dialects.v20 import common as mavlink

from mavsim_core import px4_modes
from mavsim_core.px4_modes import Mode


def test_mode_flag_bits_are_mavlinks():
    for name in (
        "CUSTOM_MODE_ENABLED",
        "AUTO_ENABLED",
        "GUIDED_ENABLED",
        "STABILIZE_ENABLED",
        "MANUAL_INPUT_ENABLED",
        "SAFETY_ARMED",
    ):
        assert getattr(px4_modes, f"MAV_MODE_FLAG_{name}") == getattr(mavlink, f"MAV_MODE_FLAG_{name}")


def test_custom_mode_round_trip_and_px4_numbers():
    assert Mode.AUTO_LOITER.custom_mode == 4 << 16 | 3 << 24
    assert Mode.POSCTL.custom_mode == 3 << 16
    for m in Mode:
        assert Mode.from_custom_mode(m.custom_mode) is m
    assert Mode.from_custom_mode(4 << 16) is Mode.AUTO_MISSION  # AUTO without a sub-mode, as PX4's commander


def test_one_table_for_the_flight_controller_and_the_ground_station():
    assert [m.name for m in px4_modes.MODES] == [m.name.removeprefix("AUTO_") for m in Mode]
    assert px4_modes.lookup_mode("hold").custom_mode == Mode.AUTO_LOITER.custom_mode
    assert px4_modes.custom_mode_to_name(Mode.AUTO_RTL.custom_mode) == "RTL"


def test_base_mode_flags_as_px4_sets_them():
    f = Mode.AUTO_MISSION.base_mode_flags(armed=True)
    assert f & mavlink.MAV_MODE_FLAG_SAFETY_ARMED and f & mavlink.MAV_MODE_FLAG_AUTO_ENABLED
    assert not Mode.POSCTL.base_mode_flags(armed=False) & mavlink.MAV_MODE_FLAG_SAFETY_ARMED
    assert Mode.POSCTL.base_mode_flags(armed=False) & mavlink.MAV_MODE_FLAG_MANUAL_INPUT_ENABLED
