"""The gRPC MAVSDK-Python flies the stack as its upstream examples do.

Many users still run the gRPC MAVSDK-Python: ``mavsdk<4``, published on from MAVSDK 4 on as
``mavsdk-grpc`` and imported as ``mavsdk_grpc`` ("``import mavsdk_grpc as mavsdk``: the code is
identical", its README).  Its ``System`` starts the bundled ``mavsdk_server`` (C++, gRPC) and talks
to it; a different path from MAVSDK 4's native binding (tests/test_e2e_commands.py and others),
so a feature works only when both drive it.  The flows are those of MAVSDK-Python's examples,
written as a user would: ``takeoff_and_land.py`` (connect, wait for a global position and home,
arm, take off, land), ``mission.py`` (upload, return after the mission, start, follow the progress),
``geofence.py`` (an inclusion square around home; then a go-to past it, stopped inside),
``offboard_position_ned.py`` (a setpoint before starting, then NED position setpoints), ``goto.py``
(a point and a heading at an altitude AMSL from home's), ``all_params.py`` with the Info plugin's
version, ``log_files.py`` (list, download a ULog), the Param plugin and ``failure_injection.py`` (GPS
off in flight: it lands).  Asserted by the simulator's
truth where the vehicle went (the height reached, each waypoint passed within a metre, the point and
heading of a go-to, back home, on the ground and disarmed), else by what the client got (the
parameters, the version, a log file that is a ULog).

Each ``mavsdk_server`` serves gRPC on a port of its own, ``GRPC_BASE + instance``: the examples'
default 50051 would collide between test files running in parallel.  Wall-clock values are only
"give up waiting" timeouts.
"""

from __future__ import annotations

import asyncio
import math

import mavsdk_grpc as mavsdk  # the upstream examples' ``mavsdk``, as its README says
import pytest
from mavsdk_grpc.failure import FailureType, FailureUnit
from mavsdk_grpc.geofence import FenceType, GeofenceData, Point, Polygon
from mavsdk_grpc.mission import MissionItem, MissionPlan
from mavsdk_grpc.offboard import PositionNedYaw

# tests/e2e_flight_helpers.py
from e2e_flight_helpers import latlon, sim_sleep, truth_and_stack_fixtures, truth_yaw, until

# (the package's own start-up of mavsdk_server uses importlib.resources.path, deprecated: not ours to mend)
pytestmark = [pytest.mark.e2e, pytest.mark.filterwarnings("ignore:path is deprecated:DeprecationWarning")]
truth, stack = truth_and_stack_fixtures(flight_logs=True)  # a test reads them

GRPC_BASE = 50100  # mavsdk_server's gRPC port: this plus the stack's instance number
WAIT_S = 180.0  # wall seconds for one whole flight (a loaded 2-core machine)
ALT_M = 4.0
MISSION_NE = [(12.0, 0.0), (12.0, 10.0), (0.0, 10.0)]  # waypoints, m north/east of home


async def connected(stack, inst: int) -> mavsdk.System:
    """``System()`` connected and ready to fly, as the examples wait for it."""
    drone = mavsdk.System(port=GRPC_BASE + inst)
    await drone.connect(system_address=f"udpin://0.0.0.0:{stack.api_port}")
    async for state in drone.core.connection_state():
        if state.is_connected:
            break
    async for health in drone.telemetry.health():
        if health.is_global_position_ok and health.is_home_position_ok:
            break
    return drone


async def landed_and_disarmed(drone: mavsdk.System) -> None:
    async for in_air in drone.telemetry.in_air():
        if not in_air:
            break
    async for armed in drone.telemetry.armed():
        if not armed:
            break


async def take_off(drone: mavsdk.System, truth, above_m: float, settle_s: float = 0.0) -> None:
    """Arm, take off (to the take-off altitude set before), on once higher than ``above_m`` above home and
    ``settle_s`` simulated seconds later."""
    await drone.action.arm()
    await drone.action.takeoff()
    async for position in drone.telemetry.position():
        if position.relative_altitude_m > above_m:
            break
    if settle_s > 0:
        await sim_sleep(truth, settle_s)


def run(flight) -> None:
    asyncio.run(asyncio.wait_for(flight, WAIT_S))


