"""The simulator's scenario files (:mod:`sitl.scenario`): pure, tested directly.

The shipped scenarios, good and bad files (each error names the file, the key and the reason),
the event schedule, and the lockstep server applying events at its 50 Hz periods.  The SIM_*
table itself is tested in tests/test_sim_params.py.
"""

from __future__ import annotations

import math
import tomllib
from pathlib import Path
from types import SimpleNamespace

import pytest

from sitl.scenario import EventSchedule, ScenarioError, ScenarioEvent, list_scenarios, load_scenario
from sitl.sim_settings import CameraSettings, MotorSettings, SensorSettings, UgvSettings, WindSettings

from sim_params_helpers import make_params, write  # tests/sim_params_helpers.py

ROOT = Path(__file__).resolve().parent.parent


# --------------------------------------------------------------------------- scenarios


def test_shipped_scenarios():
    assert {"calm", "windy", "hexa_motor_failure"} <= set(list_scenarios())
    calm = load_scenario("calm")
    params, *_ = make_params()
    assert all(params.get(n) == v for n, v in calm.parameters.items()) and calm.events == ()
    windy = load_scenario("windy")
    assert windy.parameters == {
        "SIM_WIND_SPD": 5.0,
        "SIM_WIND_DIR": 270.0,
        "SIM_WIND_TURB": 1.0,
        "SIM_GUST_SPD": 2.0,
        "SIM_GUST_DUR": 2.0,
        "SIM_GUST_INT": 10.0,
    }
    hexa = load_scenario("hexa_motor_failure")
    assert hexa.parameters == {}
    assert hexa.events == (ScenarioEvent(20_000_000, {"SIM_ENGINE_FAIL": 1, "SIM_ENGINE_MUL": 0.0}),)
    assert all(s.description for s in (calm, windy, hexa))
    rtk = load_scenario("rtk_gps")  # (tests/test_sensors.py flies its receiver)
    assert rtk.parameters["SIM_GPS_FIXTYPE"] == 6 and rtk.parameters["SIM_GPS_NOISE"] < params.get("SIM_GPS_NOISE")


def test_scenarios_are_package_data():
    with open(ROOT / "pyproject.toml", "rb") as f:
        package_data = tomllib.load(f)["tool"]["setuptools"]["package-data"]["params"]
    assert "scenarios/*.toml" in package_data and "*.params" in package_data  # params/rtk_gps.params


def test_good_file_with_events(tmp_path):
    path = write(
        tmp_path,
        """
description = "test"
[parameters]
SIM_WIND_SPD = 3
SIM_GPS_LAG_MS = 100
[[events]]
at_s = 12.5
set = { SIM_GPS_DISABLE = 1 }
[[events]]
at_s = 2
set = { SIM_ENGINE_FAIL = 4, SIM_ENGINE_MUL = 0.5 }
""",
    )
    sc = load_scenario(str(path))
    assert sc.name == "s" and sc.description == "test"
    assert sc.parameters == {"SIM_WIND_SPD": 3.0, "SIM_GPS_LAG_MS": 100}
    assert isinstance(sc.parameters["SIM_WIND_SPD"], float) and isinstance(sc.parameters["SIM_GPS_LAG_MS"], int)
    assert [e.at_us for e in sc.events] == [2_000_000, 12_500_000]  # sorted by time
    assert sc.events[0].values == {"SIM_ENGINE_FAIL": 4, "SIM_ENGINE_MUL": 0.5}


_PAD = "[pad]\nmarkers = [{}]\n"


def test_a_pad_table_sets_the_nested_pad(tmp_path):
    text = _PAD.format("{ id = 76, size_m = 0.333, x_m = 0.3 }, { id = 5, size_m = 0.1, y_m = -0.05 }")
    sc = load_scenario(write(tmp_path, text))
    assert sc.pad is not None and [(m.marker_id, m.size_m, m.x_m, m.y_m) for m in sc.pad.markers] == [
        (76, 0.333, 0.3, 0.0),
        (5, 0.1, 0.0, -0.05),
    ]
    assert load_scenario(write(tmp_path, "")).pad is None  # the default nested pad


