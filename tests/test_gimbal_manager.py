"""The flight controller's gimbal manager (autopilot/mavlink/gimbal_manager.py) and its geometry
(autopilot/control/gimbal_pointing.py), without sockets: who is in control, range checks, ROI geometry, the
messages' fields (issue 34, item 2)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink

from autopilot.control.gimbal_pointing import (
    NO_GIMBAL_REQUEST,
    CameraAttitude,
    attitude_from_quaternion,
    look_along,
    look_at,
)
from autopilot.mavlink.command_fields import FieldError
from autopilot.mavlink.gimbal_control import DeviceRange, GimbalControl, resolve_control_id
from autopilot.mavlink.gimbal_manager import DEVICE_TIMEOUT_US, GimbalManager
from autopilot.param_catalogue import default_store
from autopilot.topics import LandedState

OWN = (1, 1)
GCS, OTHER = (245, 190), (255, 0)
NAN = math.nan
rad = math.radians


@pytest.mark.parametrize(
    "value, current, sender, expected",
    [
        (42, 0, 7, 42),  # an id
        (-1, 9, 7, 9),  # unchanged
        (-2, 9, 7, 1),  # the autopilot itself
        (-3, 7, 7, 0),  # released by its holder
        (-3, 9, 7, 9),  # not released by another
    ],
)
def test_configure_ids_read_as_px4(value, current, sender, expected):
    assert resolve_control_id(value, current, 1, sender) == expected


def test_control_is_taken_released_and_only_its_holder_commands():
    c = GimbalControl()
    assert not c.allows(GCS) and not c.allows((0, 0))
    c = c.configured((245, 190, -1, -1), GCS, OWN)
    assert c.allows(GCS) and not c.allows(OTHER)
    assert c.configured((-3, -3, -1, -1), OTHER, OWN) == c  # another cannot release it
    assert c.configured((-3, -3, -1, -1), GCS, OWN).primary == (0, 0)
    assert c.configured((-2, -2, -1, -1), OTHER, OWN).primary == OWN
    with pytest.raises(FieldError):
        resolve_control_id(-7, 0, 1, 245)


def test_look_along_and_at_give_pitch_down_and_yaw_from_north():
    a = look_along((1.0, 1.0, math.sqrt(2.0)))  # 45 deg down toward north-east
    assert a.yaw_earth and a.pitch_rad == pytest.approx(-math.pi / 4) and a.yaw_rad == pytest.approx(math.pi / 4)
    down = look_along((0.0, 0.0, 3.0))  # straight down: the vehicle's heading kept
    assert not down.yaw_earth and down.pitch_rad == pytest.approx(-math.pi / 2) and down.yaw_rad == 0.0
    b = look_at((10.0, 0.0, -20.0), (10.0, -20.0, 0.0))  # 20 m west and 20 m below
    assert b.yaw_rad == pytest.approx(-math.pi / 2) and b.pitch_rad == pytest.approx(-math.pi / 4)
    with pytest.raises(ValueError):
        look_along((0.0, 0.0, 0.0))


def test_quaternion_round_trip():
    att = CameraAttitude(0.0, rad(-45), rad(30))
    back = attitude_from_quaternion(att.quaternion_wxyz(), False)
    assert back.pitch_rad == pytest.approx(att.pitch_rad) and back.yaw_rad == pytest.approx(att.yaw_rad)
    assert attitude_from_quaternion([NAN] * 4, False) is None


def device_information(roll_deg, pitch_deg, yaw_deg=(-160, 160)):
    """GIMBAL_DEVICE_INFORMATION with these joint ranges (deg; NaN: unknown)."""
    (r0, r1), (p0, p1), (y0, y1) = roll_deg, pitch_deg, yaw_deg
    return mavlink.MAVLink_gimbal_device_information_message(
        0, b"", b"", b"", 0, 0, 0, 0, 0, rad(r0), rad(r1), rad(p0), rad(p1), rad(y0), rad(y1), 0
    )


class Estimate:
    """The estimate the manager reads: a valid position (NED m) from an origin at 47 N, 8 E, 400 m AMSL."""

    position_valid = True
    origin_lat_deg, origin_lon_deg, origin_alt_amsl_m = 47.0, 8.0, 400.0
    yaw_rad = 0.0

    def __init__(self, pos_ned_m) -> None:
        self.pos_ned_m = pos_ned_m


class Status:
    def __init__(self, landed=LandedState.IN_AIR, estimate=None, home=None, request=NO_GIMBAL_REQUEST):
        self.landed_state, self.estimate, self.home, self.gimbal_request = landed, estimate, home, request


class Harness:
    """A manager with recording effects, its device reported."""

    def __init__(self) -> None:
        self.params = default_store()
        self.status = Status()
        self.device: list = []
        self.sent: list = []
        self.texts: list[str] = []
        self.source = GCS
        self.reaches: list[float | None] = []  # what the manager published to the commander, step by step
        self.m = GimbalManager(
            self.params, lambda: self.status, self.device.append, lambda msg, c: self.sent.append((msg, c)),
            lambda sev, text: self.texts.append(text), lambda: self.source, OWN, self.reaches.append,
        )  # fmt: skip

    def report(self, information: bool = True) -> None:
        q = [1.0, 0.0, 0.0, 0.0]
        self.m.on_device_status(
            mavlink.MAVLink_gimbal_device_attitude_status_message(0, 0, 0, 44, q, NAN, NAN, NAN, 0, 0.0, NAN, 1)
        )
        if information:
            self.m.on_device_information(device_information((-45, 45), (-135, 30)))

    def tick(self, now_us: int) -> None:
        """One scheduled link step: the device's, then the link's update (as autopilot/lockstep_loop.py runs them)."""
        self.m.control_step(now_us)
        self.m.update(now_us)

    def gcs_points(self, pitch_deg: float, yaw_deg: float) -> int:
        """The ground station takes control (CONFIGURE) and points the gimbal (PITCHYAW); the PITCHYAW's result."""
        self.command(mavlink.MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE, GCS[0], GCS[1], -1, -1)
        return self.command(mavlink.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW, pitch_deg, yaw_deg)

    def command(self, cmd: int, *p: float, source=GCS) -> int:
        self.source = source
        params = tuple(list(p) + [NAN] * (7 - len(p)))
        return self.m.commands()[cmd](None, params, mavlink.MAV_FRAME_GLOBAL)


