"""End-to-end: commands with out-of-range, infinite or NaN fields are refused (issue 18, findings 3 and 4).

Real ``sitl`` and ``autopilot`` processes (``--speed max``), a pymavlink ground station on the API port
(:class:`gcs.client.VehicleClient`) sending COMMAND_LONG / COMMAND_INT with hostile fields, and the
simulator's truth (:class:`gcs.sim_client.SimClient`).  What a user checks: the COMMAND_ACK result, the
STATUSTEXT that explains a refusal, the arming state and mode in HEARTBEAT, and where the vehicle truly is.

- On the ground: COMPONENT_ARM_DISARM with param1 0.6, inf or NaN is DENIED (only 0 and 1 are valid, as the
  MAVLink spec says) and changes nothing; NAV_TAKEOFF to 1e30 m, 1e38 m or +inf is DENIED with a STATUSTEXT
  naming the ceiling (GF_MAX_VER_DIST, or the 10 km hard ceiling) and the vehicle stays on the ground;
  NAV_LAND while armed on the ground is accepted and the vehicle disarms COM_DISARM_LAND later, as after any
  landing (with COM_DISARM_PRFLT off it used to sit armed in AUTO.LAND for ever).
- Hovering: DO_REPOSITION with +-inf latitude/longitude/altitude or a yaw of 1e38 is DENIED and the hover
  holds; a DO_REPOSITION as COMMAND_INT in MAV_FRAME_GLOBAL_RELATIVE_ALT_INT reads its altitude above home
  (not AMSL, which would be hundreds of metres underground).
"""

from __future__ import annotations

import math

import pytest

from gcs.client import VehicleClient, mavlink
from gcs.launcher import Stack
from gcs.sim_client import SimClient
from mavsim_core import ports

from e2e_flight_helpers import CLIENT_SPEED, horizontal, latlon  # tests/e2e_flight_helpers.py

pytestmark = pytest.mark.e2e
WAIT_S = 120.0  # wall-clock safety net of each wait
ALT_M = 5.0
HOVER_TOL_M = 0.4
DENIED, ACCEPTED = mavlink.MAV_RESULT_DENIED, mavlink.MAV_RESULT_ACCEPTED
INF, NAN = math.inf, math.nan
HEARTBEAT_S = 1.5  # simulated seconds: HEARTBEAT comes at 1 Hz, so its arming flag is at most this old


@pytest.fixture(scope="module")
def vehicle(inst):
    """(client, truth) of one stack; pre-flight auto-disarm off, so slow steps on a busy machine cannot
    disarm the vehicle between commands."""
    with (
        Stack(instance=inst, speed=CLIENT_SPEED, flight_logs=False) as stack,
        SimClient(ports.sim_component_port(inst)) as truth,
        VehicleClient(stack.api_url, timeout_s=WAIT_S, idle=stack.check_alive) as client,
    ):
        truth.wait_connected()
        assert client.target_system == stack.sysid
        client.param_set("COM_DISARM_PRFLT", -1.0)
        client.wait_until(client.prearm_ok, WAIT_S, "ready to arm")
        yield client, truth


def command(client: VehicleClient, cmd: int, *params: float):
    """COMMAND_LONG ``cmd`` with param1..7 (missing ones 0); the CommandResult (result, refusal reason)."""
    return client.command_long(cmd, *params, timeout_s=20)


def truth_down(truth) -> float:
    return truth.latest().pos_ned_m[2]


