"""The simulator's SIM_* parameters: the table, scenario files, the MAVLink service, the process.

* :class:`sitl.sim_params.SimParameters` and :mod:`sitl.scenario` are pure: tested directly.
* :class:`sitl.param_server.SimParamServer` runs in this process on a real UDP socket;
  a pymavlink client (``udpin``) is its default peer.  The test drives ``poll()`` itself
  with a fake wall clock, so nothing depends on timing (deadlines only stop a broken
  test from hanging).
* One test (marked ``e2e``) starts the real ``sitl`` process (its instance from
  tests/instances.py), which serves its parameters while it waits for a flight controller.
"""

from __future__ import annotations

import math
import os
import socket
import struct
import subprocess
import sys
import time
import tomllib
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from mavsim_core.param_encoding import INT32, REAL32, raw_param_value  # noqa: E402
from sitl import __main__ as sitl_main  # noqa: E402
from sitl.param_server import SIM_COMPID, SIM_SYSID, SimParamServer  # noqa: E402
from sitl.scenario import EventSchedule, ScenarioError, ScenarioEvent, list_scenarios, load_scenario  # noqa: E402
from sitl.sim_params import ParamRow, SimParamError, SimParameters, format_table  # noqa: E402
from sitl.sim_settings import MotorSettings, SensorSettings, WindSettings, param_fields, sim_param  # noqa: E402

ROOT = Path(__file__).resolve().parent.parent
GCS_SYS, GCS_COMP = 255, 190

from instances import instance  # tests/instances.py: every test's instance numbers

SITL_INSTANCE = instance("test_sim_params", "sitl")


def make_params() -> tuple[SimParameters, WindSettings, SensorSettings, MotorSettings]:
    wind, sensors, motors = WindSettings(), SensorSettings(), MotorSettings()
    return SimParameters(wind, sensors, motors), wind, sensors, motors


def float32(x: float) -> float:
    return struct.unpack("<f", struct.pack("<f", x))[0]


# --------------------------------------------------------------------------- SimParameters


def test_list_order_indices_and_defaults():
    params, wind, sensors, motors = make_params()
    fields = [f for s in (wind, sensors, motors) for f in param_fields(s)]
    assert len(params) == len(fields) and len(params) > 30
    assert params.names() == [f.metadata["param"] for f in fields]
    assert len(set(params.names())) == len(params)
    for i, p in enumerate(params):
        assert p.index == i and params.at(i) is p and params.param(p.name) is p
        assert params.get(p.name) == p.default
        assert len(p.name) <= 16 and p.name.startswith("SIM_")
    assert params.param("SIM_ENGINE_FAIL").type == "INT32"
    assert params.param("SIM_WIND_SPD").type == "REAL32"
    assert "SIM_WIND_SPD" in params and "NOPE" not in params


def test_set_writes_the_settings_objects():
    params, wind, sensors, motors = make_params()
    assert params.set("SIM_WIND_SPD", 5) == 5.0
    assert wind.speed_m_s == 5.0 and isinstance(wind.speed_m_s, float)
    assert params.set("SIM_ENGINE_FAIL", 3.0) == 3
    assert motors.fail_motor == 3 and isinstance(motors.fail_motor, int)  # INT32 stored as int
    params.set("SIM_GPS_LAG_MS", 200)
    assert sensors.gps_lag_ms == 200 and params.get("SIM_GPS_LAG_MS") == 200
    params.set("SIM_GPS_GLITCH_N", -1000)  # limits are inclusive
    assert sensors.gps_glitch_n_m == -1000.0
    # a limit that came through a float32 (0.1 -> 0.10000000149) is the limit
    assert params.set("SIM_GYR_NOISE", float32(0.1)) == 0.1


