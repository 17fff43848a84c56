"""Helpers of the SIM_* parameter tests (test_sim_params.py, test_sim_scenarios.py, test_sim_param_server.py,
test_sitl_cli.py): a fresh table with its settings objects, scenario files, PARAM_VALUE decoding."""

from __future__ import annotations

from pathlib import Path

from mavsim_core.param_encoding import REAL32
from sitl.sim_params import SimParameters
from sitl.sim_settings import MotorSettings, SensorSettings, WindSettings

GCS_SYS, GCS_COMP = 255, 190  # the pymavlink clients' MAVLink system and component ids


def make_params() -> tuple[SimParameters, WindSettings, SensorSettings, MotorSettings]:
    wind, sensors, motors = WindSettings(), SensorSettings(), MotorSettings()
    return SimParameters(wind, sensors, motors), wind, sensors, motors


def write(tmp_path: Path, text: str, name: str = "s.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


def value_of(pv) -> int | float:
    """A PARAM_VALUE's value, C-cast: the float is the value (an int for integer types)."""
    return pv.param_value if pv.param_type == REAL32 else int(pv.param_value)
