"""The ULog writer (mavsim_core/ulog_writer.py), read back with pyulog as Flight Review reads a PX4 log."""

from __future__ import annotations

import math

import numpy as np
import pytest

pyulog = pytest.importorskip("pyulog", reason="pyulog is a dependency: pip install .")

from mavsim_core.ulog_writer import (  # noqa: E402
    DEFAULT_CONFIGURATION,
    DEFAULT_SYSTEM,
    MAGIC,
    ULogFormat,
    ULogWriter,
)

ATTITUDE = ULogFormat("vehicle_attitude", ("uint64_t timestamp", "float[4] q", "uint8_t quat_reset_counter"))
MIXED = ULogFormat(
    "mixed",
    (
        "uint64_t timestamp", "bool flag", "int8_t i8", "uint16_t u16", "int32_t i32", "int64_t i64",
        "double lat", "float[3] v", "char[8] name",
    ),
)  # fmt: skip


def _write_sample_log(path, n: int = 250) -> None:
    with ULogWriter(path, start_us=1_000_000, buffer_bytes=1024) as w:  # a small buffer: many file writes
        w.add_format(ATTITUDE)
        w.add_format(MIXED)
        w.add_info("sys_name", "PX4")
        w.add_info("ver_sw_release", 0x010E00FF, "uint32_t")
        w.add_info("time_ref_utc", -3600)
        w.add_parameter("MPC_XY_P", 0.95, is_int=False)
        w.add_parameter("SYS_AUTOSTART", 4001, is_int=True)
        w.add_default_parameter("MPC_XY_P", 0.5, is_int=False, default_types=DEFAULT_SYSTEM | DEFAULT_CONFIGURATION)
        att = w.subscribe("vehicle_attitude")
        mixed = w.subscribe("mixed", multi_id=1)
        for k in range(n):
            t = 1_000_000 + 4000 * k
            a = 0.01 * k
            w.write(att, t, math.cos(a / 2), 0.0, 0.0, math.sin(a / 2), k % 256)
            if k % 10 == 0:
                w.write(mixed, t, k % 20 == 0, -(k % 100), k, -k, 2**40 + k, 47.0 + k * 1e-7, 1.0, -2.0, k, b"abc")
            if k == 100:
                w.log(4, t, "Battery low")
                w.add_parameter("MPC_XY_P", 1.25, is_int=False)
            if k % 250 == 0:
                w.sync()


def test_round_trip_through_pyulog(tmp_path):
    path = tmp_path / "flight.ulg"
    _write_sample_log(path)
    log = pyulog.ULog(str(path))
    assert not log.file_corruption
    assert log.start_timestamp == 1_000_000
    assert log.last_timestamp == 1_000_000 + 4000 * 249
    assert log.msg_info_dict == {"sys_name": "PX4", "ver_sw_release": 0x010E00FF, "time_ref_utc": -3600}
    assert log.get_version_info_str() == "v1.14.0"
    assert log.initial_parameters["SYS_AUTOSTART"] == 4001
    assert log.initial_parameters["MPC_XY_P"] == pytest.approx(0.95)
    assert [(t, name, round(v, 6)) for t, name, v in log.changed_parameters] == [(1_400_000, "MPC_XY_P", 1.25)]
    assert log.get_default_parameters(0) == {"MPC_XY_P": pytest.approx(0.5)}
    assert log.get_default_parameters(1) == {"MPC_XY_P": pytest.approx(0.5)}
    assert [(m.log_level_str(), m.timestamp, m.message) for m in log.logged_messages] == [
        ("WARNING", 1_400_000, "Battery low")
    ]

    att = log.get_dataset("vehicle_attitude")
    assert len(att.data["timestamp"]) == 250
    assert np.all(np.diff(att.data["timestamp"]) == 4000)
    np.testing.assert_allclose(att.data["q[3]"][100], math.sin(0.5), rtol=1e-6)
    assert att.data["quat_reset_counter"][255 % 250] == 5
    mixed = log.get_dataset("mixed", multi_instance=1)
    assert len(mixed.data["timestamp"]) == 25
    assert list(mixed.data["flag"][:3]) == [1, 0, 1]
    assert mixed.data["i8"][1] == -10 and mixed.data["u16"][2] == 20 and mixed.data["i32"][2] == -20
    assert mixed.data["i64"][3] == 2**40 + 30
    assert mixed.data["lat"][1] == pytest.approx(47.0 + 10e-7, abs=1e-12)  # a double keeps 1e-7 deg
    assert mixed.data["v[2]"][4] == 40.0
    assert bytes(mixed.data[f"name[{i}]"][0] for i in range(3)) == b"abc"


def test_file_layout_follows_the_spec(tmp_path):
    """Header magic and version, the flag-bits message first, every format as PX4 writes it."""
    path = tmp_path / "flight.ulg"
    _write_sample_log(path, n=3)
    raw = path.read_bytes()
    assert raw[:7] == MAGIC and raw[7] == 1 and int.from_bytes(raw[8:16], "little") == 1_000_000
    assert raw[16:19] == bytes((40, 0, ord("B")))  # 8 compat + 8 incompat flag bytes + 3 appended offsets
    assert raw[19] == 1 and raw[27:35] == bytes(8)  # DEFAULT_PARAMETERS compat bit; no incompatible bits
    assert b"vehicle_attitude:uint64_t timestamp;float[4] q;uint8_t quat_reset_counter;" in raw
    assert raw.count(bytes((0x2F, 0x73, 0x13, 0x20, 0x25, 0x0C, 0xBB, 0x12))) == 1


def test_flush_makes_a_log_being_written_readable(tmp_path):
    path = tmp_path / "live.ulg"
    w = ULogWriter(path, 0)
    w.add_format(ATTITUDE)
    sub = w.subscribe("vehicle_attitude")
    for k in range(10):
        w.write(sub, k * 1000, 1.0, 0.0, 0.0, 0.0, 0)
    w.flush()
    assert w.bytes_written == path.stat().st_size
    assert len(pyulog.ULog(str(path)).get_dataset("vehicle_attitude").data["timestamp"]) == 10
    w.close()
    assert w.closed


@pytest.mark.parametrize(
    "fields, why",
    [
        (("float x",), "the first field must be"),
        (("uint64_t timestamp", "float3 x"), "bad field"),
        (("uint64_t timestamp", "vector3 v"), "bad field"),  # nested types are not supported
        (("uint64_t timestamp", "float[0] x"), "bad array size"),
        (("uint64_t timestamp", "float x", "int32_t x"), "bad field"),
    ],
)
def test_bad_formats_are_refused(fields, why):
    with pytest.raises(ValueError, match=why):
        ULogFormat("topic", fields)


def test_sections_and_values_are_checked(tmp_path):
    w = ULogWriter(tmp_path / "x.ulg", 0)
    w.add_format(ATTITUDE)
    with pytest.raises(ValueError, match="defined twice"):
        w.add_format(ATTITUDE)
    with pytest.raises(ValueError, match="no format"):
        w.subscribe("vehicle_status")
    w.subscribe("vehicle_attitude")
    with pytest.raises(ValueError, match="after the data section"):
        w.add_format(MIXED)
    with pytest.raises(ValueError, match="log level"):
        w.log(8, 0, "?")
    with pytest.raises(ValueError, match="bad ULog key"):
        w.add_info("bad key", 1)
    w.close()