@pytest.mark.parametrize(
    "name, value, reason",
    [
        ("SIM_NOPE", 1.0, "unknown parameter"),
        ("SIM_WIND_SPD", math.nan, "finite"),
        ("SIM_WIND_SPD", math.inf, "finite"),
        ("SIM_WIND_SPD", -math.inf, "finite"),
        ("SIM_WIND_SPD", 30.5, "outside range [0, 30] m/s"),
        ("SIM_WIND_SPD", -0.1, "outside range"),
        ("SIM_GYR_NOISE", 0.1000002, "outside range"),
        ("SIM_ENGINE_FAIL", 13, "outside range [0, 12]"),
        ("SIM_ENGINE_FAIL", 2.5, "not an integer"),
        ("SIM_GPS_LAG_MS", 1e-45, "not an integer"),  # a byte-wise int mistaken for a float
        ("SIM_ENGINE_FAIL", "3", "expected a number"),
        ("SIM_GPS_DISABLE", True, "expected a number"),
        ("SIM_WIND_SPD", None, "expected a number"),
    ],
)
def test_refusals_change_nothing(name, value, reason):
    params, *_ = make_params()
    before = {n: params.get(n) for n in params.names()}
    with pytest.raises(SimParamError) as err:
        params.set(name, value)
    assert reason in err.value.reason and err.value.name == name
    assert str(err.value).startswith(f"{name}: ")
    assert {n: params.get(n) for n in params.names()} == before


def test_set_many_is_all_or_nothing_and_at_checks_index():
    params, wind, _, motors = make_params()
    with pytest.raises(SimParamError, match="SIM_ENGINE_FAIL"):
        params.set_many({"SIM_WIND_SPD": 4.0, "SIM_ENGINE_FAIL": 99})
    assert wind.speed_m_s == 0.0 and motors.fail_motor == 0
    params.set_many({"SIM_WIND_SPD": 4.0, "SIM_ENGINE_FAIL": 2})
    assert wind.speed_m_s == 4.0 and motors.fail_motor == 2
    for bad in (-1, len(params)):
        with pytest.raises(SimParamError, match="no parameter at index"):
            params.at(bad)


def test_describe_and_table():
    params, *_ = make_params()
    params.set("SIM_WIND_DIR", 270)
    rows = params.describe()
    assert len(rows) == len(params) and all(isinstance(r, ParamRow) for r in rows)
    row = next(r for r in rows if r.name == "SIM_WIND_DIR")
    assert (row.value, row.default, row.min, row.max, row.unit) == (270, 0.0, 0.0, 360.0, "deg")
    table = format_table(rows).splitlines()
    assert table[0].split()[:5] == ["NAME", "VALUE", "MIN", "MAX", "UNIT"]
    assert any(line.split()[:4] == ["SIM_WIND_DIR", "270", "0", "360"] for line in table)
    assert any(line.split()[:4] == ["SIM_ENGINE_FAIL", "0", "0", "12"] for line in table)


def test_int32_limits_must_survive_a_float():
    @dataclass
    class Huge:
        n: int = sim_param("SIM_HUGE", 0, 0, 2**31 - 1, "", "too wide for the float path", "INT32")

    with pytest.raises(ValueError, match="SIM_HUGE"):
        SimParameters(WindSettings(), SensorSettings(), Huge())


# --------------------------------------------------------------------------- scenarios


def write(tmp_path: Path, text: str, name: str = "s.toml") -> Path:
    path = tmp_path / name
    path.write_text(text)
    return path


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


def test_scenarios_are_package_data():
    with open(ROOT / "pyproject.toml", "rb") as f:
        package_data = tomllib.load(f)["tool"]["setuptools"]["package-data"]["params"]
    assert "scenarios/*.toml" in package_data


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


# --------------------------------------------------------------------------- the CLI


def test_cli_list_params(capsys):
    assert (
        sitl_main.main(
            ["--list-params", "--scenario", "windy", "--param", "SIM_WIND_SPD=7", "--param", "SIM_ENGINE_FAIL=2"]
        )
        == 0
    )
    out = capsys.readouterr().out.splitlines()
    rows = {line.split()[0]: line.split() for line in out[1:]}
    assert rows["SIM_WIND_SPD"][1] == "7" and rows["SIM_WIND_DIR"][1] == "270" and rows["SIM_ENGINE_FAIL"][1] == "2"
    assert rows["SIM_WIND_SPD"][2:5] == ["0", "30", "m/s"]


@pytest.mark.parametrize(
    "args, message",
    [
        (["--param", "SIM_WIND_SPD=99"], "SIM_WIND_SPD: 99 outside range"),
        (["--param", "SIM_NOPE=1"], "SIM_NOPE: unknown parameter"),
        (["--param", "SIM_WIND_SPD=fast"], "value must be a number"),
        (["--param", "SIM_WIND_SPD"], "expected NAME=VALUE"),
        (["--scenario", "no_such_scenario"], "no such scenario file"),
    ],
)
def test_cli_errors_exit_2(capsys, args, message):
    with pytest.raises(SystemExit) as exit_:  # argparse errors exit by themselves ...
        sys.exit(sitl_main.main(["--list-params", *args]))  # ... checked values return 2
    assert exit_.value.code == 2
    assert message in capsys.readouterr().err


