"""What a PX4 client sees of issue 36's leftovers at the link, over loopback UDP (tests/gcs_link_harness.py):

- GET_HOME_POSITION before home is set: TEMPORARILY_REJECTED and a STATUSTEXT saying why, to the asker only;
- a PARAM_REQUEST_READ flood for unknown names: every one answered (PARAM_ERROR, as before), one STATUSTEXT
  per endpoint per UNKNOWN_TEXT_PERIOD_S and the rest counted in one STATUSTEXT after it;
- a PARAM_SET of MAV_SYS_ID (applies at the next start) says so;
- MANUAL_CONTROL's extension fields read as PX4 reads them (aux1..aux6 behind enabled_extensions) and echoed by
  the MANUAL_CONTROL stream;
- ATTITUDE_TARGET while body rates are flown: ATTITUDE_IGNORE and the vehicle's attitude, from the flight
  controller's own setpoints;
- FLIGHT_INFORMATION's flight_uuid is COM_FLIGHT_UUID.
"""

from __future__ import annotations

import dataclasses
import math
import os
import struct
from types import SimpleNamespace

import numpy as np
import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from autopilot.commander.external_inputs import ExternalInputs  # noqa: E402
from autopilot.flight_controller import FlightController  # noqa: E402
from autopilot.mavlink import param_service  # noqa: E402
from autopilot.mavlink.control_messages import manual_input  # noqa: E402
from autopilot.mavlink.telemetry import attitude_target  # noqa: E402
from autopilot.mavlink.vehicle_interface import FlightControllerVehicle  # noqa: E402
from autopilot.param_catalogue import default_store  # noqa: E402
from autopilot.telemetry_extras import FlightTimes, TelemetryExtras  # noqa: E402
from autopilot.topics import AttitudeSetpoint  # noqa: E402
from mavsim_core.quaternion import from_euler  # noqa: E402
from params.vehicle import load_vehicle  # noqa: E402

from gcs_link_harness import StubVehicle, acks, command_long, make_snapshot, of_type

ACCEPTED, LATER = mavlink.MAV_RESULT_ACCEPTED, mavlink.MAV_RESULT_TEMPORARILY_REJECTED
HOME_TEXT = "Home position not set: waiting for a position fix"


# --------------------------------------------------------------------------- GET_HOME_POSITION


def test_get_home_position_before_home_is_rejected_for_now_with_a_statustext(make_harness, free_instance):
    h = make_harness(free_instance(), StubVehicle(snapshot=make_snapshot(with_estimate=False)))  # no home yet
    gcs, api = h.connect("gcs"), h.connect("api")
    command_long(gcs, mavlink.MAV_CMD_GET_HOME_POSITION)
    got = h.pump(0.1, until=lambda m: m.get_type() == "COMMAND_ACK")
    assert [a.result for a in acks(got["gcs"], mavlink.MAV_CMD_GET_HOME_POSITION)] == [LATER]
    assert [(m.severity, m.text) for m in of_type(got["gcs"], "STATUSTEXT")] == [
        (mavlink.MAV_SEVERITY_WARNING, HOME_TEXT)
    ]
    assert of_type(got["gcs"], "HOME_POSITION") == [] and of_type(got["api"], "STATUSTEXT") == []  # the asker's
    h.vehicle.snap = make_snapshot()  # home set
    command_long(api, mavlink.MAV_CMD_GET_HOME_POSITION)
    got = h.pump(0.1, until=lambda m: m.get_type() == "COMMAND_ACK")["api"]
    assert [a.result for a in acks(got, mavlink.MAV_CMD_GET_HOME_POSITION)] == [ACCEPTED]
    assert of_type(got, "HOME_POSITION") and of_type(got, "STATUSTEXT") == []  # (sent, and also streamed)


# --------------------------------------------------------------------------- unknown parameters


class Clock:
    """The parameter service's wall clock, moved by the test."""

    def __init__(self) -> None:
        self.s = 100.0

    def __call__(self) -> float:
        return self.s


def _read_unknown(h, client, names) -> dict[str, list]:
    """PARAM_REQUEST_READ of each name, one a link update (a burst past the link's receive budget would be
    dropped unread: rx_drain); what every client received meanwhile."""
    got: dict[str, list] = {name: [] for name in h.clients}
    for name in names:
        client.mav.param_request_read_send(1, 1, name.encode(), -1)
        for endpoint, msgs in h.pump(0.02).items():
            got[endpoint] += msgs
    return got


