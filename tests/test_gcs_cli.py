"""Tests of the bundled ground station that need no simulator or flight controller.

Pure parts (mode table, parameter encoding, NED <-> lat/lon, argument parsing)
are tested directly; the client, CLI, process stack and demo are exercised
against :mod:`gcs.fake_vehicle`, a kinematic stand-in speaking PX4's MAVLink,
and against a port where nothing answers.
"""

from __future__ import annotations

import math
import random
import socket
import struct
import subprocess
import sys
import time
from pathlib import Path

import pytest

from gcs import demo, geo, modes, param_codec
from gcs.__main__ import build_parser, main, resolve_url, status_line
from gcs.client import CommandRefused, GcsTimeout, VehicleClient
from gcs.fake_vehicle import HOME, FakeVehicle
from gcs.stack import Stack, StackError

ROOT = Path(__file__).resolve().parent.parent
FAKE = {"sitl_module": "gcs.fake_vehicle sitl", "autopilot_module": "gcs.fake_vehicle autopilot"}


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# --------------------------------------------------------------------------- modes


PX4_NUMBERS = {  # name: (main, sub), from PX4's px4_custom_mode.h
    "MANUAL": (1, 0), "ALTCTL": (2, 0), "POSCTL": (3, 0), "READY": (4, 1), "TAKEOFF": (4, 2),
    "LOITER": (4, 3), "MISSION": (4, 4), "RTL": (4, 5), "LAND": (4, 6), "PRECLAND": (4, 9),
    "ACRO": (5, 0), "OFFBOARD": (6, 0), "STABILIZED": (7, 0),
}


@pytest.mark.parametrize("mode", modes.MODES, ids=lambda m: m.name)
def test_mode_round_trip(mode):
    cm = modes.name_to_custom_mode(mode.name)
    assert cm == PX4_NUMBERS[mode.name][0] << 16 | PX4_NUMBERS[mode.name][1] << 24
    assert modes.custom_mode_to_name(cm) == mode.name
    assert modes.name_to_custom_mode(mode.px4_name) == cm
    assert modes.name_to_custom_mode(mode.px4_name.lower()) == cm
    assert modes.decode_custom_mode(cm) == (mode.main, mode.sub)


def test_mode_table_covers_px4_modes():
    assert set(modes.mode_names()) == set(PX4_NUMBERS)


def test_mode_aliases_and_errors():
    loiter = modes.name_to_custom_mode("LOITER")
    assert loiter == 0x03040000
    for alias in ("hold", "HOLD", "AUTO.LOITER", "auto.hold", " Loiter "):
        assert modes.name_to_custom_mode(alias) == loiter
    assert modes.same_mode("AUTO.MISSION", "mission")
    assert modes.name_to_custom_mode("AUTO.RTL") == 5 << 24 | 4 << 16
    with pytest.raises(modes.UnknownModeError, match="unknown mode 'GUIDED'"):
        modes.lookup_mode("GUIDED")
    assert modes.custom_mode_to_name(4 << 16 | 7 << 24) == "UNKNOWN(4.7)"
    assert modes.custom_mode_to_name(3 << 16 | 1 << 24) == "POSCTL"  # POSCTL sub-modes (orbit...) are POSCTL


# --------------------------------------------------------------------------- parameters


INT32_VALUES = [0, 1, -1, 42, 4001, 1000000, 2**31 - 1, -2**31,
                -8388607, -4194305, 2139095041, 0x7FA00000]  # the last four are signalling-NaN patterns


@pytest.mark.parametrize("value", INT32_VALUES)
def test_int32_bytewise_round_trip(value):
    raw = param_codec.encode_param_bytes(value, param_codec.INT32)
    assert raw == struct.pack("<i", value)  # byte-wise: the int's own bytes, not a float conversion
    assert param_codec.decode_param_bytes(raw, param_codec.INT32) == value


def test_int32_encoding_is_not_float_conversion():
    assert param_codec.encode_param_float(1, param_codec.INT32) == struct.unpack("<f", b"\x01\0\0\0")[0]
    assert param_codec.encode_param_float(1, param_codec.INT32) != 1.0
    for value in (0, 1, -1, 42, 2**31 - 1, -2**31, 123456789):
        f = param_codec.encode_param_float(value, param_codec.INT32)
        assert param_codec.decode_param_float(f, param_codec.INT32) == value