def test_cli_bad_scenario_file_exits_2(tmp_path, capsys):
    path = write(tmp_path, "[parameters]\nSIM_ENGINE_FAIL = 99\n")
    assert sitl_main.main(["--list-params", "--scenario", str(path)]) == 2
    err = capsys.readouterr().err
    assert str(path) in err and "parameters.SIM_ENGINE_FAIL" in err and "outside range" in err


# --------------------------------------------------------------------------- the MAVLink service


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Harness:
    """A SimParamServer on a real socket and a pymavlink client as its default peer."""

    def __init__(self) -> None:
        self.params, self.wind, self.sensors, self.motors = make_params()
        port = free_udp_port()
        self.client = mavutil.mavlink_connection(
            f"udpin:127.0.0.1:{port}", source_system=GCS_SYS, source_component=GCS_COMP
        )
        self.changes: list[tuple[str, float, tuple]] = []
        self.server = SimParamServer(
            self.params,
            bind=("127.0.0.1", 0),
            default_peer=("127.0.0.1", port),
            on_param_set=lambda *a: self.changes.append(a),
        )
        self.now_s = 0.0  # the fake wall clock handed to poll()

    def pump(self, rounds: int = 20) -> list:
        """Poll the server and drain the client until a few rounds bring nothing new."""
        got, quiet, deadline = [], 0, time.monotonic() + 5.0
        while quiet < rounds and time.monotonic() < deadline:
            self.server.poll(self.now_s)
            m = self.client.recv_match(blocking=True, timeout=0.005)
            if m is None:
                quiet += 1
                continue
            quiet = 0
            if m.get_type() != "BAD_DATA":
                got.append(m)
        return got

    def hello(self) -> None:
        """First contact: the heartbeat tells the client where the server is."""
        got = self.pump()
        assert [m.get_type() for m in got] == ["HEARTBEAT"]

    def close(self) -> None:
        self.server.close()
        self.client.close()


@pytest.fixture
def h():
    harness = Harness()
    yield harness
    harness.close()


def of_type(msgs: list, kind: str) -> list:
    return [m for m in msgs if m.get_type() == kind]


def value_of(pv) -> int | float:
    """A PARAM_VALUE's value, C-cast: the float is the value (an int for integer types)."""
    return pv.param_value if pv.param_type == REAL32 else int(pv.param_value)


def test_heartbeat_identity_and_pacing(h):
    got = h.pump()
    (hb,) = of_type(got, "HEARTBEAT")
    assert (hb.get_srcSystem(), hb.get_srcComponent()) == (SIM_SYSID, SIM_COMPID) == (1, 51)
    assert (hb.type, hb.autopilot) == (mavlink.MAV_TYPE_GENERIC, mavlink.MAV_AUTOPILOT_GENERIC)
    assert h.client.probably_vehicle_heartbeat(hb) and h.client.target_system == 1  # pymavlink locks on
    h.now_s = 0.9
    assert of_type(h.pump(), "HEARTBEAT") == []
    h.now_s = 1.0
    assert len(of_type(h.pump(), "HEARTBEAT")) == 1
    h.now_s = 10.0  # a stalled loop gets one heartbeat, not a burst
    assert len(of_type(h.pump(), "HEARTBEAT")) == 1


def test_full_list_download(h):
    h.hello()
    h.client.mav.param_request_list_send(SIM_SYSID, SIM_COMPID)
    got = of_type(h.pump(), "PARAM_VALUE")
    n = len(h.params)
    assert len(got) == n
    assert {m.param_count for m in got} == {n}
    assert sorted(m.param_index for m in got) == list(range(n))
    assert [m.param_id for m in sorted(got, key=lambda m: m.param_index)] == h.params.names()
    for m in got:
        p = h.params.at(m.param_index)
        assert m.param_type == (INT32 if p.type == "INT32" else REAL32)
        assert value_of(m) == pytest.approx(h.params.get(p.name), rel=1e-7)
    lag = next(m for m in got if m.param_id == "SIM_GPS_LAG_MS")
    assert raw_param_value(lag) == struct.pack("<f", 120.0)  # C-cast (the simulator is not PX4), not byte-wise