def _texts(msgs: list) -> list[str]:
    return [m.text for m in of_type(msgs, "STATUSTEXT")]


def test_a_read_flood_for_unknown_names_is_answered_but_not_spammed(make_harness, free_instance):
    h = make_harness(free_instance())
    clock = h.link.param_service.clock = Clock()
    gcs, api = h.connect("gcs"), h.connect("api")
    got = _read_unknown(h, gcs, [f"NO_SUCH_{i:03d}" for i in range(50)])
    assert len(of_type(got["gcs"], "PARAM_ERROR")) == 50  # every read answered, as before
    assert _texts(got["gcs"]) == ["unknown parameter NO_SUCH_000"]
    got = _read_unknown(h, api, ["OTHER_LINK"])  # another endpoint has its own period
    assert _texts(got["api"]) == ["unknown parameter OTHER_LINK"] and _texts(got["gcs"]) == []
    clock.s += param_service.UNKNOWN_TEXT_PERIOD_S  # the period is over: the held-back ones counted, once
    got = h.pump(0.1)
    assert _texts(got["gcs"]) == ["49 more requests for unknown parameters"] and _texts(got["api"]) == []
    assert _texts(_read_unknown(h, gcs, ["LATE_ONE"])["gcs"]) == []  # in the period that count started
    clock.s += param_service.UNKNOWN_TEXT_PERIOD_S
    assert _texts(h.pump(0.1)["gcs"]) == ["1 more request for unknown parameters"]
    clock.s += param_service.UNKNOWN_TEXT_PERIOD_S
    h.pump(0.1)  # a quiet period: the next one is said at once
    assert _texts(_read_unknown(h, gcs, ["AFTER_QUIET"])["gcs"]) == ["unknown parameter AFTER_QUIET"]


def test_setting_mav_sys_id_says_it_applies_at_the_next_start(make_harness, free_instance):
    params = default_store()
    h = make_harness(free_instance(), StubVehicle(params=params))
    gcs = h.connect("gcs")
    byte_wise = struct.unpack("<f", struct.pack("<i", 7))[0]  # PX4's INT32 encoding
    gcs.mav.param_set_send(1, 1, b"MAV_SYS_ID", byte_wise, mavlink.MAV_PARAM_TYPE_INT32)
    got = h.pump(0.1)["gcs"]
    assert params.get("MAV_SYS_ID") == 7  # stored, and reported
    assert [m.param_id for m in of_type(got, "PARAM_VALUE")] == ["MAV_SYS_ID"]
    assert [m.text for m in of_type(got, "STATUSTEXT")] == ["MAV_SYS_ID 7 applies at the next start"]
    assert h.link.sysid == 1  # the link keeps its id until then


# --------------------------------------------------------------------------- MANUAL_CONTROL's extensions


def _manual(**ext) -> mavlink.MAVLink_manual_control_message:
    fields = dict(buttons2=0, enabled_extensions=0, s=0, t=0, aux1=0, aux2=0, aux3=0, aux4=0, aux5=0, aux6=0)
    fields.update(ext)
    return mavlink.MAVLink_manual_control_message(1, 500, -250, 700, 100, 0b101, **fields)


def test_manual_control_extensions_are_read_as_px4_reads_them():
    m = manual_input(_manual(), 10, 1.0)
    assert (m.pitch, m.roll, m.throttle, m.yaw, m.buttons) == (0.5, -0.25, 0.7, 0.1, 0b101)
    assert all(math.isnan(v) for v in (*m.aux, m.s, m.t)) and m.buttons2 == 0  # none enabled: none known
    bits = 1 << 0 | 1 << 2 | 1 << 4 | 1 << 7  # s, aux1, aux3, aux6
    m = manual_input(_manual(enabled_extensions=bits, s=-300, t=400, aux1=1000, aux2=800, aux3=-1001, aux6=-500,
                             buttons2=0x8001), 10, 1.0)  # fmt: skip
    assert m.s == -0.3 and math.isnan(m.t)  # t sent but not enabled
    assert m.aux[0] == 1.0 and math.isnan(m.aux[1]) and math.isnan(m.aux[2])  # aux3 out of range: not read
    assert math.isnan(m.aux[3]) and math.isnan(m.aux[4]) and m.aux[5] == -0.5 and m.buttons2 == 0x8001