def test_without_a_device_every_gimbal_command_is_unsupported_and_nothing_is_advertised():
    h = Harness()
    assert h.command(mavlink.MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE, 245, 190) == mavlink.MAV_RESULT_UNSUPPORTED
    assert h.m.information() is None
    h.tick(1_000_000)
    assert h.sent == [] and h.device == []


def test_information_status_and_relay_fields():
    h = Harness()
    h.report()
    info = h.m.information()
    assert info.gimbal_device_id == 154 and info.cap_flags & mavlink.GIMBAL_MANAGER_CAP_FLAGS_HAS_YAW_LOCK
    assert (info.pitch_min, info.pitch_max) == pytest.approx((rad(-90), rad(30)))  # PX4's range and the device's
    assert (info.yaw_min, info.yaw_max) == pytest.approx((rad(-160), rad(160)))
    assert h.command(mavlink.MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE, 245, 190, -1, -1) == mavlink.MAV_RESULT_ACCEPTED
    h.tick(0)
    kinds = {(m.get_type(), c) for m, c in h.sent}
    assert ("GIMBAL_DEVICE_ATTITUDE_STATUS", 154) in kinds and ("GIMBAL_MANAGER_STATUS", 1) in kinds
    relayed = next(m for m, c in h.sent if m.get_type() == "GIMBAL_DEVICE_ATTITUDE_STATUS")
    assert relayed.gimbal_device_id == 0  # a separate component (154)
    status = next(m for m, c in h.sent if m.get_type() == "GIMBAL_MANAGER_STATUS")
    assert (status.primary_control_sysid, status.primary_control_compid) == GCS