def test_read_by_name_and_index(h):
    h.hello()
    h.client.mav.param_request_read_send(SIM_SYSID, SIM_COMPID, b"SIM_GUST_DUR", -1)
    (pv,) = of_type(h.pump(), "PARAM_VALUE")
    assert (pv.param_id, pv.param_value, pv.param_index) == ("SIM_GUST_DUR", 2.0, h.params.param("SIM_GUST_DUR").index)
    idx = h.params.param("SIM_ENGINE_FAIL").index
    h.client.mav.param_request_read_send(SIM_SYSID, SIM_COMPID, b"IGNORED", idx)
    (pv,) = of_type(h.pump(), "PARAM_VALUE")
    assert pv.param_id == "SIM_ENGINE_FAIL" and pv.param_type == INT32 and value_of(pv) == 0
    h.client.mav.param_request_read_send(0, 0, b"SIM_WIND_DIR", -1)  # broadcast target
    assert [m.param_id for m in of_type(h.pump(), "PARAM_VALUE")] == ["SIM_WIND_DIR"]
    h.client.mav.param_request_read_send(SIM_SYSID, 1, b"SIM_WIND_DIR", -1)  # the flight controller's: not us
    assert of_type(h.pump(), "PARAM_VALUE") == []
    h.client.mav.param_request_read_send(SIM_SYSID, SIM_COMPID, b"SIM_NOPE", -1)
    h.client.mav.param_request_read_send(SIM_SYSID, SIM_COMPID, b"", len(h.params))
    got = h.pump()
    assert of_type(got, "PARAM_VALUE") == []
    n = len(h.params)
    assert [m.text for m in of_type(got, "STATUSTEXT")] == [
        "SIM_NOPE: unknown parameter",
        f"#{n}: no parameter at index {n} (0..{n - 1})",
    ]


def test_set_real32_and_int32_c_cast(h):
    h.hello()
    h.client.mav.param_set_send(SIM_SYSID, SIM_COMPID, b"SIM_WIND_SPD", 4.5, REAL32)
    got = h.pump()
    (pv,) = of_type(got, "PARAM_VALUE")
    assert (pv.param_id, pv.param_value, pv.param_type) == ("SIM_WIND_SPD", 4.5, REAL32)
    assert of_type(got, "STATUSTEXT") == []
    assert h.wind.speed_m_s == 4.5  # the models read this object on their next step

    h.client.mav.param_set_send(SIM_SYSID, SIM_COMPID, b"SIM_ENGINE_FAIL", 3.0, INT32)
    (pv,) = of_type(h.pump(), "PARAM_VALUE")
    assert pv.param_type == INT32 and raw_param_value(pv) == struct.pack("<f", 3.0)
    assert h.motors.fail_motor == 3 and isinstance(h.motors.fail_motor, int)

    # read back
    h.client.mav.param_request_read_send(SIM_SYSID, SIM_COMPID, b"SIM_ENGINE_FAIL", -1)
    h.client.mav.param_request_read_send(SIM_SYSID, SIM_COMPID, b"SIM_WIND_SPD", -1)
    assert [(m.param_id, value_of(m)) for m in of_type(h.pump(), "PARAM_VALUE")] == [
        ("SIM_ENGINE_FAIL", 3),
        ("SIM_WIND_SPD", 4.5),
    ]

    # a client that sends an integer parameter typed REAL32: the value is what counts
    h.client.mav.param_set_send(SIM_SYSID, SIM_COMPID, b"SIM_GPS_LAG_MS", 250.0, REAL32)
    (pv,) = of_type(h.pump(), "PARAM_VALUE")
    assert pv.param_type == INT32 and value_of(pv) == 250 and h.sensors.gps_lag_ms == 250
    assert [c[:2] for c in h.changes] == [("SIM_WIND_SPD", 4.5), ("SIM_ENGINE_FAIL", 3), ("SIM_GPS_LAG_MS", 250)]
    assert h.server.params_set == 3


