"""End-to-end: what MAVSDK 4 learns about the vehicle, and the telemetry it asks for, from the real stack.

A ``sitl`` + ``autopilot`` stack (a free instance, ``--speed max``) and MAVSDK 4
on the API port.  The Info plugin shows the version PX4 would show: flight software 1.14.0 (the PX4
release whose behaviour is followed), the git hash of the running checkout (the 5 bytes PX4 sends,
the commit's first 10 hex digits, of which MAVSDK 4.1 prints 9; the 3 bytes below them are the
vendor version, this project's own) and a non-zero hardware uid, the same after the flight
controller restarts.  The Telemetry plugin's ``set_rate_*`` calls send SET_MESSAGE_INTERVAL for
messages the link does not stream by default (ODOMETRY, HIGHRES_IMU) and for ALTITUDE and
SYSTEM_TIME; their subscriptions then deliver the vehicle's odometry, IMU, altitudes and UTC time,
checked against what the vehicle on the ground must report (gravity on the accelerometer, at home,
a clock near now).  (MAVSDK reports ODOMETRY's frames as "undefined": its enum knows only the
deprecated BODY_NED, VISION_NED and ESTIM_NED; the frames sent are checked in
tests/test_gcs_link_telemetry_more.py.)
"""

from __future__ import annotations

import asyncio
import math
import subprocess
import time
from pathlib import Path

import pytest

mavsdk = pytest.importorskip("mavsdk", reason="MAVSDK is in the test extras: pip install '.[test]'")
from mavsdk.asyncio.plugins.action import ActionAsync  # noqa: E402
from mavsdk.asyncio.plugins.info import InfoAsync  # noqa: E402
from mavsdk.asyncio.plugins.param import ParamAsync  # noqa: E402
from mavsdk.asyncio.plugins.telemetry import TelemetryAsync  # noqa: E402
from mavsdk.plugins.info import InfoError  # noqa: E402
from mavsdk_session import ground_station  # noqa: E402

from autopilot.mavlink.identity import vendor_version

from e2e_flight_helpers import truth_and_stack_fixtures, until  # tests/e2e_flight_helpers.py

pytestmark = pytest.mark.e2e
truth, stack = truth_and_stack_fixtures()
WAIT_S = 60.0  # wall seconds before giving up on one answer (a busy 2-core machine)


def head_commit() -> str | None:
    """The checkout's HEAD (40 hex digits), None when the tests do not run from a git checkout."""
    root = Path(__file__).resolve().parents[1]
    try:
        out = subprocess.run(["git", "rev-parse", "HEAD"], cwd=root, capture_output=True, text=True, timeout=30)
    except (OSError, subprocess.SubprocessError):
        return None
    return out.stdout.strip() if out.returncode == 0 else None


async def _session(stack, body):
    async with ground_station() as sdk:  # tests/mavsdk_session.py: plugins released first
        await sdk.add_any_connection(f"udpin://0.0.0.0:{stack.api_port}")
        system = await sdk.first_autopilot(timeout_s=30.0)
        assert system is not None, "MAVSDK found no autopilot"
        return await body(system)


async def _first(gen, timeout_s: float = WAIT_S):
    async def one():
        async for item in gen:
            return item

    return await asyncio.wait_for(one(), timeout_s)


async def _info(system):
    """(version, identification) once MAVSDK has AUTOPILOT_VERSION."""
    info = InfoAsync(system)
    got = {}

    async def received():
        try:
            got["version"], got["id"] = await info.get_version(), await info.get_identification()
            return True
        except InfoError:  # InformationNotReceivedYet: MAVSDK asks again every second
            return False

    await until(received, WAIT_S, "AUTOPILOT_VERSION in MAVSDK's Info plugin", period_s=0.2)
    flight = await _first(info.subscribe_flight_information())  # MAVSDK requests FLIGHT_INFORMATION itself
    assert flight.time_boot_ms > 0 and flight.flight_uid == 0  # never armed: no flight yet
    return got["version"], got["id"]


def test_info_shows_the_version_and_a_stable_hardware_uid(stack):
    version, ident = asyncio.run(_session(stack, _info))
    print(f"\nMAVSDK Info: {version}\n{ident}")
    assert (version.flight_sw_major, version.flight_sw_minor, version.flight_sw_patch) == (1, 14, 0)
    vendor = (version.flight_sw_vendor_major, version.flight_sw_vendor_minor, version.flight_sw_vendor_patch)
    commit = head_commit()
    shown = version.flight_sw_git_hash  # MAVSDK 4.1 prints 9 of the 10 hex digits (its formatting drops the last)
    assert len(shown) >= 9
    if commit is not None:  # run from the checkout: the running code's commit
        assert shown == commit[: len(shown)]
        assert vendor == vendor_version()
    else:  # an installed package: no commit to tell
        assert shown.strip("0") == ""
    uid = ident.hardware_uid
    assert uid.strip("0") != "" and ident.legacy_uid != 0
    stack.restart_autopilot()
    _, again = asyncio.run(_session(stack, _info))
    assert (again.hardware_uid, again.legacy_uid) == (uid, ident.legacy_uid)