def test_takeoff_and_land_as_the_upstream_example(stack, truth, inst):
    heights = []

    async def flight():
        drone = await connected(stack, inst)
        ground = truth.latest().pos_ned_m[2]  # NED: heights are up from here
        await drone.action.set_takeoff_altitude(ALT_M)
        await take_off(drone, truth, ALT_M - 0.3, 3.0)
        heights.append(ground - truth.now().pos_ned_m[2])
        await drone.action.land()
        await landed_and_disarmed(drone)
        heights.append(ground - truth.now().pos_ned_m[2])

    run(flight())
    stack.check_alive()
    print(f"hovering {heights[0]:.2f} m up by the truth, then {heights[1]:.2f} m, disarmed")
    assert heights[0] == pytest.approx(ALT_M, abs=0.3)
    assert abs(heights[1]) < 0.1


def test_geofence_as_the_upstream_example_holds_the_vehicle_inside(stack, truth, inst):
    """geofence.py's fence (an inclusion square of +-0.0001 deg around home), then a go-to 60 m North: the
    vehicle stops inside it (GF_ACTION 2, Hold, as PX4).  Before the module's flights that move the vehicle:
    outside an inclusion fence arming is refused, as PX4 refuses it.  The fence is cleared at the end."""
    seen = {}

    async def flight():
        drone = await connected(stack, inst)
        async for home in drone.telemetry.home():
            lat, lon, amsl = home.latitude_deg, home.longitude_deg, home.absolute_altitude_m
            break
        corners = [
            (lat - 1e-4, lon - 1e-4),
            (lat + 1e-4, lon - 1e-4),
            (lat + 1e-4, lon + 1e-4),
            (lat - 1e-4, lon + 1e-4),
        ]
        polygon = Polygon([Point(*c) for c in corners], FenceType.INCLUSION)
        await drone.geofence.upload_geofence(GeofenceData(polygons=[polygon], circles=[]))
        start = truth.latest().pos_ned_m
        await take_off(drone, truth, 2.0, 2.0)
        await drone.action.goto_location(*latlon(start[0] + 60.0, start[1]), amsl + ALT_M, 0.0)
        async for mode in drone.telemetry.flight_mode():
            if mode == mavsdk.telemetry.FlightMode.HOLD:
                break
        await sim_sleep(truth, 8.0)
        seen["north"] = truth.latest().pos_ned_m[0] - start[0]
        await drone.geofence.clear_geofence()
        await drone.action.land()
        await landed_and_disarmed(drone)

    run(flight())
    stack.check_alive()
    fence_m = 1e-4 * math.pi / 180 * 6_371_000
    print(f"geofence: stopped {seen['north']:.1f} m North of the 60 m asked, the fence {fence_m:.1f} m away")
    assert 3.0 < seen["north"] < fence_m


def test_mission_as_the_upstream_example_returns_home_and_lands(stack, truth, inst):
    seen = {"progress": [], "track": []}

    async def flight():
        drone = await connected(stack, inst)
        seen["start"] = truth.latest().pos_ned_m  # home will be here: where it arms
        items = [
            MissionItem(
                *latlon(n, e),
                ALT_M,
                5.0,
                True,
                math.nan,
                math.nan,
                MissionItem.CameraAction.NONE,
                math.nan,
                math.nan,
                math.nan,
                math.nan,
                math.nan,
                MissionItem.VehicleAction.NONE,
            )  # fmt: skip
            for n, e in MISSION_NE
        ]
        await drone.mission.set_return_to_launch_after_mission(True)
        await drone.mission.upload_mission(MissionPlan(items))
        seen["downloaded"] = len((await drone.mission.download_mission()).mission_items)
        await drone.action.arm()
        await drone.mission.start_mission()

        async def progress():
            async for p in drone.mission.mission_progress():
                seen["progress"].append((p.current, p.total))
                if p.current == p.total:
                    return

        t0_ms = truth.latest().time_ms  # the track from the simulator's truth at 50 Hz, whenever it was read
        await progress()
        await landed_and_disarmed(drone)
        seen["end"] = truth.now().pos_ned_m  # after the reader caught up: latest() may be from before the landing
        seen["track"] = [s.pos_ned_m[:2] for s in truth.since(t0_ms)]

    run(flight())
    stack.check_alive()
    track = seen["track"]
    closest = [min(math.hypot(p[0] - n, p[1] - e) for p in track) for n, e in MISSION_NE]
    end = seen["end"]
    print(f"progress {seen['progress']}; closest to each waypoint {[round(c, 2) for c in closest]} m; end {end}")
    assert seen["downloaded"] == len(MISSION_NE)
    assert seen["progress"][-1] == (len(MISSION_NE), len(MISSION_NE))
    assert max(closest) < 1.0
    start = seen["start"]
    assert math.hypot(end[0] - start[0], end[1] - start[1]) < 1.0 and abs(end[2] - start[2]) < 0.1  # home, landed