def test_refused_set_echoes_old_value_and_says_why(h):
    h.hello()
    h.client.mav.param_set_send(SIM_SYSID, SIM_COMPID, b"SIM_WIND_SPD", 40.0, REAL32)
    got = h.pump()
    (pv,) = of_type(got, "PARAM_VALUE")
    assert (pv.param_id, pv.param_value) == ("SIM_WIND_SPD", 0.0)
    (st,) = of_type(got, "STATUSTEXT")
    assert st.severity == mavlink.MAV_SEVERITY_ERROR and st.text == "SIM_WIND_SPD: 40 outside range [0, 30] m/s"
    assert h.wind.speed_m_s == 0.0

    h.client.mav.param_set_send(SIM_SYSID, SIM_COMPID, b"SIM_ENGINE_FAIL", 2.5, REAL32)
    got = h.pump()
    (pv,) = of_type(got, "PARAM_VALUE")
    assert pv.param_type == INT32 and value_of(pv) == 0
    assert "not an integer" in of_type(got, "STATUSTEXT")[0].text

    h.client.mav.param_set_send(SIM_SYSID, SIM_COMPID, b"SIM_ENGINE_FAIL", math.nan, REAL32)
    h.client.mav.param_set_send(SIM_SYSID, SIM_COMPID, b"SIM_ENGINE_FAIL", 2.8e-45, INT32)  # a byte-wise 2: refused
    got = h.pump()
    assert [value_of(m) for m in of_type(got, "PARAM_VALUE")] == [0, 0]
    texts = [m.text for m in of_type(got, "STATUSTEXT")]
    assert texts[0] == "SIM_ENGINE_FAIL: value must be finite, not nan"
    assert texts[1].startswith("SIM_ENGINE_FAIL: 2.8026e-45 is not an integer")

    h.client.mav.param_set_send(SIM_SYSID, SIM_COMPID, b"SIM_NOPE", 1.0, REAL32)
    got = h.pump()
    assert of_type(got, "PARAM_VALUE") == []
    assert [m.text for m in of_type(got, "STATUSTEXT")] == ["SIM_NOPE: unknown parameter"]
    assert h.motors.fail_motor == 0 and h.changes == [] and h.server.params_set == 0


