"""End-to-end: gimbal protocol v2 through MAVSDK's Gimbal plugin (issue 34, item 2), on a vehicle on the ground.

One stack (``SIM_CAM_MOUNT=2``: the gimbal without the UGV's world) at CLIENT_SPEED, driven by both MAVSDK
Python APIs unmodified (a plugin works only when both drive it):

* MAVSDK 4's native API finds the gimbal manager, takes control, points the camera (pitch -45, yaw 30 deg, yaw
  following the nose) and reads its attitude back; the simulator's truth port (the camera's attitude from the
  joints) agrees.  A pitch beyond the device's range and a command after control was released are refused
  (MAVSDK's ERROR: DENIED) with a STATUSTEXT, and the gimbal stays where it was.
* The gRPC MAVSDK-Python (``mavsdk_grpc``, its bundled ``mavsdk_server``) runs the flow of its upstream
  example ``gimbal.py`` as a user writes it (tests/test_e2e_mavsdk_grpc.py's way): the first gimbal of
  ``gimbal_list()``, ``take_control`` PRIMARY, ``set_angles`` (yaw following), the ``attitude()`` stream read
  until it shows the angles, ``release_control``; the truth agrees.

Only settled states and answers are asserted (clients in wall time against a stack at full speed).
"""

from __future__ import annotations

import asyncio
import math

import pytest

mavsdk = pytest.importorskip("mavsdk", reason="MAVSDK is in the test extras: pip install '.[test]'")
from mavsdk.asyncio.plugins.gimbal import GimbalAsync  # noqa: E402
from mavsdk.asyncio.plugins.telemetry import TelemetryAsync  # noqa: E402
from mavsdk.plugins.gimbal import ControlMode, GimbalMode, SendMode  # noqa: E402
from mavsdk_session import ground_station  # noqa: E402

mavsdk_grpc = pytest.importorskip("mavsdk_grpc", reason="mavsdk-grpc is in the test extras")

from gcs.launcher import Stack  # noqa: E402
from gcs.sim_client import SimClient  # noqa: E402
from mavsim_core import ports  # noqa: E402
from mavsim_core.quaternion import to_euler  # noqa: E402

from e2e_flight_helpers import CLIENT_SPEED, sim_sleep, until  # noqa: E402  # tests/e2e_flight_helpers.py

# (mavsdk_grpc's own start-up of mavsdk_server uses importlib.resources.path, deprecated: not ours to mend)
pytestmark = [pytest.mark.e2e, pytest.mark.filterwarnings("ignore:path is deprecated:DeprecationWarning")]
GRPC_BASE = 50100  # mavsdk_server's gRPC port: this plus the module's instance, as tests/test_e2e_mavsdk_grpc.py
WAIT_S = 60.0  # wall-clock safety net of each wait
PITCH_DEG, YAW_DEG = -45.0, 30.0
GRPC_PITCH_DEG, GRPC_YAW_DEG = -60.0, -20.0  # other angles than the native test's, so each is seen to move it
ROI_NORTH_M, ROI_BELOW_M = 10.0, 10.0  # the gRPC test's region of interest from home: pitch -45 deg, yaw North
TOL_DEG = 1.5  # settled camera vs commanded, MAVSDK's report vs the truth (the vehicle sits, near level)


@pytest.fixture(scope="module")
def gimbal_stack(inst):
    with (
        SimClient(ports.sim_component_port(inst)) as truth,
        Stack(
            instance=inst, speed=CLIENT_SPEED, extra_sitl_args=["--param", "SIM_CAM_MOUNT=2"], flight_logs=False
        ) as s,
    ):
        yield s, truth


def truth_pitch_yaw_earth_deg(truth) -> tuple[float, float]:
    """The camera's pitch and yaw from North (deg), from the simulator's truth."""
    _, pitch, yaw = to_euler(truth.gimbal_truth.q)
    return math.degrees(pitch), math.degrees(yaw)


def truth_pitch_yaw_rel_deg(truth) -> tuple[float, float]:
    """The camera's pitch and yaw relative to the vehicle's heading (deg), from the simulator's truth."""
    cam, body = truth.gimbal_truth, truth.latest_state
    _, pitch, yaw = to_euler(cam.q)
    _, _, heading = to_euler(body.attitude_quaternion)
    return math.degrees(pitch), (math.degrees(yaw - heading) + 180.0) % 360.0 - 180.0