def test_offboard_position_ned_as_the_upstream_example(stack, truth, inst):
    seen = {}

    async def flight():
        drone = await connected(stack, inst)
        ground = truth.latest().pos_ned_m
        await drone.action.arm()
        await drone.offboard.set_position_ned(PositionNedYaw(0.0, 0.0, 0.0, 0.0))  # one before start, as required
        await drone.offboard.start()
        await drone.offboard.set_position_ned(
            PositionNedYaw(0.0, 0.0, -3.0, 0.0)
        )  # the EKF's origin: may be metres off
        await sim_sleep(truth, 8.0)

        async def still() -> bool:
            return math.hypot(*truth.latest().vel_ned_m_s) < 0.05

        await until(still, WAIT_S, "still over the offboard frame's origin")
        await sim_sleep(truth, 2.0)
        first = truth.latest().pos_ned_m
        await drone.offboard.set_position_ned(PositionNedYaw(6.0, -4.0, -3.0, 90.0))
        await sim_sleep(truth, 10.0)
        here = truth.latest().pos_ned_m  # the truth moved as the setpoints (their frame's origin is the EKF's)
        seen["offset"] = [here[0] - first[0], here[1] - first[1], here[2] - ground[2]]
        async for pv in drone.telemetry.position_velocity_ned():
            seen["own"] = (pv.position.north_m, pv.position.east_m, pv.position.down_m)
            break
        await drone.offboard.stop()
        await drone.action.land()
        await landed_and_disarmed(drone)

    run(flight())
    stack.check_alive()
    n, e, d = seen["offset"]
    own = seen["own"]
    print(f"offboard: moved {n:.2f} N {e:.2f} E, {-d:.2f} m up (asked 6, -4, 3); own estimate {own}")
    assert math.hypot(n - 6.0, e + 4.0) < 0.3 and abs(-d - 3.0) < 0.3
    assert math.hypot(own[0] - 6.0, own[1] + 4.0) < 0.2 and abs(own[2] + 3.0) < 0.2


def test_goto_as_the_upstream_example(stack, truth, inst):
    seen = {}

    async def flight():
        drone = await connected(stack, inst)
        async for home in drone.telemetry.home():
            absolute_altitude = home.absolute_altitude_m
            break
        ground = truth.latest().pos_ned_m[2]
        await take_off(drone, truth, 2.0)
        start = truth.now().pos_ned_m
        await drone.action.goto_location(*latlon(start[0] + 10.0, start[1]), absolute_altitude + ALT_M, 90.0)

        async def there():
            p = truth.latest()
            return math.hypot(p.pos_ned_m[0] - start[0] - 10.0, p.pos_ned_m[1] - start[1]) < 0.5 and (
                math.hypot(*p.vel_ned_m_s[:2]) < 0.2
            )

        await until(there, WAIT_S, "at the go-to point")
        await sim_sleep(truth, 3.0)
        seen["yaw_deg"] = math.degrees(truth_yaw(truth))
        seen["height"] = ground - truth.latest().pos_ned_m[2]
        await drone.action.land()
        await landed_and_disarmed(drone)

    run(flight())
    stack.check_alive()
    print(f"goto: yaw {seen['yaw_deg']:.1f} deg, {seen['height']:.2f} m up (asked {ALT_M} m above home)")
    assert seen["yaw_deg"] == pytest.approx(90.0, abs=3.0) and seen["height"] == pytest.approx(ALT_M, abs=0.3)