def test_pitchyaw_in_control_in_range_reaches_the_device_others_are_denied_without_a_jump():
    h = Harness()
    h.report()
    pitchyaw = mavlink.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW
    assert h.command(pitchyaw, -45, 30) == mavlink.MAV_RESULT_DENIED  # nobody in control yet
    assert "not in control" in h.texts[-1]
    h.command(mavlink.MAV_CMD_DO_GIMBAL_MANAGER_CONFIGURE, 245, 190, -1, -1)
    assert h.command(pitchyaw, -45, 30) == mavlink.MAV_RESULT_ACCEPTED
    h.tick(0)
    sp = h.device[-1]
    assert sp.get_type() == "GIMBAL_DEVICE_SET_ATTITUDE" and sp.flags & mavlink.GIMBAL_DEVICE_FLAGS_YAW_IN_VEHICLE_FRAME
    att = attitude_from_quaternion(sp.q, False)
    assert (att.pitch_rad, att.yaw_rad) == pytest.approx((rad(-45), rad(30)))
    n = len(h.device)
    assert h.command(pitchyaw, 60, 0) == mavlink.MAV_RESULT_DENIED  # the device tops out at +30
    assert "pitch 60.0 deg outside" in h.texts[-1]
    assert h.command(pitchyaw, -10, 0, source=OTHER) == mavlink.MAV_RESULT_DENIED
    assert h.command(pitchyaw, -10, NAN) == mavlink.MAV_RESULT_DENIED  # pitch without yaw
    h.tick(20_000)
    assert len(h.device) == n  # nothing sent: the gimbal holds


def test_messages_from_a_client_not_in_control_are_ignored_with_one_statustext():
    h = Harness()
    h.report()
    msg = mavlink.MAVLink_gimbal_manager_set_pitchyaw_message(1, 1, 0, 0, rad(-30), 0.0, NAN, NAN)
    msg._header.srcSystem, msg._header.srcComponent = OTHER
    for _ in range(3):
        h.m.handlers()["GIMBAL_MANAGER_SET_PITCHYAW"](None, msg)
    assert len([t for t in h.texts if "not in control" in t]) == 1
    h.tick(0)
    assert h.device == []


def test_roi_points_from_the_estimated_position_and_none_returns_to_neutral():
    h = Harness()
    h.report()

    h.status = Status(estimate=Estimate(np.array([0.0, 0.0, -20.0])))  # 20 m up over the origin
    lat = 47.0 + math.degrees(20.0 / 6378137.0)  # 20 m north, on the ground
    assert (
        h.command(mavlink.MAV_CMD_DO_SET_ROI_LOCATION, 0, NAN, NAN, NAN, lat, 8.0, 400.0) == mavlink.MAV_RESULT_ACCEPTED
    )
    h.tick(0)
    att = attitude_from_quaternion(h.device[-1].q, True)
    assert att.pitch_rad == pytest.approx(rad(-45), abs=1e-4) and att.yaw_rad == pytest.approx(0.0, abs=1e-4)
    assert h.device[-1].flags & mavlink.GIMBAL_DEVICE_FLAGS_YAW_IN_EARTH_FRAME
    assert h.command(mavlink.MAV_CMD_DO_SET_ROI_NONE, 0) == mavlink.MAV_RESULT_ACCEPTED
    h.tick(20_000)
    assert h.device[-1].flags & mavlink.GIMBAL_DEVICE_FLAGS_NEUTRAL


def test_point_along_for_the_precision_landing():
    h = Harness()
    h.report()
    h.m.point_along((0.0, 0.0, 1.0))
    h.tick(0)
    att = attitude_from_quaternion(h.device[-1].q, False)
    assert att.pitch_rad == pytest.approx(-math.pi / 2)