async def _native(stack, truth) -> dict:
    out: dict = {}
    async with ground_station() as sdk:  # tests/mavsdk_session.py: plugins released first
        await sdk.add_any_connection(f"udpin://0.0.0.0:{stack.api_port}")
        system = await sdk.first_autopilot(timeout_s=30.0)
        assert system is not None, "MAVSDK found no autopilot"
        gimbal, tel = GimbalAsync(system), TelemetryAsync(system)
        texts: list[str] = []

        async def collect():
            async for t in tel.subscribe_status_text():
                texts.append(t.text)

        collector = asyncio.ensure_future(collect())

        async def found():
            return len((await gimbal.gimbal_list()).gimbals) > 0

        await until(found, WAIT_S, "MAVSDK found the gimbal")
        item = (await gimbal.gimbal_list()).gimbals[0]
        gid = item.gimbal_id
        out["device_id"] = item.gimbal_device_id
        await gimbal.take_control(gid, ControlMode.PRIMARY)
        await gimbal.set_angles(gid, 0.0, PITCH_DEG, YAW_DEG, GimbalMode.YAW_FOLLOW, SendMode.ONCE)

        async def settled():
            a = await gimbal.get_attitude(gid)
            e = a.euler_angle_forward
            return abs(e.pitch_deg - PITCH_DEG) < TOL_DEG and abs(e.yaw_deg - YAW_DEG) < TOL_DEG

        await until(settled, WAIT_S, "the camera at pitch -45, yaw 30")
        await asyncio.sleep(0.5)
        out["mavsdk"] = (await gimbal.get_attitude(gid)).euler_angle_forward
        out["truth"] = truth_pitch_yaw_rel_deg(truth)
        out["control"] = await gimbal.get_control_status(gid)

        with pytest.raises(mavsdk.plugins.gimbal.GimbalError):  # pitch +60: beyond the device's +30
            await gimbal.set_angles(gid, 0.0, 60.0, 0.0, GimbalMode.YAW_FOLLOW, SendMode.ONCE)
        await gimbal.release_control(gid)
        with pytest.raises(mavsdk.plugins.gimbal.GimbalError):  # no longer in control
            await gimbal.set_angles(gid, 0.0, -10.0, 0.0, GimbalMode.YAW_FOLLOW, SendMode.ONCE)
        await asyncio.sleep(1.0)
        out["after"] = truth_pitch_yaw_rel_deg(truth)
        out["texts"] = list(texts)
        collector.cancel()
    return out


def test_mavsdk_native_gimbal_points_reads_back_and_refuses(gimbal_stack):
    stack, truth = gimbal_stack
    out = asyncio.run(_native(stack, truth))
    assert out["device_id"] == 154  # MNT_MAV_COMPID, as PX4's simulated gimbal
    e = out["mavsdk"]
    pitch_t, yaw_t = out["truth"]
    assert abs(pitch_t - PITCH_DEG) < TOL_DEG and abs(yaw_t - YAW_DEG) < TOL_DEG, out["truth"]
    assert abs(e.pitch_deg - pitch_t) < TOL_DEG and abs(e.yaw_deg - yaw_t) < TOL_DEG, (e, out["truth"])
    assert out["control"].control_mode == ControlMode.PRIMARY
    texts = " | ".join(out["texts"])
    assert "Gimbal pitch/yaw denied: pitch 60.0 deg outside" in texts, texts
    assert "is not in control" in texts, texts
    pitch_a, yaw_a = out["after"]  # neither refusal moved it
    assert abs(pitch_a - PITCH_DEG) < TOL_DEG and abs(yaw_a - YAW_DEG) < TOL_DEG, out["after"]


