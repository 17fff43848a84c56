"""MAVSDK (4.x native binding) flies missions and a geofence on the real stack.

What a MAVSDK user does with the Mission, MissionRaw and Geofence plugins: upload a
10-waypoint square with a speed change, download it back unchanged, start it and follow
``mission_progress`` to the end; upload a raw plan with a DO_JUMP; upload an inclusion
polygon (with the circle of radius 0 MAVSDK's users add for "no circle") and fly toward it: the
vehicle stops inside.  Where the vehicle went is checked
against the simulator's ground truth, not against what the flight controller says.
"""

from __future__ import annotations

import asyncio
import contextlib
import math

import pytest

mavsdk = pytest.importorskip("mavsdk", reason="MAVSDK is in the test extras: pip install '.[test]'")
from mavsdk.asyncio.plugins.action import ActionAsync  # noqa: E402
from mavsdk.asyncio.plugins.geofence import GeofenceAsync  # noqa: E402
from mavsdk.asyncio.plugins.mission import MissionAsync  # noqa: E402
from mavsdk.asyncio.plugins.mission_raw import MissionRawAsync  # noqa: E402
from mavsdk.asyncio.plugins.telemetry import TelemetryAsync  # noqa: E402
from mavsdk.plugins import mission_raw as raw  # noqa: E402
from mavsdk.plugins.mission import MissionItem, MissionPlan  # noqa: E402
from mavsdk.plugins.telemetry import FlightMode  # noqa: E402
from mavsdk_session import ground_station  # noqa: E402

from e2e_flight_helpers import closest_approach, latlon, truth_and_stack_fixtures, until  # tests/e2e_flight_helpers.py

pytestmark = pytest.mark.e2e
truth, stack = truth_and_stack_fixtures()
NAN = float("nan")
ACCEPT_M = 2.0


def waypoint(north: float, east: float, alt: float, speed: float = NAN) -> MissionItem:
    lat, lon = latlon(north, east)
    return MissionItem(
        lat, lon, alt, speed, True, NAN, NAN, MissionItem.CameraAction.NONE, NAN, 1.0, ACCEPT_M, NAN, NAN,
        MissionItem.VehicleAction.NONE,
    )  # fmt: skip


async def _session(stack, body):
    async with ground_station() as sdk:  # tests/mavsdk_session.py: plugins released first
        await sdk.add_any_connection(f"udpin://0.0.0.0:{stack.api_port}")
        system = await sdk.first_autopilot(timeout_s=30.0)
        assert system is not None, "MAVSDK found no autopilot"
        tel = TelemetryAsync(system)

        async def ready():
            h = await tel.health()
            return h.is_global_position_ok and h.is_home_position_ok and h.is_armable and not await tel.armed()

        await until(ready, 90, "health: position, home, armable, disarmed")
        return await body(system, tel)


async def _land_and_disarm(system, tel) -> None:
    await ActionAsync(system).return_to_launch()

    async def disarmed():
        return not await tel.armed()

    await until(disarmed, 120, "disarmed after the return")


SQUARE = [(0, 0), (15, 0), (30, 0), (30, 15), (30, 30), (15, 30), (0, 30), (0, 15), (0, 0), (5, 5)]


def test_mavsdk_square_mission_upload_download_fly(stack, truth):
    items = [waypoint(n, e, 6.0, 5.0 if k == 4 else NAN) for k, (n, e) in enumerate(SQUARE)]

    async def body(system, tel):
        mission = MissionAsync(system)
        await mission.upload_mission(MissionPlan(items))
        down = (await mission.download_mission()).mission_items
        start_ms = truth.latest().time_ms
        await ActionAsync(system).arm()
        await mission.start_mission()
        progress = []

        async def finished():
            p = await mission.mission_progress()
            if not progress or progress[-1] != p.current:
                progress.append(p.current)
            return p.current == p.total and await mission.is_mission_finished()

        await until(finished, 180, "the mission's end")
        await _land_and_disarm(system, tel)
        return down, progress, start_ms

    down, progress, start_ms = asyncio.run(_session(stack, body))
    stack.check_alive()
    assert len(down) == len(items)
    for up, back in zip(items, down):
        assert back.latitude_deg == pytest.approx(up.latitude_deg, abs=2e-7)
        assert back.longitude_deg == pytest.approx(up.longitude_deg, abs=2e-7)
        assert back.relative_altitude_m == pytest.approx(up.relative_altitude_m)
        assert back.acceptance_radius_m == pytest.approx(ACCEPT_M)
        assert back.is_fly_through and (math.isnan(up.speed_m_s) or back.speed_m_s == pytest.approx(up.speed_m_s))
    assert progress == sorted(progress) and progress[-1] == len(items)
    for north, east in SQUARE:  # within the acceptance radius of every waypoint, by the ground truth
        assert closest_approach(truth, start_ms, north, east) < ACCEPT_M, (north, east)


def _raw_item(seq, command, p1=0.0, p2=0.0, north=None, east=None, alt=0.0, frame=6):
    x = y = 0
    if north is not None:
        lat, lon = latlon(north, east)
        x, y = round(lat * 1e7), round(lon * 1e7)
    return raw.MissionItem(seq, frame, command, 1 if seq == 0 else 0, 1, p1, p2, 0.0, NAN, x, y, alt, 0)