def test_commands(h):
    h.hello()
    h.client.mav.command_long_send(SIM_SYSID, SIM_COMPID, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
    (ack,) = of_type(h.pump(), "COMMAND_ACK")
    assert (ack.command, ack.result) == (mavlink.MAV_CMD_COMPONENT_ARM_DISARM, mavlink.MAV_RESULT_UNSUPPORTED)
    assert (ack.target_system, ack.target_component) == (GCS_SYS, GCS_COMP)
    h.client.mav.command_long_send(
        SIM_SYSID,
        SIM_COMPID,
        mavlink.MAV_CMD_REQUEST_MESSAGE,
        0,
        mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION,
        0,
        0,
        0,
        0,
        0,
        0,
    )
    got = h.pump()
    (ver,) = of_type(got, "AUTOPILOT_VERSION")
    assert ver.capabilities & mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_C_CAST
    assert not ver.capabilities & mavlink.MAV_PROTOCOL_CAPABILITY_PARAM_ENCODE_BYTEWISE
    assert of_type(got, "COMMAND_ACK")[0].result == mavlink.MAV_RESULT_ACCEPTED
    h.client.mav.command_int_send(SIM_SYSID, SIM_COMPID, 0, mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 0, 0, 0)
    (ack,) = of_type(h.pump(), "COMMAND_ACK")
    assert ack.result == mavlink.MAV_RESULT_UNSUPPORTED


def test_mavftp_is_refused_at_once(h):
    h.hello()
    request = [7, 0, 3, 4, 1, 0, 0, 0, 0, 0, 0, 0] + [ord("/")] + [0] * 238  # seq 7, session 3, OpenFileRO "/"
    h.client.mav.file_transfer_protocol_send(0, SIM_SYSID, SIM_COMPID, request)
    (reply,) = of_type(h.pump(), "FILE_TRANSFER_PROTOCOL")
    p = reply.payload
    assert (p[0] | p[1] << 8, p[2], p[3], p[4], p[5], p[12]) == (8, 3, 129, 1, 4, 7)  # NAK, ERR_UnknownCommand


def test_malformed_datagrams_are_ignored(h):
    h.hello()
    server_addr = ("127.0.0.1", h.server.local_address[1])
    raw = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        good = mavlink.MAVLink_param_request_read_message(SIM_SYSID, SIM_COMPID, b"SIM_WIND_DIR", -1)
        packet = bytearray(good.pack(mavlink.MAVLink(None, GCS_SYS, GCS_COMP)))
        bad_crc = bytearray(packet)
        bad_crc[-1] ^= 0xFF
        for junk in (
            b"",
            b"\x00",
            b"hello world" * 50,
            bytes(range(256)),
            bytes(packet[:-3]),
            bytes(bad_crc),
            b"\xfd\xff" + b"\x00" * 300,
        ):
            raw.sendto(junk, server_addr)
        raw.sendto(bytes(packet) + b"\xfd\x09", server_addr)  # a good packet with trailing damage
        got = h.pump()
        assert [m.param_id for m in of_type(got, "PARAM_VALUE")] == ["SIM_WIND_DIR"]
        assert h.server.rx_errors >= 5
    finally:
        raw.close()


def test_peers_are_remembered_and_send_reaches_everyone(h):
    h.hello()
    other = mavutil.mavlink_connection(
        "udpout:127.0.0.1:%d" % h.server.local_address[1], source_system=GCS_SYS, source_component=191
    )
    try:
        other.mav.param_request_read_send(SIM_SYSID, SIM_COMPID, b"SIM_WIND_TURB", -1)
        got_default = h.pump()
        assert [m.param_id for m in of_type(got_default, "PARAM_VALUE")] == ["SIM_WIND_TURB"]  # default peer too
        m = other.recv_match(type="PARAM_VALUE", blocking=True, timeout=2)
        assert m is not None and m.param_id == "SIM_WIND_TURB"  # and the one who asked
        h.server.send(h.server.encode([mavlink.MAVLink_local_position_ned_message(1, 1.0, 2.0, 3.0, 0, 0, 0)]))
        m = other.recv_match(type="LOCAL_POSITION_NED", blocking=True, timeout=2)
        assert m is not None and (m.x, m.get_srcComponent()) == (1.0, SIM_COMPID)
        assert [x.x for x in of_type(h.pump(), "LOCAL_POSITION_NED")] == [1.0]
        assert len(h.server.destinations) == 2
    finally:
        other.close()


# --------------------------------------------------------------------------- the real process


@pytest.mark.e2e
def test_sitl_process_serves_parameters_while_waiting_for_the_flight_controller(tmp_path):
    instance = SITL_INSTANCE
    port = 14560 + instance
    client = mavutil.mavlink_connection(f"udpin:127.0.0.1:{port}", source_system=GCS_SYS, source_component=GCS_COMP)
    log_path = tmp_path / "sitl.log"
    log = open(log_path, "w")  # the child's; read through log_path (seeking this would move the child's offset)
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "sitl",
            "--instance",
            str(instance),
            "--speed",
            "max",
            "--scenario",
            "windy",
            "--param",
            "SIM_GPS_LAG_MS=80",
        ],
        cwd=ROOT,
        stdin=subprocess.DEVNULL,
        stdout=log,
        stderr=subprocess.STDOUT,
        start_new_session=True,
    )
    try:
        hb = client.recv_match(type="HEARTBEAT", blocking=True, timeout=60)
        assert hb is not None, f"no HEARTBEAT from sitl:\n{log_path.read_text()}"
        assert (hb.get_srcSystem(), hb.get_srcComponent()) == (1, 51)

        def exchange(send, name):
            for _ in range(5):  # UDP: retry as a ground station would
                send()
                m = client.recv_match(
                    type="PARAM_VALUE", blocking=True, timeout=2, condition=f"PARAM_VALUE.param_id == '{name}'"
                )
                if m is not None:
                    return m
            raise AssertionError(f"no PARAM_VALUE for {name}")

        m = exchange(lambda: client.mav.param_request_read_send(1, 51, b"SIM_WIND_DIR", -1), "SIM_WIND_DIR")
        assert m.param_value == 270.0  # from the scenario
        m = exchange(lambda: client.mav.param_request_read_send(1, 51, b"SIM_GPS_LAG_MS", -1), "SIM_GPS_LAG_MS")
        assert value_of(m) == 80  # from --param
        m = exchange(lambda: client.mav.param_set_send(1, 51, b"SIM_WIND_SPD", 3.0, REAL32), "SIM_WIND_SPD")
        assert m.param_value == 3.0
        m = exchange(lambda: client.mav.param_set_send(1, 51, b"SIM_ENGINE_FAIL", 2.0, INT32), "SIM_ENGINE_FAIL")
        assert value_of(m) == 2
        assert proc.poll() is None
    finally:
        proc.terminate()
        try:
            proc.wait(timeout=10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
        client.close()
        log.close()
    text = log_path.read_text()
    assert "scenario windy" in text and "SIM_WIND_SPD = 3 (PARAM_SET from" in text, text