async def _grpc_example(stack, truth, inst: int) -> dict:
    """The upstream ``gimbal.py``'s flow through the gRPC API: connect, the first gimbal of the list, take
    control, angles (yaw following), a slow look up by rates (SendMode.STREAM: one rate setpoint), angles again,
    a region of interest (altitude AMSL, as the example), release.  Each step waits on the ``attitude()``
    stream (the example sleeps) and the truth is read once it shows the step done."""
    out: dict = {}
    gimbal_api = mavsdk_grpc.gimbal
    follow, once, stream = gimbal_api.GimbalMode.YAW_FOLLOW, gimbal_api.SendMode.ONCE, gimbal_api.SendMode.STREAM
    drone = mavsdk_grpc.System(port=GRPC_BASE + inst)
    await drone.connect(system_address=f"udpin://0.0.0.0:{stack.api_port}")
    async for state in drone.core.connection_state():
        if state.is_connected:
            break
    async for home in drone.telemetry.home():
        break
    async for gimbal_list in drone.gimbal.gimbal_list():
        if gimbal_list.gimbals:
            item = gimbal_list.gimbals[0]
            break
    out["device_id"] = item.gimbal_device_id
    gid = item.gimbal_id

    async def attitude_until(done):
        async for attitude in drone.gimbal.attitude():
            if attitude.gimbal_id == gid and done(attitude.euler_angle_forward):
                return attitude.euler_angle_forward

    def near(pitch_deg, yaw_deg):
        return lambda e: abs(e.pitch_deg - pitch_deg) < TOL_DEG and abs(e.yaw_deg - yaw_deg) < TOL_DEG

    await drone.gimbal.take_control(gid, gimbal_api.ControlMode.PRIMARY)
    await drone.gimbal.set_angles(gid, 0.0, GRPC_PITCH_DEG, GRPC_YAW_DEG, follow, once)
    await attitude_until(near(GRPC_PITCH_DEG, GRPC_YAW_DEG))
    await sim_sleep(truth, 1.0)
    out["mavsdk"] = await attitude_until(lambda e: True)
    out["truth"] = truth_pitch_yaw_rel_deg(truth)
    out["control"] = await drone.gimbal.get_control_status(gid)

    await drone.gimbal.set_angular_rates(gid, 0.0, 5.0, 0.0, follow, stream)  # "slowly look up"
    out["looked_up"] = (await attitude_until(lambda e: e.pitch_deg > GRPC_PITCH_DEG + 3.0)).pitch_deg
    await drone.gimbal.set_angles(gid, 0.0, 0.0, 0.0, follow, once)  # "back to horizontal" stops the rates
    await attitude_until(near(0.0, 0.0))
    await sim_sleep(truth, 1.0)
    out["horizontal"] = truth_pitch_yaw_rel_deg(truth)

    north_deg = math.degrees(ROI_NORTH_M / 6_378_137.0)  # the ROI: ROI_NORTH_M north of home, ROI_BELOW_M below
    await drone.gimbal.set_roi_location(
        gid, home.latitude_deg + north_deg, home.longitude_deg, home.absolute_altitude_m - ROI_BELOW_M
    )
    roi_pitch_deg = -math.degrees(math.atan2(ROI_BELOW_M, ROI_NORTH_M))
    await attitude_until(lambda e: abs(e.pitch_deg - roi_pitch_deg) < 2 * TOL_DEG)
    await sim_sleep(truth, 1.0)
    out["roi"] = (roi_pitch_deg, truth_pitch_yaw_earth_deg(truth))
    await drone.gimbal.release_control(gid)
    return out


def test_mavsdk_grpc_gimbal_example_points_reads_back_and_looks_at_a_roi(gimbal_stack, inst):
    stack, truth = gimbal_stack
    out = asyncio.run(asyncio.wait_for(_grpc_example(stack, truth, inst), WAIT_S))
    assert out["device_id"] == 154
    e = out["mavsdk"]
    pitch_t, yaw_t = out["truth"]
    roi_pitch, (roi_pitch_t, roi_yaw_t) = out["roi"]
    print(f"gRPC MAVSDK: pitch {e.pitch_deg:.2f} yaw {e.yaw_deg:.2f} deg, truth {pitch_t:.2f} {yaw_t:.2f}; "
          f"looked up to {out['looked_up']:.1f}; horizontal {out['horizontal']}; ROI pitch {roi_pitch:.1f} deg, "
          f"truth {roi_pitch_t:.2f} (yaw from North {roi_yaw_t:.2f})")  # fmt: skip
    assert abs(pitch_t - GRPC_PITCH_DEG) < TOL_DEG and abs(yaw_t - GRPC_YAW_DEG) < TOL_DEG, out["truth"]
    assert abs(e.pitch_deg - pitch_t) < TOL_DEG and abs(e.yaw_deg - yaw_t) < TOL_DEG, (e, out["truth"])
    assert out["control"].control_mode == mavsdk_grpc.gimbal.ControlMode.PRIMARY
    assert all(abs(a) < TOL_DEG for a in out["horizontal"]), out["horizontal"]  # the rates stopped
    assert abs(roi_pitch_t - roi_pitch) < 2 * TOL_DEG and abs(roi_yaw_t) < 2 * TOL_DEG, out["roi"]
