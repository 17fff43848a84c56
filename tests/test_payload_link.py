"""The flight controller's onboard payload link (autopilot/mavlink/payload_link.py) over loopback UDP.

A GcsLink with the payload link as its router (as ``autopilot`` assembles it), a pymavlink ground station in
front (tests/gcs_link_harness.py) and, when a test wants one, a pymavlink socket on the camera's port playing a
MAVLink camera (component 100).  Time is simulated: the harness pumps ``link.update``.
"""

from __future__ import annotations

import os

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from autopilot.mavlink.payload_link import NO_CAMERA, PayloadLink  # noqa: E402
from mavsim_core import ports  # noqa: E402

from gcs_link_harness import acks, command_long, of_type  # tests/gcs_link_harness.py

CAM = mavlink.MAV_COMP_ID_CAMERA


def _with_payload(make_harness, inst: int):
    h = make_harness(inst)
    payload = PayloadLink(h.link.endpoints, h.link.sysid, h.link.compid, inst, h.link.send_statustext)
    h.link.add_service(payload)
    h.link.router = payload.route
    return h, payload


def _camera(inst: int, sysid: int = 1) -> mavutil.mavfile:
    """A MAVLink camera sending to the payload link (which answers its senders as well as the camera's port)."""
    return mavutil.mavlink_connection(
        f"udpout:127.0.0.1:{ports.payload_local_port(inst)}", source_system=sysid, source_component=CAM,
        dialect="common",
    )  # fmt: skip


def _camera_heard(h, cam) -> None:
    cam.mav.heartbeat_send(mavlink.MAV_TYPE_CAMERA, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, mavlink.MAV_STATE_ACTIVE)
    got = h.pump(0.5, until=lambda m: m.get_type() == "HEARTBEAT" and m.get_srcComponent() == CAM)
    assert any(m.get_srcComponent() == CAM for m in of_type(got["gcs"], "HEARTBEAT")), "camera not forwarded"


def _drain(conn) -> list:
    out = []
    while (m := conn.recv_match(blocking=False)) is not None:
        out.append(m)
    return out


def test_without_a_camera_a_capture_command_is_unsupported_with_a_reason(make_harness, free_instance):
    """To component 100 or to all: one COMMAND_ACK, MAV_RESULT_UNSUPPORTED, from the flight controller, and a
    STATUSTEXT saying there is no camera."""
    h, _ = _with_payload(make_harness, free_instance())
    c = h.connect()
    for target in (CAM, 0):
        command_long(c, mavlink.MAV_CMD_IMAGE_START_CAPTURE, 0, 0, 1, 1, target_component=target)
        got = h.pump(0.3)["gcs"]
        a = acks(got, mavlink.MAV_CMD_IMAGE_START_CAPTURE)
        assert [(x.result, x.get_srcComponent()) for x in a] == [(mavlink.MAV_RESULT_UNSUPPORTED, 1)], target
        assert any(t.text == NO_CAMERA for t in of_type(got, "STATUSTEXT")), target


def test_a_camera_is_forwarded_both_ways_and_answers_alone(make_harness, free_instance):
    """The camera's HEARTBEAT and answers reach the ground station byte for byte (component 100); a command for
    it, or a broadcast camera command, reaches the camera and only the camera answers it; a ground station's
    HEARTBEAT reaches the camera and still keeps the flight controller's data link."""
    inst = free_instance()
    h, payload = _with_payload(make_harness, inst)
    c = h.connect()
    cam = _camera(inst)
    _camera_heard(h, cam)
    assert payload.camera_present()
    for target in (CAM, 0):
        command_long(c, mavlink.MAV_CMD_IMAGE_START_CAPTURE, 0, 0, 1, target + 1, target_component=target)
        got = h.pump(0.1)["gcs"]
        assert acks(got, mavlink.MAV_CMD_IMAGE_START_CAPTURE) == [], "the flight controller answered for the camera"
        at_camera = [m for m in _drain(cam) if m.get_type() == "COMMAND_LONG"]
        assert [(m.command, m.param4) for m in at_camera] == [(mavlink.MAV_CMD_IMAGE_START_CAPTURE, target + 1)]
        cam.mav.command_ack_send(mavlink.MAV_CMD_IMAGE_START_CAPTURE, mavlink.MAV_RESULT_ACCEPTED, 0, 0, 255, 190)
        got = h.pump(0.1)["gcs"]
        a = acks(got, mavlink.MAV_CMD_IMAGE_START_CAPTURE)
        assert [(x.result, x.get_srcComponent()) for x in a] == [(mavlink.MAV_RESULT_ACCEPTED, CAM)]
    # A command for the flight controller stays with it (answered once, not sent to the camera).
    command_long(c, mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION)
    got = h.pump(0.2)["gcs"]
    assert len(acks(got, mavlink.MAV_CMD_REQUEST_MESSAGE)) == 1
    assert not [m for m in _drain(cam) if m.get_type() == "COMMAND_LONG"]
    c.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
    h.pump(0.1)
    assert any(m.get_type() == "HEARTBEAT" and m.type == mavlink.MAV_TYPE_GCS for m in _drain(cam))
    assert h.vehicle.gcs_heartbeats, "the flight controller no longer sees the ground station's HEARTBEAT"
    cam.close()


def test_a_silent_camera_is_gone_after_its_timeout(make_harness, free_instance):
    """Three simulated seconds without its HEARTBEAT: commands for it are refused again, with the reason."""
    inst = free_instance()
    h, payload = _with_payload(make_harness, inst)
    c = h.connect()
    cam = _camera(inst)
    _camera_heard(h, cam)
    h.pump(3.5)
    assert not payload.camera_present()
    command_long(c, mavlink.MAV_CMD_VIDEO_START_CAPTURE, 0, 1, target_component=CAM)
    got = h.pump(0.2)["gcs"]
    assert [x.result for x in acks(got, mavlink.MAV_CMD_VIDEO_START_CAPTURE)] == [mavlink.MAV_RESULT_UNSUPPORTED]
    cam.close()
