"""Flight logs fetched as a PX4 user fetches them: MAVSDK's LogFiles plugin, pyulog, pymavlink.

One short flight on the real stack (arm, take off to 5 m, land, disarmed), then MAVSDK 4 lists the
vehicle's logs and downloads the last one; it must be byte for byte the ``.ulg`` the flight controller
wrote, pyulog must read it as a PX4 log (the topics Flight Review and PlotJuggler plot, with data that
agrees with the flight: the altitude reached, arming and the PX4 modes flown, motors, sensors,
battery, GPS), and pyulog's own ``ulog_info`` and ``ulog_params`` must run on it.  Then pymavlink
sends what a careless client would (an unknown log id, an offset past the end: an empty LOG_DATA)
and LOG_ERASE, after which the vehicle lists no log and the files are gone.
"""

from __future__ import annotations

import asyncio
import os
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

mavsdk = pytest.importorskip("mavsdk", reason="MAVSDK is in the test extras: pip install '.[test]'")
pyulog = pytest.importorskip("pyulog", reason="pyulog is a dependency: pip install .")
os.environ.setdefault("MAVLINK20", "1")
from mavsdk.asyncio.plugins.action import ActionAsync  # noqa: E402
from mavsdk.asyncio.plugins.log_files import LogFilesAsync  # noqa: E402
from mavsdk.asyncio.plugins.telemetry import TelemetryAsync  # noqa: E402
from mavsdk.plugins.log_files import LogFilesResult  # noqa: E402
from mavsdk_session import ground_station  # noqa: E402
from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from gcs.launcher import Stack  # noqa: E402

from e2e_flight_helpers import CLIENT_SPEED, until, wait_armable  # tests/e2e_flight_helpers.py

pytestmark = pytest.mark.e2e
WAIT_S = 180.0  # wall-clock safety net of each wait
ALT_M = 5.0
TOPICS = {  # what Flight Review's and PlotJuggler's usual plots read
    "vehicle_attitude", "vehicle_attitude_setpoint", "vehicle_rates_setpoint", "vehicle_angular_velocity",
    "vehicle_local_position", "vehicle_local_position_setpoint", "trajectory_setpoint", "vehicle_global_position",
    "sensor_combined", "vehicle_gps_position", "vehicle_air_data", "battery_status", "actuator_outputs",
    "actuator_motors", "vehicle_status", "vehicle_land_detected",
}  # fmt: skip


@pytest.fixture(scope="module")
def stack(inst):
    with Stack(instance=inst, speed=CLIENT_SPEED) as s:
        yield s


def _logs_on_disk(stack) -> list[Path]:
    return sorted(stack.log_dir.glob("*.ulg"))


async def _fly(system) -> None:
    tel, action = TelemetryAsync(system), ActionAsync(system)

    await wait_armable(tel, WAIT_S)
    await action.set_takeoff_altitude(ALT_M)
    await action.arm()
    await action.takeoff()

    async def up():
        return (await tel.position()).relative_altitude_m > ALT_M - 0.4

    await until(up, WAIT_S, f"take-off to {ALT_M} m")
    await action.land()

    async def disarmed():
        return not await tel.armed()

    await until(disarmed, WAIT_S, "landed and disarmed")


async def _fly_and_download(stack, into: Path) -> dict:
    async with ground_station() as sdk:  # tests/mavsdk_session.py: plugins released first
        await sdk.add_any_connection(f"udpin://0.0.0.0:{stack.api_port}")
        system = await sdk.first_autopilot(timeout_s=30.0)
        assert system is not None, "MAVSDK found no autopilot"
        await _fly(system)

        async def closed():  # the recorder closes the flight's files a second after disarming
            return "flight log closed" in stack.log_path("autopilot").read_text()

        await until(closed, WAIT_S, "the flight's logs closed")
        log_files = LogFilesAsync(system)
        entries = await log_files.get_entries()
        path = into / "last_flight.ulg"
        progress, wall0 = [], time.monotonic()
        async for result, data in log_files.download_log_file(entries[-1], str(path)):
            progress.append((result, data.progress))
        wall_s = time.monotonic() - wall0
        print(f"MAVSDK downloaded {entries[-1].size_bytes} bytes in {wall_s:.2f} s (wall) at speed max")
        return {"entries": entries, "path": path, "progress": progress, "on_disk": _logs_on_disk(stack)}


@pytest.fixture(scope="module")
def flight(stack, tmp_path_factory) -> dict:
    return asyncio.run(_fly_and_download(stack, tmp_path_factory.mktemp("download")))


def test_mavsdk_lists_the_logs_and_downloads_the_last_flight(flight):
    entries, on_disk = flight["entries"], flight["on_disk"]
    assert len(on_disk) == 1  # one flight, one ULog
    assert [e.id for e in entries] == list(range(len(on_disk)))  # PX4's numbering: 0..N-1, oldest first
    assert entries[-1].size_bytes == on_disk[-1].stat().st_size > 100_000
    assert entries[-1].date.endswith("Z") and entries[-1].date[:4].isdigit()  # the UTC time of arming
    assert flight["progress"][-1] == (LogFilesResult.SUCCESS, pytest.approx(1.0))
    assert flight["path"].read_bytes() == on_disk[-1].read_bytes()