def test_arm_disarm_takeoff_and_land_fields_on_the_ground(vehicle):
    client, truth = vehicle
    arm = mavlink.MAV_CMD_COMPONENT_ARM_DISARM
    for p1 in (0.6, INF, NAN, -1.0):
        result = command(client, arm, p1)
        assert result.result == DENIED, f"ARM_DISARM param1={p1}: {result.describe()}"
    client.wait_sim_time(HEARTBEAT_S)
    assert not client.armed(), "a refused ARM_DISARM armed the vehicle"
    command(client, arm, 1.0).check()
    client.wait_armed(True, WAIT_S)
    for p1 in (NAN, 0.4, -INF):
        result = command(client, arm, p1)
        assert result.result == DENIED, f"ARM_DISARM param1={p1} while armed: {result.describe()}"
    client.wait_sim_time(HEARTBEAT_S)
    assert client.armed(), "a refused ARM_DISARM disarmed the vehicle"

    takeoff = mavlink.MAV_CMD_NAV_TAKEOFF
    for alt in (1e30, 1e38, INF, -INF, -1e30):
        result = command(client, takeoff, 0, 0, 0, NAN, NAN, NAN, alt)
        assert result.result == DENIED, f"NAV_TAKEOFF to {alt} m: {result.describe()}"
        if math.isfinite(alt) and alt > 0:  # (an infinity: "param7 is inf")
            assert result.reason and "ceiling" in result.reason, result.reason
    client.wait_sim_time(HEARTBEAT_S)
    assert client.armed() and truth_down(truth) > -0.2, "a refused take-off left the ground"
    assert client.mode_name() != "TAKEOFF"

    result = command(client, mavlink.MAV_CMD_NAV_LAND, 0, 0, 0, NAN, NAN, NAN, NAN)
    assert result.result == ACCEPTED, result.describe()
    client.wait_sim_time(client.param_get("COM_DISARM_LAND") + HEARTBEAT_S)
    assert not client.armed(), "LAND on the ground was accepted but the vehicle stayed armed"


def test_reposition_fields_while_hovering(vehicle):
    client, truth = vehicle
    if client.armed():
        command(client, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0.0).check()
    home = client.wait_home()
    command(client, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1.0).check()
    command(client, mavlink.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, NAN, NAN, NAN, home.alt_amsl_m + ALT_M).check()
    client.wait_until(lambda: client.takeoff_done(ALT_M), WAIT_S, "take-off")
    client.wait_until(lambda: client.mode_name() == "LOITER", WAIT_S, "holding")
    client.wait_sim_time(2.0)
    hover = truth.now().pos_ned_m

    lat, lon = latlon(hover[0] + 3.0, hover[1])
    alt = home.alt_amsl_m + ALT_M
    bad = {
        "lat +inf": (-1, 1, 0, NAN, INF, lon, alt),
        "lat -inf": (-1, 1, 0, NAN, -INF, lon, alt),
        "lon +inf": (-1, 1, 0, NAN, lat, INF, alt),
        "alt +inf": (-1, 1, 0, NAN, lat, lon, INF),
        "alt -inf": (-1, 1, 0, NAN, lat, lon, -INF),
        "yaw 1e38": (-1, 1, 0, 1e38, lat, lon, alt),
        "yaw inf": (-1, 1, 0, INF, lat, lon, alt),
        "speed inf": (INF, 1, 0, NAN, lat, lon, alt),
        "half a position": (-1, 1, 0, NAN, lat, NAN, alt),
    }
    for what, params in bad.items():
        result = command(client, mavlink.MAV_CMD_DO_REPOSITION, *params)
        assert result.result == DENIED, f"DO_REPOSITION {what}: {result.describe()}"
    result = client.command_int(
        mavlink.MAV_CMD_DO_REPOSITION, -1, 1, 0, NAN, round(lat * 1e7), round(lon * 1e7), INF, timeout_s=20
    )
    assert result.result == DENIED, f"DO_REPOSITION (COMMAND_INT) altitude inf: {result.describe()}"
    client.wait_sim_time(3.0)
    now = truth.now().pos_ned_m
    assert math.dist(now, hover) < HOVER_TOL_M, f"refused repositions moved the vehicle: {hover} -> {now}"
    assert client.armed() and client.mode_name() == "LOITER"

    # a relative-altitude frame: 3 m north at ALT_M + 1 above home
    result = client.command_int(
        mavlink.MAV_CMD_DO_REPOSITION, -1, 1, 0, NAN, round(lat * 1e7), round(lon * 1e7), ALT_M + 1.0,
        frame=mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, timeout_s=20,
    )  # fmt: skip
    assert result.result == ACCEPTED, result.describe()
    client.wait_until(lambda: client.arrived(hover[0] + 3.0, hover[1]), WAIT_S, "3 m north")
    client.wait_sim_time(2.0)
    now = truth.now().pos_ned_m
    assert horizontal(now, (hover[0] + 3.0, hover[1])) < 0.5 and abs(-now[2] - (ALT_M + 1.0)) < 0.5, now

    command(client, mavlink.MAV_CMD_NAV_LAND, 0, 0, 0, NAN, NAN, NAN, NAN).check()
    client.wait_until(client.landed_and_disarmed, WAIT_S, "landed and disarmed")