def test_real32_and_small_int_types():
    for value in (0.0, 2.5, -1e-3, 1e6):
        raw = param_codec.encode_param_bytes(value, param_codec.REAL32)
        assert param_codec.decode_param_bytes(raw, param_codec.REAL32) == struct.unpack("<f", struct.pack("<f", value))[0]
    assert param_codec.decode_param_bytes(param_codec.encode_param_bytes(-5, param_codec.INT8), param_codec.INT8) == -5
    assert param_codec.decode_param_bytes(param_codec.encode_param_bytes(60000, param_codec.UINT16),
                                          param_codec.UINT16) == 60000
    with pytest.raises(ValueError):
        param_codec.encode_param_bytes(1.5, param_codec.INT32)
    with pytest.raises(ValueError):
        param_codec.encode_param_bytes(2**31, param_codec.INT32)


# --------------------------------------------------------------------------- geo


def test_ned_global_round_trip():
    rng = random.Random(1)
    for lat0 in (0.0, 47.397742, -33.9, 70.0):
        for _ in range(50):
            n, e, d = (rng.uniform(-500, 500) for _ in range(3))
            lat, lon, alt = geo.ned_to_global(lat0, 8.5, 488.0, n, e, d)
            n2, e2, d2 = geo.global_to_ned(lat0, 8.5, 488.0, lat, lon, alt)
            assert (n2, e2, d2) == pytest.approx((n, e, d), abs=1e-6)


def test_ned_to_global_flat_earth_formula():
    lat, lon, alt = geo.ned_to_global(47.0, 8.0, 500.0, 10.0, 10.0, -5.0)
    assert math.radians(lat - 47.0) == pytest.approx(10.0 / 6378137.0)
    assert math.radians(lon - 8.0) == pytest.approx(10.0 / (6378137.0 * math.cos(math.radians(47.0))))
    assert alt == 505.0
    assert geo.e7_to_deg(geo.deg_to_e7(47.3977421)) == pytest.approx(47.3977421, abs=1e-7)


# --------------------------------------------------------------------------- CLI parsing


def test_cli_parsing():
    p = build_parser()
    a = p.parse_args(["status"])
    assert a.command == "status" and not a.once and resolve_url(a) == "udpin:0.0.0.0:14550"
    a = p.parse_args(["--instance", "3", "--timeout", "2.5", "status", "--once"])
    assert a.once and a.timeout == 2.5 and resolve_url(a) == "udpin:0.0.0.0:14553"
    a = p.parse_args(["--url", "udpin:127.0.0.1:15000", "--instance", "3", "arm"])
    assert resolve_url(a) == "udpin:127.0.0.1:15000"
    assert math.isnan(p.parse_args(["takeoff"]).alt)
    assert math.isnan(p.parse_args(["takeoff", "nan"]).alt)
    a = p.parse_args(["takeoff", "7.5", "--arm"])
    assert a.alt == 7.5 and a.arm
    assert p.parse_args(["disarm", "--force"]).force
    assert not p.parse_args(["disarm"]).force
    assert p.parse_args(["mode", "AUTO.LOITER"]).name == "AUTO.LOITER"
    a = p.parse_args(["param", "set", "MPC_XY_P", "0.95"])
    assert (a.param_command, a.name, a.value) == ("set", "MPC_XY_P", 0.95)
    for bad in ([], ["fly"], ["mode"], ["--timeout", "0", "arm"], ["takeoff", "inf"]):
        with pytest.raises(SystemExit) as exc:
            p.parse_args(bad)
        assert exc.value.code == 2


def test_unknown_mode_exits_1_without_connecting(capsys):
    assert main(["--instance", "37", "--timeout", "0.2", "mode", "GUIDED"]) == 1
    assert "unknown mode 'GUIDED'" in capsys.readouterr().err


# --------------------------------------------------------------------------- nothing answering


def test_arm_without_vehicle_times_out_with_exit_2(capsys):
    t0 = time.monotonic()
    assert main(["--instance", "37", "--timeout", "0.5", "arm"]) == 2
    assert time.monotonic() - t0 < 5
    err = capsys.readouterr().err
    assert "timed out after 0.5 s waiting for a heartbeat from the vehicle" in err
    assert "udpin:0.0.0.0:14587" in err


def test_python_m_gcs_arm_without_vehicle_exits_2():
    proc = subprocess.run([sys.executable, "-m", "gcs", "--instance", "37", "--timeout", "0.5", "arm"],
                          cwd=ROOT, capture_output=True, text=True, timeout=30)
    assert proc.returncode == 2
    assert "waiting for a heartbeat" in proc.stderr


# --------------------------------------------------------------------------- against the fake vehicle