def test_all_parameters_the_version_and_the_flight_logs(stack, inst, tmp_path):
    seen = {}

    async def session():
        drone = await connected(stack, inst)
        params = await drone.param.get_all_params()
        seen["ints"] = {p.name: p.value for p in params.int_params}
        seen["floats"] = {p.name: p.value for p in params.float_params}
        version = await drone.info.get_version()
        seen["version"] = (version.flight_sw_major, version.flight_sw_minor, version.flight_sw_patch)
        entries = await drone.log_files.get_entries()
        seen["entries"] = len(entries)
        smallest = min(entries, key=lambda e: e.size_bytes)
        path = tmp_path / "downloaded.ulg"
        async for progress in drone.log_files.download_log_file(smallest, str(path)):
            if progress.progress == 1.0:
                break
        seen["log"] = path.read_bytes()
        seen["log_size"] = smallest.size_bytes

    run(session())
    print(f"{len(seen['ints'])} int and {len(seen['floats'])} float parameters; version {seen['version']}; "
          f"{seen['entries']} logs, the smallest {seen['log_size']} bytes")  # fmt: skip
    assert seen["floats"]["MPC_XY_CRUISE"] == pytest.approx(5.0) and seen["ints"]["SYS_AUTOSTART"] > 0
    assert len(seen["ints"]) + len(seen["floats"]) > 100
    assert seen["version"] == (1, 14, 0)  # PX4's numbering, AUTOPILOT_VERSION.flight_sw_version
    assert seen["entries"] >= 3  # this module's flights
    assert len(seen["log"]) == seen["log_size"] and seen["log"].startswith(b"ULog")


def test_parameters_read_and_written_through_the_param_plugin(stack, inst):
    seen = {}

    async def session():
        drone = await connected(stack, inst)
        seen["before"] = await drone.param.get_param_float("MPC_XY_CRUISE")
        await drone.param.set_param_float("MPC_XY_CRUISE", 4.5)
        seen["after"] = await drone.param.get_param_float("MPC_XY_CRUISE")
        seen["int"] = await drone.param.get_param_int("SYS_AUTOSTART")
        try:
            await drone.param.get_param_float("NO_SUCH_PARAM")
        except mavsdk.param.ParamError as exc:
            seen["missing"] = exc._result.result
        await drone.param.set_param_float("MPC_XY_CRUISE", seen["before"])

    run(session())
    assert seen["before"] == pytest.approx(5.0)
    assert seen["after"] == pytest.approx(4.5)
    assert seen["int"] > 0
    assert seen.get("missing") is not None, "a missing parameter was read without an error"


def test_failure_injection_as_the_upstream_example_lands_on_losing_gps(stack, truth, inst):
    """failure_injection.py's flow: SYS_FAILURE_EN 1, take off, GPS off in flight (MAV_CMD_INJECT_FAILURE):
    the position estimate is lost, so the vehicle lands (LAND, as PX4's failsafe without a position); GPS
    back on; it ends on the ground, disarmed."""
    seen = {"modes": []}

    async def flight():
        drone = await connected(stack, inst)
        await drone.param.set_param_int("SYS_FAILURE_EN", 1)
        ground = truth.latest().pos_ned_m[2]
        await take_off(drone, truth, ALT_M - 0.5, 2.0)

        async def modes():
            async for mode in drone.telemetry.flight_mode():
                seen["modes"].append(mode)

        watcher = asyncio.ensure_future(modes())
        await drone.failure.inject(FailureUnit.SENSOR_GPS, FailureType.OFF, 0)

        async def landing() -> bool:
            return bool(seen["modes"]) and seen["modes"][-1] == mavsdk.telemetry.FlightMode.LAND

        await until(landing, WAIT_S, "LAND after the GPS was lost")
        await drone.failure.inject(FailureUnit.SENSOR_GPS, FailureType.OK, 0)
        await landed_and_disarmed(drone)
        watcher.cancel()
        seen["height"] = ground - truth.now().pos_ned_m[2]
        await drone.param.set_param_int("SYS_FAILURE_EN", 0)

    run(flight())
    stack.check_alive()
    print(f"failure injection: modes {[m.name for m in dict.fromkeys(seen['modes'])]}; {seen['height']:.2f} m up")
    assert mavsdk.telemetry.FlightMode.LAND in seen["modes"] and abs(seen["height"]) < 0.1