async def _telemetry(system):
    tel = TelemetryAsync(system)

    async def healthy():
        h = await tel.health()
        return h.is_global_position_ok and h.is_home_position_ok

    await until(healthy, 90, "global position and home")
    await tel.set_rate_odometry(20.0)  # SET_MESSAGE_INTERVAL ODOMETRY 50 ms: off by default
    await tel.set_rate_imu(50.0)  # HIGHRES_IMU 20 ms
    await tel.set_rate_altitude(5.0)
    await tel.set_rate_unix_epoch_time(2.0)
    out = {"odometry": await _first(tel.subscribe_odometry()), "imu": await _first(tel.subscribe_imu())}
    out["altitude"] = await _first(tel.subscribe_altitude())
    out["utc_us"] = await _first(tel.subscribe_unix_epoch_time())
    out["home"] = await tel.home()
    return out


def test_telemetry_plugin_gets_odometry_imu_altitude_and_time(stack):
    wall_us = time.time() * 1e6
    got = asyncio.run(_session(stack, _telemetry))
    od, imu, alt = got["odometry"], got["imu"], got["altitude"]
    print(f"\nMAVSDK Telemetry:\n{od}\n{imu}\n{alt}\nUTC {got['utc_us']} (wall {wall_us:.0f})")
    # on the ground at home, level: position within a metre of the origin, still, gravity on the z axis
    assert math.hypot(od.position_body.x_m, od.position_body.y_m) < 1.0
    assert abs(od.velocity_body.x_m_s) < 0.3 and abs(od.velocity_body.y_m_s) < 0.3
    assert abs(od.q.w) > 0.7 or abs(od.q.z) > 0.7  # a rotation about the vertical only
    assert imu.acceleration_frd.down_m_s2 == pytest.approx(-9.81, abs=0.5)  # specific force: up
    assert math.hypot(imu.acceleration_frd.forward_m_s2, imu.acceleration_frd.right_m_s2) < 0.5
    assert imu.magnetic_field_frd.down_gauss > 0.1  # the northern hemisphere's field points down
    assert alt.altitude_relative_m == pytest.approx(0.0, abs=0.5)
    assert alt.altitude_amsl_m == pytest.approx(got["home"].absolute_altitude_m, abs=0.5)
    assert math.isfinite(alt.altitude_monotonic_m) and math.isnan(alt.altitude_terrain_m)
    assert abs(got["utc_us"] - wall_us) < 600e6  # UTC from the wall clock at start: near now


async def _flight_information(system):
    """MAVSDK's flight information (FLIGHT_INFORMATION, which its Info plugin asks for at 1 Hz) disarmed, then armed."""
    info, tel, action = InfoAsync(system), TelemetryAsync(system), ActionAsync(system)
    param = ParamAsync(system)

    async def armable():
        h = await tel.health()
        return h.is_global_position_ok and h.is_home_position_ok and h.is_armable and not await tel.armed()

    await until(armable, 90, "health: position, home, armable, disarmed")
    before = await _first(info.subscribe_flight_information())
    # At --speed max PX4's disarm-if-no-take-off (COM_DISARM_PRFLT, 10 s) passes in a third of a wall second,
    # which can fall between two of MAVSDK's 1 Hz requests: the vehicle stays armed while the test reads.
    prflt = await param.get_param_float("COM_DISARM_PRFLT")
    await param.set_param_float("COM_DISARM_PRFLT", -1.0)
    await action.arm()
    try:
        flights = info.subscribe_flight_information()
        async for armed in flights:
            if armed.flight_uid != before.flight_uid and armed.duration_since_arming_ms > 0:
                break
    finally:
        await action.disarm()
        await param.set_param_float("COM_DISARM_PRFLT", prflt)
    return before, armed


def test_flight_information_counts_flights_and_times_since_arming(stack):
    before, armed = asyncio.run(
        _session(stack, lambda system: asyncio.wait_for(_flight_information(system), 2 * WAIT_S))
    )
    print(f"\nMAVSDK FlightInfo before arming: {before}\narmed: {armed}")
    assert before.flight_uid + 1 == armed.flight_uid  # the flight number counts the armings
    # times since boot (MAVLink's FLIGHT_INFORMATION), so MAVSDK's durations make sense: armed moments ago
    assert 0 < armed.duration_since_arming_ms < 60_000 and armed.duration_since_takeoff_ms == 0
    assert before.duration_since_arming_ms == 0 or before.flight_uid > 0