@pytest.fixture
def fake():
    """A FakeVehicle thread sending to a free UDP port; yields (vehicle, url for the client)."""
    port = free_udp_port()
    vehicle = FakeVehicle([f"udpout:127.0.0.1:{port}"], speed=20.0)
    with vehicle:
        yield vehicle, f"udpin:127.0.0.1:{port}"


def cli(url: str, *args: str, timeout: float = 5.0) -> int:
    return main(["--url", url, "--timeout", str(timeout), *args])


def test_client_state_and_commands(fake):
    vehicle, url = fake
    with VehicleClient(url, timeout_s=5) as c:
        assert c.mode_name() == "LOITER" and not c.armed()
        c.wait_until(c.prearm_ok, 5, "ready to arm")
        home = c.wait_home()
        assert (home.lat_deg, home.lon_deg, home.alt_amsl_m) == pytest.approx(HOME, abs=1e-6)
        t0 = c.sim_time_s()
        c.wait_sim_time(0.5)
        assert c.sim_time_s() >= t0 + 0.5
        assert c.position_ned() == pytest.approx((0, 0, 0), abs=0.02)
        res = c.set_mode("posctl")
        assert res.accepted and res.result_name == "ACCEPTED"
        c.wait_mode("POSCTL", 5)
        assert c.mode_name() == "POSCTL"
        res = c.command_long(31000, 1, 2)  # a command the vehicle does not implement
        assert not res.accepted and res.result_name == "UNSUPPORTED"
        with pytest.raises(CommandRefused, match="UNSUPPORTED"):
            res.check()
        with pytest.raises(GcsTimeout, match="waiting for the impossible"):
            c.wait_until(lambda: False, 0.3, "the impossible")


def test_command_retries_until_ack(fake):
    vehicle, url = fake
    vehicle.drop_acks = 2
    with VehicleClient(url, timeout_s=5) as c:
        res = c.command_long(176, 1, 4, 3, timeout_s=3, retries=3)  # DO_SET_MODE AUTO.LOITER
        assert res.accepted
        sent = [m for m in vehicle.commands if m.command == 176]
        assert [m.confirmation for m in sent] == [0, 1, 2]


def test_command_without_ack_times_out(fake):
    vehicle, url = fake
    with VehicleClient(url, timeout_s=5) as c:
        vehicle.drop_acks = 100
        with pytest.raises(GcsTimeout, match="MAV_CMD_COMPONENT_ARM_DISARM"):
            c.arm(timeout_s=0.6)


def test_params_int32_and_real32(fake):
    vehicle, url = fake
    with VehicleClient(url, timeout_s=5) as c:
        assert c.param_get("SYS_AUTOSTART") == 4001
        assert c.param_get("MIS_TAKEOFF_ALT") == pytest.approx(2.5)
        assert c.param_set("SYS_AUTOSTART", 4002) == 4002
        assert vehicle.params["SYS_AUTOSTART"][0] == struct.pack("<i", 4002)
        assert c.param_set("COM_RC_IN_MODE", -8388607) == -8388607  # survives as exact bytes
        assert vehicle.params["COM_RC_IN_MODE"][0] == struct.pack("<i", -8388607)
        assert c.param_set("MIS_TAKEOFF_ALT", 3.25) == pytest.approx(3.25)
        with pytest.raises(GcsTimeout, match="NO_SUCH_PARAM"):
            c.param_get("NO_SUCH_PARAM", timeout_s=0.5)


def test_goto_ned_sends_global_reposition(fake):
    vehicle, url = fake
    with VehicleClient(url, timeout_s=5) as c:
        c.wait_until(c.prearm_ok, 5, "ready")
        c.arm().check()
        c.takeoff(HOME[2] + 3).check()
        c.wait_until(lambda: c.takeoff_done(3.0), 10, "takeoff")
        c.goto_ned(4.0, -3.0, -3.0).check()
        msg = [m for m in vehicle.commands if m.command == 192][-1]
        assert msg.get_type() == "COMMAND_INT" and msg.frame == 0
        lat, lon, alt = geo.ned_to_global(*HOME, 4.0, -3.0, -3.0)
        assert (msg.x, msg.y, msg.z) == (geo.deg_to_e7(lat), geo.deg_to_e7(lon), pytest.approx(alt))
        assert msg.param1 == -1 and msg.param2 == 1 and math.isnan(msg.param4)
        c.wait_until(lambda: c.arrived(4.0, -3.0), 10, "arrival")
        n, e, d = c.position_ned()
        assert math.hypot(n - 4.0, e + 3.0) < 0.5 and d == pytest.approx(-3.0, abs=0.3)