def test_a_silent_device_is_lost_after_the_timeout_and_found_again_when_it_reports():
    h = Harness()
    h.report()
    h.gcs_points(-45, 30)
    h.tick(0)
    n = len(h.device)
    h.tick(DEVICE_TIMEOUT_US)  # silent for exactly the timeout: still there
    assert h.m.advertised and not any("lost" in t for t in h.texts)
    h.tick(DEVICE_TIMEOUT_US + 20_000)
    assert not h.m.advertised and h.m.information() is None
    assert "Gimbal device lost" in h.texts[-1]
    assert h.command(mavlink.MAV_CMD_DO_GIMBAL_MANAGER_PITCHYAW, -10, 0) == mavlink.MAV_RESULT_UNSUPPORTED
    h.sent.clear()
    h.tick(DEVICE_TIMEOUT_US + 400_000)
    assert h.sent == [] and len(h.device) == n  # nothing advertised, relayed or sent while it is away
    h.report()  # it returns: advertised again, its control and setpoint kept, the setpoint sent again
    h.tick(DEVICE_TIMEOUT_US + 420_000)
    assert h.m.advertised and h.m.control.primary == GCS
    att = attitude_from_quaternion(h.device[-1].q, False)
    assert len(h.device) == n + 1 and (att.pitch_rad, att.yaw_rad) == pytest.approx((rad(-45), rad(30)))


def test_roi_altitude_is_amsl_whatever_the_frame_as_px4_reads_it():
    """MAVSDK's set_roi_location sends its AMSL altitude in a MAV_FRAME_GLOBAL_RELATIVE_ALT COMMAND_INT."""
    h = Harness()
    h.report()

    h.status = Status(estimate=Estimate(np.array([0.0, 0.0, 0.0])))
    lat = 47.0 + math.degrees(10.0 / 6378137.0)  # 10 m north, 10 m below
    roi = h.m.commands()[mavlink.MAV_CMD_DO_SET_ROI_LOCATION]
    params = (0, NAN, NAN, NAN, lat, 8.0, 390.0)
    assert roi(None, params, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT) == mavlink.MAV_RESULT_ACCEPTED
    h.tick(0)
    assert attitude_from_quaternion(h.device[-1].q, True).pitch_rad == pytest.approx(rad(-45), abs=1e-4)


@pytest.mark.parametrize(
    "roll_deg, pitch_deg, reach_deg",
    [
        ((-45, 45), (-135, 30), 45),  # the vehicle files' gimbal: 45 every way (pitch 45 aft, 120 forward)
        ((-40, 40), (-120, 30), 30),  # the pitch joint's 30 deg aft of straight down is the least
        ((-20, 30), (-135, 30), 20),  # roll to the left
        ((-60, 60), (-170, -10), 60),  # forward, pitch up to -10 deg: 80 either side of straight down
        ((NAN, NAN), (NAN, NAN), 90),  # nothing known: no limit, held to 90
        ((-45, 45), (-80, 30), 0),  # pitch cannot look straight down
    ],
)
def test_the_devices_tilt_reach_is_its_least_from_straight_down(roll_deg, pitch_deg, reach_deg):
    """How far the joints turn the camera from the body's down axis whatever the direction: the smallest of the roll
    joint's reach either side of level and the pitch joint's either side of -90 deg (DeviceRange.tilt_reach_rad)."""
    reach = DeviceRange.from_information(device_information(roll_deg, pitch_deg)).tilt_reach_rad
    assert math.degrees(reach) == pytest.approx(reach_deg)


def test_the_manager_publishes_the_devices_reach_at_each_step_and_none_without_a_device():
    """What a precision landing's view cone takes with PLD_CAM_REACH -1 (autopilot/commander/external_inputs.py)."""
    h = Harness()
    h.tick(0)
    assert h.reaches == [None]  # no device has reported
    h.report(information=False)
    h.tick(20_000)
    assert h.m.advertised and h.reaches[-1] is None  # its range not known yet
    h.report()
    h.tick(40_000)
    h.tick(60_000)
    assert h.reaches[-2:] == [pytest.approx(rad(45))] * 2
    h.tick(60_000 + DEVICE_TIMEOUT_US + 20_000)
    assert not h.m.advertised and h.reaches[-1] is None  # lost
    off = Harness()
    off.params.set("MNT_MODE_OUT", 0)  # the manager off: the flight controller sees no gimbal
    off.report()
    off.tick(0)
    assert off.reaches == [None]
