"""Where a precision landing points the camera gimbal (autopilot/navigation/precland_gimbal.py): the decision's
table, and the gimbal manager taking over for it and giving control back (issue 34, item 2)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink
from test_gimbal_manager import GCS, OWN, Harness, Status  # tests/test_gimbal_manager.py: its harness

from autopilot.control.gimbal_pointing import NO_GIMBAL_REQUEST, GimbalAim, GimbalRequest, attitude_from_quaternion
from autopilot.navigation.precland import PrecLandPhase as P
from autopilot.navigation.precland_gimbal import landing_gimbal_request

HERE = np.array([0.0, 0.0, -3.0])  # the vehicle, 3 m up (NED)
DECK = np.array([1.0, -2.0, 0.0])  # the target estimate
ALONG = GimbalRequest(GimbalAim.ALONG, (1.0, -2.0, 3.0))
DOWN = GimbalRequest(GimbalAim.DOWN)


@pytest.mark.parametrize(
    "enabled, phase, target, vehicle, expected",
    [
        (True, None, DECK, HERE, NO_GIMBAL_REQUEST),  # no precision landing: the gimbal is its clients'
        (True, P.PREPARATION, None, HERE, DOWN),  # no target yet
        (True, P.PREPARATION, DECK, HERE, DOWN),
        (True, P.TRACKING, DECK, HERE, ALONG),  # toward the target estimate
        (True, P.APPROACHING, DECK, HERE, ALONG),
        (True, P.DOCKING, DECK, HERE, ALONG),
        (True, P.TRACKING, None, HERE, DOWN),  # no estimate
        (True, P.DOCKING, DECK, None, DOWN),  # no vehicle position
        (True, P.DOCKING, HERE, HERE, DOWN),  # on the target: no direction
        (True, P.TRACKING, np.array([math.nan, 0.0, 0.0]), HERE, DOWN),
        (True, P.SEARCH, DECK, HERE, DOWN),  # lost: looking down while climbing to search
        (True, P.FALLBACK, DECK, HERE, DOWN),
        (True, P.DONE, DECK, HERE, NO_GIMBAL_REQUEST),  # docked, motors cut: given back
        (False, P.TRACKING, DECK, HERE, NO_GIMBAL_REQUEST),  # PLD_GIMB_POINT 0
        # near straight down (issue 34 item 5): 0.37 m off at 1 m up (20 deg) is looked at straight down, so the
        # camera's yaw does not chase the bearing round to its joint's stop; 0.6 m off (31 deg) along the line
        (True, P.APPROACHING, np.array([-0.27, -0.26, 1.0]), np.zeros(3), DOWN),
        (True, P.DOCKING, np.array([0.0, -0.6, 1.0]), np.zeros(3), GimbalRequest(GimbalAim.ALONG, (0.0, -0.6, 1.0))),
    ],
)
def test_landing_gimbal_request_table(enabled, phase, target, vehicle, expected):
    assert landing_gimbal_request(enabled, phase, target, vehicle) == expected


def test_the_manager_takes_over_for_the_landing_and_gives_control_and_setpoint_back():
    h = Harness()
    h.report()
    h.gcs_points(-30, 20)
    h.tick(0)
    h.status = Status(request=ALONG)  # the landing starts
    h.tick(20_000)
    assert h.m.control.primary == OWN
    status = [m for m, c in h.sent if m.get_type() == "GIMBAL_MANAGER_STATUS"][-1]
    assert (status.primary_control_sysid, status.primary_control_compid) == OWN
    att = attitude_from_quaternion(h.device[-1].q, True)
    assert h.device[-1].flags & mavlink.GIMBAL_DEVICE_FLAGS_YAW_IN_EARTH_FRAME
    assert att.yaw_rad == pytest.approx(math.atan2(-2.0, 1.0))
    assert att.pitch_rad == pytest.approx(-math.atan2(3.0, math.sqrt(5.0)))
    assert h.command(mavlink.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW, 0, 0) == mavlink.MAV_RESULT_DENIED
    n = len(h.device)
    h.tick(40_000)  # the same request: nothing sent again
    assert len(h.device) == n
    h.status = Status(request=DOWN)
    h.tick(60_000)
    assert attitude_from_quaternion(h.device[-1].q, False).pitch_rad == pytest.approx(-math.pi / 2)
    h.status = Status()  # the landing ended: the client's control and its pitch -30, yaw 20 come back
    h.tick(80_000)
    assert h.m.control.primary == GCS
    back = attitude_from_quaternion(h.device[-1].q, False)
    assert (back.pitch_rad, back.yaw_rad) == pytest.approx((math.radians(-30), math.radians(20)))


def test_without_a_controller_before_the_landing_nobody_holds_it_after():
    h = Harness()
    h.report()
    h.status = Status(request=DOWN)
    h.tick(0)
    assert h.m.control.primary == OWN
    h.status = Status()
    h.tick(20_000)
    assert h.m.control.primary == (0, 0)
    assert h.device[-1].flags & mavlink.GIMBAL_DEVICE_FLAGS_NEUTRAL  # back to the neutral it had


def test_a_client_taking_control_during_the_landing_keeps_it():
    h = Harness()
    h.report()
    h.status = Status(request=ALONG)
    h.tick(0)
    assert h.gcs_points(-10, 0) == mavlink.MAV_RESULT_ACCEPTED
    h.tick(20_000)
    assert attitude_from_quaternion(h.device[-1].q, False).pitch_rad == pytest.approx(math.radians(-10))
    h.status = Status()
    h.tick(40_000)
    assert h.m.control.primary == GCS
    assert attitude_from_quaternion(h.device[-1].q, False).pitch_rad == pytest.approx(math.radians(-10))