@pytest.mark.parametrize(
    "text, key, reason",
    [
        ("[parameters]\nSIM_NOPE = 1\n", "parameters.SIM_NOPE", "unknown parameter"),
        ("[parameters]\nSIM_WIND_SPD = 31.0\n", "parameters.SIM_WIND_SPD", "outside range [0, 30] m/s"),
        ("[parameters]\nSIM_ENGINE_FAIL = 1.5\n", "parameters.SIM_ENGINE_FAIL", "not an integer"),
        ('[parameters]\nSIM_WIND_SPD = "5"\n', "parameters.SIM_WIND_SPD", "expected a number"),
        ("[parameters]\nSIM_WIND_SPD = nan\n", "parameters.SIM_WIND_SPD", "finite"),
        ("wind = 3\n", "wind", "unknown key"),
        ("parameters = 3\n", "parameters", "must be a table"),
        ("description = 3\n", "description", "must be a string"),
        ("[[events]]\nat_s = 1\nset = { SIM_ENGINE_FAIL = 20 }\n", "events[0].set.SIM_ENGINE_FAIL", "outside range"),
        ("[[events]]\nat_s = -1\nset = { SIM_ENGINE_FAIL = 1 }\n", "events[0].at_s", ">= 0"),
        ('[[events]]\nat_s = "soon"\nset = { SIM_ENGINE_FAIL = 1 }\n', "events[0].at_s", ">= 0"),
        ("[[events]]\nat_s = 1\n", "events[0]", "missing set"),
        ("[[events]]\nat_s = 1\nset = {}\n", "events[0].set", "sets no parameter"),
        ("[[events]]\nat_s = 1\nwhen = 2\nset = { SIM_ENGINE_FAIL = 1 }\n", "events[0].when", "unknown key"),
        ("events = 3\n", "events", "array of tables"),
        # the nested pad (vision.pad): markers that overlap or do not fit the deck, one line naming the key
        (_PAD.format("{ id = 76, size_m = 0.333 }, { id = 42, size_m = 0.125 }"), "pad.markers[1]", "overlaps"),
        (_PAD.format("{ id = 76, size_m = 0.333, x_m = 0.5 }"), "pad.markers[0]", "does not fit"),
        (
            _PAD.format("{ id = 76, size_m = 0.333 }, { id = 76, size_m = 0.1, x_m = 0.4 }"),
            "pad.markers[1].id",
            "twice",
        ),
        (_PAD.format("{ id = 76, size_m = -0.3 }"), "pad.markers[0].size_m", "> 0"),
        (_PAD.format("{ id = 76, size_m = 0.3, z_m = 1 }"), "pad.markers[0].z_m", "unknown key"),
        (_PAD.format("{ size_m = 0.3 }"), "pad.markers[0]", "missing id"),
        (_PAD.format('{ id = 76, size_m = "big" }'), "pad.markers[0].size_m", "number of metres"),
        ("[pad]\nlayout = 1\n", "pad", "markers = "),
    ],
)
def test_bad_files_name_file_key_and_reason(tmp_path, text, key, reason):
    path = write(tmp_path, text)
    with pytest.raises(ScenarioError) as err:
        load_scenario(path)
    e = err.value
    assert e.file == str(path) and e.key == key and reason in e.reason
    assert str(e).startswith(f"{path}: {key}: ")


def test_bad_toml_and_missing_file(tmp_path):
    path = write(tmp_path, "[parameters\nSIM_WIND_SPD = 1\n")
    with pytest.raises(ScenarioError, match="not valid TOML") as err:
        load_scenario(path)
    assert err.value.file == str(path)
    with pytest.raises(ScenarioError, match="no such scenario file.*windy"):
        load_scenario("no_such_scenario")


def test_event_schedule():
    a, b, c = (
        ScenarioEvent(0, {"SIM_WIND_SPD": 1.0}),
        ScenarioEvent(40_000, {"SIM_WIND_SPD": 2.0}),
        ScenarioEvent(40_000, {"SIM_WIND_SPD": 3.0}),
    )
    sched = EventSchedule([b, a, c])
    assert sched.next_us == 0 and len(sched) == 3
    assert sched.pop_due(0) == [a] and sched.next_us == 40_000
    assert sched.pop_due(20_000) == []
    assert sched.pop_due(60_000) == [b, c] and sched.next_us == math.inf and len(sched) == 0
    assert EventSchedule().next_us == math.inf


def test_lockstep_applies_events_at_50hz_periods():
    from sitl.lockstep import LockstepServer

    wind, sensors, motors = WindSettings(), SensorSettings(), MotorSettings()
    fake_sim = SimpleNamespace(
        wind_settings=wind,
        sensors=SimpleNamespace(settings=sensors),
        motor_settings=motors,
        ugv_settings=UgvSettings(),
        camera_settings=CameraSettings(),
        rotors=SimpleNamespace(n=6),
    )
    server = LockstepServer(
        fake_sim,
        0,
        None,
        None,  # TCP port 0: any free port; no truth, no UDP service
        events=load_scenario("hexa_motor_failure").events,
    )
    try:
        assert server.param_server is None
        server._every_truth_period(19_980_000)
        assert motors.fail_motor == 0
        server._every_truth_period(20_000_000)
        assert (motors.fail_motor, motors.fail_efficiency) == (1, 0.0)
    finally:
        server.close()