def test_manual_control_reaches_the_commander_with_its_aux_and_is_echoed(make_harness, free_instance):
    inputs = ExternalInputs()
    vehicle = FlightControllerVehicle(SimpleNamespace(params=default_store(), commander=SimpleNamespace(inputs=inputs)))
    vehicle.on_control_message(_manual(enabled_extensions=0b1100, aux1=250, aux2=-1000), 5_000)
    assert inputs.manual.aux[:2] == (0.25, -1.0) and inputs.manual.received_us == 5_000
    # the link's MANUAL_CONTROL stream (off by default, as in PX4) echoes what the vehicle read
    h = make_harness(free_instance())
    h.vehicle.snap = dataclasses.replace(h.vehicle.snap, extras=TelemetryExtras(manual=inputs.manual))
    gcs = h.connect("gcs")
    assert of_type(h.pump(1.0)["gcs"], "MANUAL_CONTROL") == []
    command_long(gcs, mavlink.MAV_CMD_SET_MESSAGE_INTERVAL, mavlink.MAVLINK_MSG_ID_MANUAL_CONTROL, 200_000)
    h.pump(0.1)
    echo = of_type(h.pump(1.0)["gcs"], "MANUAL_CONTROL")
    assert 4 <= len(echo) <= 6  # 5 Hz
    e = echo[-1]
    assert (e.target, e.x, e.y, e.z, e.r, e.buttons) == (1, 500, -250, 700, 100, 0b101)
    assert (e.enabled_extensions, e.aux1, e.aux2, e.aux3) == (0b1100, 250, -1000, 0)


# --------------------------------------------------------------------------- ATTITUDE_TARGET


def test_attitude_target_while_body_rates_are_flown_says_no_attitude():
    fc = FlightController(load_vehicle("quad_x"), default_store())
    fc.commander.status = dataclasses.replace(fc.commander.status, armed=True)
    snap = make_snapshot()  # the vehicle at yaw 90 deg
    q_sp = from_euler(0.1, -0.05, 1.0)
    fc._fly_attitude(AttitudeSetpoint(q_sp, None, 0.5))  # STABILIZED, offboard attitude
    at = attitude_target(dataclasses.replace(snap, control=fc.control_setpoints()), 1_000_000)
    assert at.type_mask == 0 and at.q == pytest.approx(list(q_sp))
    fc._fly_attitude(AttitudeSetpoint(None, np.array([0.3, -0.2, 0.1]), 0.5))  # ACRO, offboard body rates
    fc.rate_sp = fc.rate_override  # (what the next step flies)
    at = attitude_target(dataclasses.replace(snap, control=fc.control_setpoints()), 1_000_000)
    assert at.type_mask == mavlink.ATTITUDE_TARGET_TYPEMASK_ATTITUDE_IGNORE
    assert at.q == pytest.approx(list(snap.estimate.q_wxyz))  # the vehicle's own, not a stale setpoint
    assert (at.body_roll_rate, at.body_pitch_rate, at.body_yaw_rate) == pytest.approx((0.3, -0.2, 0.1))
    assert at.thrust == pytest.approx(0.5)


# --------------------------------------------------------------------------- FLIGHT_INFORMATION


def test_flight_information_reports_com_flight_uuid(make_harness, free_instance):
    params = default_store()
    params.set("COM_FLIGHT_UUID", 41)  # saved by an earlier run
    extras = FlightTimes(lambda: int(params.get("COM_FLIGHT_UUID"))).extras(None, 0)
    h = make_harness(free_instance())
    h.vehicle.snap = dataclasses.replace(h.vehicle.snap, extras=extras)
    command_long(h.connect("gcs"), mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_FLIGHT_INFORMATION)
    got = h.pump(0.1, until=lambda m: m.get_type() == "FLIGHT_INFORMATION")["gcs"]
    assert [m.flight_uuid for m in of_type(got, "FLIGHT_INFORMATION")] == [41]