def test_cli_flight_against_fake(fake, capsys):
    vehicle, url = fake
    assert cli(url, "status", "--once") == 0
    out = capsys.readouterr().out
    assert "LOITER" in out and "disarmed" in out and "GPS 3D" in out
    time.sleep(0.1)  # let the fake pass its pre-arm delay (1 simulated s at 20x)
    assert cli(url, "arm") == 0
    assert "armed" in capsys.readouterr().out
    assert cli(url, "takeoff", "4") == 0
    assert "m above home (mode" in capsys.readouterr().out
    assert vehicle.pos[2] == pytest.approx(-4.0, abs=0.6)
    assert cli(url, "mode", "hold") == 0
    assert "mode LOITER (AUTO.LOITER)" in capsys.readouterr().out
    assert cli(url, "disarm") == 1
    err = capsys.readouterr().err
    assert "DENIED" in err and "Disarming denied: not landed" in err
    assert cli(url, "rtl", timeout=20) == 0
    assert "landed and disarmed" in capsys.readouterr().out
    assert not vehicle.armed


def test_cli_arm_refused_prints_result_and_reason(capsys):
    port = free_udp_port()
    with FakeVehicle([f"udpout:127.0.0.1:{port}"], speed=20.0, refuse_arm=True):
        assert cli(f"udpin:127.0.0.1:{port}", "arm") == 1
    err = capsys.readouterr().err
    assert "arm refused: DENIED" in err
    assert "Arming denied: fake refusal for tests" in err


def test_status_line_without_data():
    class Nothing(VehicleClient):
        def __init__(self):  # no connection: every accessor sees an empty cache
            self._latest, self._latest_wall, self._sim_time_ms, self.statustexts = {}, {}, None, []
            self._last_rx_wall = None
    line = status_line(Nothing())
    assert "?" in line and "disarmed" in line


# --------------------------------------------------------------------------- stack and demo with stand-ins


def test_stack_ports_and_commands():
    s = Stack(instance=7, speed=2, vehicle="quad_x", extra_sitl_args=["--x"], home="1,2,3", seed=5)
    assert (s.sitl_port, s.gcs_port, s.api_port) == (4567, 14557, 14547)
    assert s.api_url == "udpin:0.0.0.0:14547"
    assert s.sitl_command()[1:] == ["-m", "sitl", "--vehicle", "quad_x", "--speed", "2", "--instance", "7",
                                    "--home", "1,2,3", "--seed", "5", "--x"]
    assert s.autopilot_command()[1:] == ["-m", "autopilot", "--vehicle", "quad_x", "--instance", "7"]


def test_demo_flies_square_against_fake_stack(capsys):
    rc = demo.main(["--instance", "41", "--sitl-module", FAKE["sitl_module"],
                    "--autopilot-module", FAKE["autopilot_module"], "--autopilot-arg=--speed=40",
                    "--ready-timeout", "20", "--step-timeout", "20"])
    out = capsys.readouterr()
    assert rc == 0, out.err
    assert "flight demo: OK" in out.out
    for expected in ("armed", "taking off to 5 m", "held 10 s", "at corner 4 (start)", "disarmed",
                     "flight time", "max altitude", "landing error", "real-time factor"):
        assert expected in out.out


def test_stack_reports_dead_child_with_log_tail(capsys):
    rc = demo.main(["--instance", "42", "--sitl-module", FAKE["sitl_module"],
                    "--autopilot-module", "gcs.no_such_module", "--ready-timeout", "20"])
    err = capsys.readouterr().err
    assert rc == 1
    assert "autopilot exited early" in err and "No module named gcs.no_such_module" in err


def test_stack_starts_logs_and_stops():
    with Stack(instance=43, extra_autopilot_args=["--speed", "20"], **FAKE) as stack:
        with VehicleClient(stack.api_url, timeout_s=20, idle=stack.check_alive) as c:
            assert c.mode_name() == "LOITER"
        procs = list(stack.procs.values())
        assert all(p.poll() is None for p in procs)
    assert all(p.poll() is not None for p in procs)
    assert "fake sitl listening on TCP 4603" in stack.log_path("sitl").read_text()
    assert stack.log_path("autopilot").read_text().startswith("$ ")
    # a second stack on a busy instance is refused up front
    with Stack(instance=44, **FAKE) as first:
        with pytest.raises(StackError, match="already in use"):
            Stack(instance=44, **FAKE).start()
        assert first.exited() == {}
