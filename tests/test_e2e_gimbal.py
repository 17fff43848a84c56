"""End-to-end: gimbal protocol v2 through MAVSDK's Gimbal plugin (issue 34, item 2), on a vehicle on the ground.

One stack (``SIM_CAM_MOUNT=2``: the gimbal without the UGV's world) at CLIENT_SPEED; MAVSDK 4's native API
finds the gimbal manager, takes control, points the camera (pitch -45, yaw 30 deg, yaw following the nose) and
reads its attitude back; the simulator's truth port (the camera's attitude from the joints) agrees.  A pitch
beyond the device's range and a command after control was released are refused (MAVSDK's ERROR: DENIED) with a
STATUSTEXT, and the gimbal stays where it was.  Only settled states and answers are asserted (a client in wall
time against a stack at full speed).
"""

from __future__ import annotations

import asyncio
import math

import pytest

mavsdk = pytest.importorskip("mavsdk", reason="MAVSDK is in the test extras: pip install '.[test]'")
from mavsdk.asyncio import ComponentType, Configuration, Mavsdk  # noqa: E402
from mavsdk.asyncio.plugins.gimbal import GimbalAsync  # noqa: E402
from mavsdk.asyncio.plugins.telemetry import TelemetryAsync  # noqa: E402
from mavsdk.plugins.gimbal import ControlMode, GimbalMode, SendMode  # noqa: E402

from gcs.launcher import Stack  # noqa: E402
from gcs.sim_client import SimClient  # noqa: E402
from mavsim_core import ports  # noqa: E402
from mavsim_core.quaternion import to_euler  # noqa: E402

from e2e_flight_helpers import CLIENT_SPEED, until  # noqa: E402  # tests/e2e_flight_helpers.py

pytestmark = pytest.mark.e2e
WAIT_S = 60.0  # wall-clock safety net of each wait
PITCH_DEG, YAW_DEG = -45.0, 30.0
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


def truth_pitch_yaw_rel_deg(truth) -> tuple[float, float]:
    """The camera's pitch and yaw relative to the vehicle's heading (deg), from the simulator's truth."""
    cam, body = truth.gimbal_truth, truth.latest_state
    _, pitch, yaw = to_euler(cam.q)
    _, _, heading = to_euler(body.attitude_quaternion)
    return math.degrees(pitch), (math.degrees(yaw - heading) + 180.0) % 360.0 - 180.0


async def _native(stack, truth) -> dict:
    out: dict = {}
    async with Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION)) as sdk:
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
