"""LANDING_TARGET decoding: the three field forms and every refusal."""

import math
import os

os.environ["MAVLINK20"] = "1"

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mav

from autopilot.mavlink.landing_target import LandingTargetRefusal, decode_landing_target
from autopilot.topics import LandingTargetMeasurement
from mavsim_core import quaternion as quat

LEVEL = np.array([1.0, 0.0, 0.0, 0.0])
YAW90 = quat.from_euler(0.0, 0.0, math.pi / 2)


def _msg(frame=mav.MAV_FRAME_BODY_FRD, valid=1, x=0.0, y=0.0, z=0.0, ax=0.0, ay=0.0, dist=0.0):
    return mav.MAVLink_landing_target_message(
        123456, 0, frame, ax, ay, dist, 0.0, 0.0, x, y, z, [1.0, 0.0, 0.0, 0.0], 0, valid
    )


def _ok(result) -> LandingTargetMeasurement:
    assert isinstance(result, LandingTargetMeasurement), result
    return result


def test_px4_local_ned_is_target_position_minus_vehicle_position():
    m = _ok(
        decode_landing_target(
            _msg(mav.MAV_FRAME_LOCAL_NED, x=10.0, y=5.0, z=0.0), LEVEL, 3.0, np.array([9.0, 5.5, -3.0])
        )
    )
    np.testing.assert_allclose(m.rel_pos_ned_m, [1.0, -0.5, 3.0])
    assert m.timestamp_us == 123456 and m.source_frame == mav.MAV_FRAME_LOCAL_NED and not m.angular


def test_body_frd_is_rotated_by_the_attitude():
    # Facing east: a target 1 m ahead and 2 m below is 1 m east, 2 m down.
    m = _ok(decode_landing_target(_msg(x=1.0, y=0.0, z=2.0), YAW90, 2.0))
    np.testing.assert_allclose(m.rel_pos_ned_m, [0.0, 1.0, 2.0], atol=1e-9)


def test_angular_form_with_distance_and_with_height_only():
    ax, ay = math.atan(0.5), math.atan(-0.25)
    ray = np.array([0.5, -0.25, 1.0])
    m = _ok(decode_landing_target(_msg(valid=0, ax=ax, ay=ay, dist=3.0), LEVEL, math.nan))
    np.testing.assert_allclose(m.rel_pos_ned_m, ray / np.linalg.norm(ray) * 3.0)
    assert m.angular
    m2 = _ok(decode_landing_target(_msg(valid=0, ax=ax, ay=ay, dist=0.0), LEVEL, 2.0))
    np.testing.assert_allclose(m2.rel_pos_ned_m, ray * 2.0)


def test_angular_form_body_ned_uses_heading_only():
    tilted_east = quat.mul(YAW90, quat.from_euler(0.2, 0.0, 0.0))
    m = _ok(decode_landing_target(_msg(mav.MAV_FRAME_BODY_NED, valid=0, ax=math.atan(1.0), dist=0.0), tilted_east, 2.0))
    np.testing.assert_allclose(m.rel_pos_ned_m, [0.0, 2.0, 2.0], atol=1e-9)


@pytest.mark.parametrize(
    "msg, q, h, pos, words",
    [
        (_msg(mav.MAV_FRAME_GLOBAL_INT, x=1.0), LEVEL, 2.0, None, "frame 5"),
        (_msg(mav.MAV_FRAME_LOCAL_NED, x=1.0), LEVEL, 2.0, None, "no local position"),
        (_msg(x=math.nan, y=0.0, z=1.0), LEVEL, 2.0, None, "not finite"),
        (_msg(x=math.inf, y=0.0, z=1.0), LEVEL, 2.0, None, "not finite"),
        (_msg(valid=0, ax=math.nan), LEVEL, 2.0, None, "not finite"),
        (_msg(valid=0, ax=0.1, dist=-1.0), LEVEL, 2.0, None, "negative distance"),
        (_msg(valid=0, ax=0.1, dist=math.inf), LEVEL, 2.0, None, "not finite"),
        (_msg(valid=0, ax=0.1, dist=0.0), LEVEL, math.nan, None, "no range and no height"),
        (_msg(mav.MAV_FRAME_GLOBAL_INT, valid=0, ax=0.1, dist=2.0), LEVEL, 2.0, None, "frame 5"),
        (_msg(valid=0, ax=1.6, dist=2.0), LEVEL, 2.0, None, "angle out of range"),
        (_msg(x=1.0), np.array([math.nan, 0, 0, 0]), 2.0, None, "attitude"),
    ],
)
def test_refusals_have_a_one_line_reason(msg, q, h, pos, words):
    r = decode_landing_target(msg, q, h, pos)
    assert isinstance(r, LandingTargetRefusal)
    assert words in r.reason and "\n" not in r.reason and len(r.reason) <= 50