def test_the_downloaded_log_is_a_px4_ulog_of_the_flight(flight):
    log = pyulog.ULog(str(flight["path"]))
    assert not log.file_corruption
    assert log.msg_info_dict["sys_name"] == "PX4"
    assert TOPICS <= {d.name for d in log.data_list}
    assert log.initial_parameters["SDLOG_MODE"] == 0 and "MPC_XY_P" in log.initial_parameters

    def topic(name):
        return log.get_dataset(name).data

    lp = topic("vehicle_local_position")
    climb_m = lp["z"][0] - lp["z"].min()  # from where it armed (NED: up is -z)
    assert climb_m == pytest.approx(ALT_M, abs=0.6)
    sp = topic("vehicle_local_position_setpoint")
    assert np.nanmin(sp["z"]) == pytest.approx(lp["z"][0] - ALT_M, abs=0.6)  # the take-off point, 5 m up
    status = topic("vehicle_status")
    assert status["arming_state"][0] == 2 and status["arming_state"][-1] == 1  # armed, then disarmed
    assert {17, 18} <= set(status["nav_state"].tolist())  # AUTO_TAKEOFF, AUTO_LAND
    assert topic("vehicle_land_detected")["landed"][-1] == 1
    motors = topic("actuator_outputs")
    assert motors["noutputs"][0] == 4 and 0.3 < np.median(motors["output[0]"]) < 0.9  # hovering
    accel_z = topic("sensor_combined")["accelerometer_m_s2[2]"]
    assert np.median(accel_z) == pytest.approx(-9.8, abs=0.5)  # specific force, FRD
    q = np.stack([topic("vehicle_attitude")[f"q[{i}]"] for i in range(4)])
    assert np.allclose(np.linalg.norm(q, axis=0), 1.0, atol=1e-4)
    assert np.median(topic("battery_status")["voltage_v"]) > 10.0
    gps, gpos = topic("vehicle_gps_position"), topic("vehicle_global_position")
    assert abs(np.median(gps["latitude_deg"]) - np.median(gpos["lat"])) < 1e-4  # about 10 m
    baro_climb = topic("vehicle_air_data")["baro_alt_meter"]
    assert baro_climb.max() - baro_climb[0] == pytest.approx(ALT_M, abs=1.0)
    texts = {m.message for m in log.logged_messages}  # the vehicle's STATUSTEXTs, as PX4 logs its mavlink_log
    assert {"Armed", "Takeoff detected", "Landing detected"} <= texts, texts
    times = topic("vehicle_attitude")["timestamp"]
    assert np.all(np.diff(times) > 0) and times[0] >= log.start_timestamp


def test_pyulogs_console_scripts_read_it(flight):
    scripts = Path(sys.executable).parent
    info = subprocess.run([scripts / "ulog_info", flight["path"]], capture_output=True, text=True, timeout=120)
    assert info.returncode == 0, info.stderr
    assert "sys_name: PX4" in info.stdout and "vehicle_local_position" in info.stdout
    params = subprocess.run([scripts / "ulog_params", flight["path"]], capture_output=True, text=True, timeout=120)
    assert params.returncode == 0, params.stderr
    assert "MPC_XY_P," in params.stdout and "SDLOG_MODE,0" in params.stdout


def _recv(conn, mtype: str, timeout_s: float = 30.0):
    msg = conn.recv_match(type=mtype, blocking=True, timeout=timeout_s)
    assert msg is not None, f"no {mtype}"
    return msg


def _list(conn, sysid: int) -> list:
    conn.mav.log_request_list_send(sysid, 1, 0, 0xFFFF)
    first = _recv(conn, "LOG_ENTRY")
    entries = [first]
    while len(entries) < first.num_logs:
        entries.append(_recv(conn, "LOG_ENTRY"))
    return entries


def test_bad_requests_and_erase_with_pymavlink(stack, flight):
    conn = mavutil.mavlink_connection(stack.gcs_url, source_system=255, source_component=190, dialect="common")
    try:
        conn.wait_heartbeat(timeout=30)
        conn.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)  # so it answers here
        entries = _list(conn, stack.sysid)
        n, size = entries[0].num_logs, entries[-1].size
        assert [e.id for e in entries] == list(range(n))
        for log_id, ofs in ((n, 0), (n - 1, size), (n - 1, size + 900)):  # unknown id; offsets at and past the end
            conn.mav.log_request_data_send(stack.sysid, 1, log_id, ofs, 90)
            reply = _recv(conn, "LOG_DATA")
            assert (reply.id, reply.ofs, reply.count) == (log_id, ofs, 0)
        conn.mav.log_request_data_send(stack.sysid, 1, n - 1, 900, 180)  # a range: two LOG_DATA
        got = [_recv(conn, "LOG_DATA") for _ in range(2)]
        assert [(m.ofs, m.count) for m in got] == [(900, 90), (990, 90)]
        assert b"".join(bytes(m.data) for m in got) == flight["on_disk"][-1].read_bytes()[900:1080]

        conn.mav.log_erase_send(stack.sysid, 1)
        empty = _list(conn, stack.sysid)
        assert [(e.id, e.num_logs) for e in empty] == [(0, 0)]  # the spec's "no logs"
        assert not list(stack.log_dir.glob("*.ulg")) and not list(stack.log_dir.glob("*.tlog"))
        conn.mav.log_request_end_send(stack.sysid, 1)
    finally:
        conn.close()