def test_mavsdk_raw_mission_with_do_jump_repeats_and_lands(stack, truth):
    items = [
        _raw_item(0, 22, north=0, east=0, alt=5.0),  # NAV_TAKEOFF
        _raw_item(1, 16, north=12, east=0, alt=5.0),
        _raw_item(2, 16, north=12, east=12, alt=5.0),
        _raw_item(3, 177, p1=1, p2=1, frame=2),  # DO_JUMP to 1, once more
        _raw_item(4, 16, north=0, east=12, alt=5.0),
        _raw_item(5, 21, north=0, east=12, alt=0.0),  # NAV_LAND there
    ]

    async def body(system, tel):
        mission = MissionRawAsync(system)
        await mission.upload_mission(items)
        down = await mission.download_mission()
        start_ms = truth.latest().time_ms
        seen = []

        async def follow():  # every progress update (polling missed an item current for 0.15 wall s at 30x)
            async for p in mission.subscribe_mission_progress():
                if not seen or seen[-1] != p.current:
                    seen.append(p.current)

        following = asyncio.create_task(follow())
        await ActionAsync(system).arm()
        await mission.start_mission()

        async def flying():
            return await tel.in_air()

        await until(flying, 30, "take-off")

        async def landed():
            return not await tel.armed()

        await until(landed, 180, "landing and disarm at the mission's end")
        following.cancel()
        with contextlib.suppress(asyncio.CancelledError):
            await following
        return down, seen, start_ms

    down, seen, start_ms = asyncio.run(_session(stack, body))
    stack.check_alive()
    assert [(d.command, d.x, d.y, d.param1, d.param2) for d in down] == [
        (i.command, i.x, i.y, i.param1, i.param2) for i in items
    ]
    # item 1 and 2 flown twice: 1, 2, (jump) 1, 2, 4, 5
    flown = [s for s in seen if s in (1, 2, 4, 5)]
    assert flown[:6] == [1, 2, 1, 2, 4, 5], seen
    end = truth.now()
    assert math.hypot(end.pos_ned_m[0] - 0, end.pos_ned_m[1] - 12) < 1.5
    assert abs(end.pos_ned_m[2]) < 0.5


def fence_items(corners: list[tuple[float, float]]) -> list:
    """The items MAVSDK's Geofence plugin makes of ``GeofenceData([inclusion polygon], [circle of radius 0 at (0,
    0)])`` (its geofence_impl.cpp: polygon vertices, then circles; the first item current, autocontinue 0)."""
    n, fence_type = len(corners), 1  # MAV_MISSION_TYPE_FENCE
    items = [raw.MissionItem(k, 5, 5001, int(k == 0), 0, float(n), 0.0, 0.0, 0.0, round(lat * 1e7),
                             round(lon * 1e7), 0.0, fence_type) for k, (lat, lon) in enumerate(corners)]  # fmt: skip
    return [*items, raw.MissionItem(n, 5, 5003, 0, 0, 0.0, 0.0, 0.0, 0.0, 0, 0, 0.0, fence_type)]


def test_mavsdk_geofence_stops_the_vehicle_at_an_inclusion_polygon(stack, truth):
    """An inclusion polygon with the circle of radius 0 at (0, 0) that MAVSDK's users send for "no circle" (issue
    36): stored, as PX4 stores it, the circle said to be ignored; the polygon then stops a go-to 60 m north.
    MAVSDK's Geofence plugin (4.0.5 and 4.1.0) refuses such a GeofenceData itself (INVALID_ARGUMENT, nothing
    sent), so the items it would send go through MissionRaw's ``upload_geofence``."""
    half = 15.0
    corners = [latlon(n, e) for n, e in ((-half, -half), (half, -half), (half, half), (-half, half))]
    texts: list[str] = []

    async def body(system, tel):
        async def collect():
            async for st in tel.subscribe_status_text():
                texts.append(st.text)

        listener = asyncio.ensure_future(collect())
        await asyncio.sleep(0.5)  # subscribed before the upload
        await MissionRawAsync(system).upload_geofence(fence_items(corners))
        texts.append(f"downloaded {len(await MissionRawAsync(system).download_geofence())}")
        action = ActionAsync(system)
        await action.set_takeoff_altitude(5.0)
        await action.arm()
        await action.takeoff()

        async def up():
            return (await tel.position()).relative_altitude_m > 4.5

        await until(up, 60, "take-off to 5 m")
        start_ms = truth.latest().time_ms
        target = latlon(60.0, 0.0)
        home_amsl = (await tel.home()).absolute_altitude_m
        await action.goto_location(target[0], target[1], home_amsl + 5.0, NAN)

        async def holding():
            return await tel.flight_mode() == FlightMode.HOLD

        await until(holding, 60, "HOLD at the fence (GF_ACTION 2)")
        await asyncio.sleep(3.0)  # let it brake and settle
        await GeofenceAsync(system).clear_geofence()
        await _land_and_disarm(system, tel)
        listener.cancel()
        return start_ms

    start_ms = asyncio.run(_session(stack, body))
    stack.check_alive()
    assert "Fence item 4: circle of radius 0 ignored" in texts and "downloaded 5" in texts, texts  # stored whole
    farthest = max(s.pos_ned_m[0] for s in truth.since(start_ms))
    assert 5.0 < farthest < half, f"went {farthest:.1f} m north: the fence is at {half} m"
