"""Tests of the bundled ground station that need no flight controller.

Pure parts (mode table, parameter encoding, NED <-> lat/lon, argument parsing,
the stack's command lines) are tested directly; the client and the CLI against
a port where nothing answers; the stack's error report with a real simulator
and a flight-controller module that does not exist.  Everything that needs a
vehicle flies the real stack in ``tests/test_e2e_flight.py``.
"""

from __future__ import annotations

import math
import random
import signal
import socket
import struct
import subprocess
import sys
from pathlib import Path

import pytest

from gcs import geo
from gcs.__main__ import build_parser, main, resolve_url, status_line
from gcs.client import VehicleClient
from gcs.errors import GcsTimeout, NoAnswer
from gcs.launcher import Stack, demo
from mavsim_core import param_encoding, ports
from mavsim_core import px4_modes as modes

ROOT = Path(__file__).resolve().parent.parent


@pytest.fixture(scope="module")
def nobody(free_instance) -> int:
    """A free instance no test starts: its own ground-station port stays silent."""
    return free_instance()


def url_of(instance: int) -> str:
    """The own ground-station port of ``instance`` (14840 + instance), as a ``udpin`` url."""
    return f"udpin:0.0.0.0:{ports.own_gcs_port(instance)}"


def free_udp_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


# --------------------------------------------------------------------------- modes


