"""The yaw setpoint's own rate fed forward to the rate loop (autopilot/control/attitude_control.with_yaw_rate):
a rate about NED down, expressed in the body FRD frame whatever the attitude (PX4's yawspeed setpoint)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from autopilot.control.attitude_control import with_yaw_rate
from mavsim_core import quaternion as quat


@pytest.mark.parametrize(
    ("roll", "pitch", "yaw", "body"),
    [
        (0.0, 0.0, 0.0, (0.0, 0.0, 1.0)),  # level: all about body z
        (0.0, 0.0, 2.0, (0.0, 0.0, 1.0)),  # the heading does not matter
        (math.pi / 2, 0.0, 0.3, (0.0, 1.0, 0.0)),  # rolled right 90 deg: NED down is body y (right)
        (0.0, math.pi / 6, 0.0, (-0.5, 0.0, math.sqrt(3) / 2)),  # nose up 30 deg: part about body x
    ],
)
def test_a_yaw_rate_about_ned_down_in_body_axes(roll, pitch, yaw, body):
    q = quat.from_euler(roll, pitch, yaw).tolist()
    out = with_yaw_rate((0.1, -0.2, 0.3), q, 0.5)
    np.testing.assert_allclose(out, np.array([0.1, -0.2, 0.3]) + 0.5 * np.array(body), atol=1e-12)
    # the body rates that turn NED down's direction not at all: R (rates) stays along NED down
    ned = quat.to_matrix(np.asarray(q)) @ (np.array(out) - np.array([0.1, -0.2, 0.3]))
    np.testing.assert_allclose(ned, [0.0, 0.0, 0.5], atol=1e-12)