PX4_NUMBERS = {  # name: (main, sub), from PX4's px4_custom_mode.h
    "MANUAL": (1, 0),
    "ALTCTL": (2, 0),
    "POSCTL": (3, 0),
    "POSCTL_ORBIT": (3, 1),
    "READY": (4, 1),
    "TAKEOFF": (4, 2),
    "LOITER": (4, 3),
    "MISSION": (4, 4),
    "RTL": (4, 5),
    "LAND": (4, 6),
    "FOLLOW_TARGET": (4, 8),
    "PRECLAND": (4, 9),
    "ACRO": (5, 0),
    "OFFBOARD": (6, 0),
    "STABILIZED": (7, 0),
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
    assert modes.custom_mode_to_name(3 << 16 | 1 << 24) == "POSCTL_ORBIT"  # DO_ORBIT's mode, as PX4 reports it
    assert modes.custom_mode_to_name(3 << 16 | 2 << 24) == "POSCTL"  # other POSCTL sub-modes (slow) are POSCTL


# --------------------------------------------------------------------------- parameters


INT32_VALUES = [
    0,
    1,
    -1,
    42,
    4001,
    1000000,
    2**31 - 1,
    -(2**31),
    -8388607,
    -4194305,
    2139095041,
    0x7FA00000,
]  # the last four are signalling-NaN patterns


@pytest.mark.parametrize("value", INT32_VALUES)
def test_int32_bytewise_round_trip(value):
    raw = param_encoding.encode_param_bytes(value, param_encoding.INT32)
    assert raw == struct.pack("<i", value)  # byte-wise: the int's own bytes, not a float conversion
    assert param_encoding.decode_param_bytes(raw, param_encoding.INT32) == value


def test_int32_encoding_is_not_float_conversion():
    assert param_encoding.encode_param_float(1, param_encoding.INT32) == struct.unpack("<f", b"\x01\0\0\0")[0]
    assert param_encoding.encode_param_float(1, param_encoding.INT32) != 1.0
    for value in (0, 1, -1, 42, 2**31 - 1, -(2**31), 123456789):
        f = param_encoding.encode_param_float(value, param_encoding.INT32)
        assert param_encoding.decode_param_float(f, param_encoding.INT32) == value


def test_real32_and_small_int_types():
    for value in (0.0, 2.5, -1e-3, 1e6):
        raw = param_encoding.encode_param_bytes(value, param_encoding.REAL32)
        as_float32 = struct.unpack("<f", struct.pack("<f", value))[0]
        assert param_encoding.decode_param_bytes(raw, param_encoding.REAL32) == as_float32
    assert (
        param_encoding.decode_param_bytes(
            param_encoding.encode_param_bytes(-5, param_encoding.INT8), param_encoding.INT8
        )
        == -5
    )
    assert (
        param_encoding.decode_param_bytes(
            param_encoding.encode_param_bytes(60000, param_encoding.UINT16), param_encoding.UINT16
        )
        == 60000
    )
    with pytest.raises(ValueError):
        param_encoding.encode_param_bytes(1.5, param_encoding.INT32)
    with pytest.raises(ValueError):
        param_encoding.encode_param_bytes(2**31, param_encoding.INT32)


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
    assert a.once and a.timeout == 2.5 and resolve_url(a) == "udpin:0.0.0.0:14550" and a.instance == 3
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
    for bad in ([], ["fly", "--stick"], ["mode"], ["--timeout", "0", "arm"], ["takeoff", "inf"]):
        with pytest.raises(SystemExit) as exc:
            p.parse_args(bad)
        assert exc.value.code == 2


def test_unknown_mode_is_a_usage_error_without_connecting(capsys, nobody):
    with pytest.raises(SystemExit) as exc:  # argparse's exit 2
        main(["--url", url_of(nobody), "--timeout", "0.2", "mode", "GUIDED"])
    assert exc.value.code == 2
    assert "argument NAME: unknown mode 'GUIDED'" in capsys.readouterr().err


@pytest.mark.parametrize(
    "url, why",
    [
        ("nonsense", "gcs: --url nonsense: neither udpin:/udp:/tcp:HOST:PORT nor an existing serial device"),
        ("udpin:0.0.0.0:99999", "gcs: cannot open the connection: bind(): port must be 0-65535"),
    ],
)
def test_a_url_that_cannot_open_is_a_usage_error_in_one_line(url, why, capsys):
    assert main(["--url", url, "--timeout", "0.2", "status"]) == 2
    err = capsys.readouterr().err
    assert err.startswith(why) and "Traceback" not in err


# --------------------------------------------------------------------------- nothing answering


def test_arm_without_vehicle_is_no_answer_with_exit_3(capsys, nobody):
    assert main(["--url", url_of(nobody), "-i", str(nobody), "--timeout", "0.5", "arm"]) == 3
    err = capsys.readouterr().err
    assert "no answer from the vehicle: timed out after 0.5 s waiting for a heartbeat from the vehicle" in err
    assert url_of(nobody) in err and f"sysid {nobody + 1}," in err


def test_python_m_gcs_arm_without_vehicle_exits_3(nobody):
    proc = subprocess.run(
        [sys.executable, "-m", "gcs", "--url", url_of(nobody), "--timeout", "0.5", "arm"],
        cwd=ROOT,
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert proc.returncode == 3
    assert "waiting for a heartbeat" in proc.stderr
    assert proc.stdout == ""


def test_command_without_ack_times_out_naming_the_command():
    with VehicleClient(f"udpin:127.0.0.1:{free_udp_port()}", wait_heartbeat=False) as c:
        with pytest.raises(NoAnswer, match="MAV_CMD_COMPONENT_ARM_DISARM.*no COMMAND_ACK after 2 attempt"):
            c.arm(timeout_s=0.6)  # sent at 0 and 0.5 s (ACK_TRY_S), then waits for the rest of its timeout
        with pytest.raises(GcsTimeout, match="waiting for the impossible"):
            c.wait_until(lambda: False, 0.3, "the impossible")


def test_status_line_without_data():
    with VehicleClient(f"udpin:127.0.0.1:{free_udp_port()}", wait_heartbeat=False) as c:
        line = status_line(c)
        assert "?" in line and "disarmed" in line
        assert c.describe() == "nothing received from the vehicle"


# --------------------------------------------------------------------------- stack


def test_stack_ports_and_commands():
    s = Stack(instance=7, speed=2, vehicle="quad_x", extra_sitl_args=["--x"], home="1,2,3", seed=5)
    assert (s.sitl_port, s.gcs_port, s.api_port, s.sysid) == (4567, 14847, 14547, 8)  # own ground-station port
    assert s.api_url == "udpin:0.0.0.0:14547"
    assert s.sitl_command()[1:] == [
        "-m",
        "sitl",
        "--vehicle",
        "quad_x",
        "--speed",
        "2",
        "--instance",
        "7",
        "--home",
        "1,2,3",
        "--seed",
        "5",
        "--x",
    ]
    assert s.autopilot_command()[1:] == [
        "-m",
        "autopilot",
        "--vehicle",
        "quad_x",
        "--instance",
        "7",
        "--gcs-port",
        "14847",
    ]
    assert Stack(instance=7, gcs_port=14550).autopilot_command()[-2:] == ["--gcs-port", "14550"]  # flight-demo
    assert Stack().speed == "max"


@pytest.mark.e2e
def test_demo_reports_dead_flight_controller_with_log_tail(capsys, free_instance):
    """The real simulator starts; the flight controller cannot: the demo says which and why."""
    sigterm = signal.getsignal(signal.SIGTERM)  # demo.main installs its own SIGTERM handler
    try:
        rc = demo.main(
            ["--instance", str(free_instance()), "--autopilot-module", "gcs.no_such_module", "--ready-timeout", "60"]
        )
    finally:
        signal.signal(signal.SIGTERM, sigterm)
    err = capsys.readouterr().err
    assert rc == 1
    assert "flight demo FAILED" in err
    assert "autopilot exited early" in err and "No module named gcs.no_such_module" in err
