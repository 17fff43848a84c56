"""GcsLink reads everything that arrives: sticks and setpoints in floods, with commands still answered at once.

A GcsLink on real loopback UDP sockets with the stub vehicle (tests/gcs_link_harness.py), driven by
the test: datagrams are queued on the link's sockets first (a loopback ``sendto`` has queued the
datagram when it returns), then ONE ``link.update`` runs, and we check what reached the vehicle
(``StubVehicle.control_messages`` / ``gcs_heartbeats``) and what the client got back.

- a flood of MANUAL_CONTROL with a COMMAND_LONG behind it is drained in one call: every stick
  message reaches the vehicle and the command is acknowledged by that call;
- MANUAL_CONTROL / SET_POSITION_TARGET_* / SET_ATTITUDE_TARGET reach the vehicle only when
  addressed to us; only a ground station's HEARTBEAT (MAV_TYPE_GCS) is reported;
- the time budget (``rx_drain.RX_BUDGET_S``, CPU time): past it and the first ``RX_MIN_HANDLED``
  datagrams of a socket, everything but commands is dropped unparsed and counted (``rx_dropped``),
  commands are still answered (``RX_KEEP_PER_SENDER`` per sender, ``RX_KEEP_MAX`` in all), and the
  next call starts from what is new;
- datagrams addressed to other systems are dropped unparsed (``rx_foreign``);
- damaged datagrams in the flood are counted (``rx_errors``) and do not stop the drain.

How long a datagram takes to handle depends on the machine (about 20 µs here), so the tests that
need every datagram handled set the budget to a second, a safety net rather than a limit; the
budget's own behaviour is tested with it at 0, where it does not depend on speed.
"""

from __future__ import annotations

import os
import time

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from autopilot.mavlink import rx_drain  # noqa: E402

from gcs_link_harness import DT_US, GCS_COMP, GCS_SYS, command_long  # tests/gcs_link_harness.py

AUTOPILOT_VERSION = mavlink.MAVLINK_MSG_ID_AUTOPILOT_VERSION
REQUEST_MESSAGE = mavlink.MAV_CMD_REQUEST_MESSAGE
GENEROUS_BUDGET_S = 1.0  # a safety net: every queued datagram is handled on any machine


def sticks(client, n: int, target: int = 1) -> None:
    """``n`` MANUAL_CONTROL datagrams, sticks centred (throttle 500 = centre)."""
    for _ in range(n):
        client.mav.manual_control_send(target, 0, 0, 500, 0, 0)


def request_version(client) -> None:
    command_long(client, REQUEST_MESSAGE, AUTOPILOT_VERSION)


def one_update(h) -> None:
    """One link update (50 Hz iteration) at the next 4 ms step of simulated time, once what was sent is
    queued (loopback queues it in sendto, or soon after when the machine is busy)."""
    time.sleep(0.05)
    h.t_us += DT_US
    h.link.update(h.t_us)


def received(client, settle_s: float = 0.3) -> list:
    """What the client has been sent: everything until ``settle_s`` of silence (safety net)."""
    out = []
    while (m := client.recv_match(blocking=True, timeout=settle_s)) is not None:
        out.append(m)
    return out


def version_acks(msgs: list) -> list:
    return [m for m in msgs if m.get_type() == "COMMAND_ACK" and m.command == REQUEST_MESSAGE]


@pytest.fixture
def ready(make_harness, inst):
    """A harness whose gcs and api clients have heard the link (so they can send), with the sockets
    drained and nothing recorded yet."""
    h = make_harness(inst)
    clients = h.connect("gcs"), h.connect("api")
    h.pump(0.1)
    for c in clients:
        received(c, settle_s=0.05)
    h.vehicle.control_messages.clear()
    h.vehicle.gcs_heartbeats.clear()
    h.link.rx_dropped = h.link.rx_errors = 0
    return h


# --------------------------------------------------------------------------- draining


def test_flood_of_sticks_then_a_command_handled_in_one_update(ready, monkeypatch):
    monkeypatch.setattr(rx_drain, "RX_BUDGET_S", GENEROUS_BUDGET_S)
    h = ready
    gcs, api = h.clients["gcs"], h.clients["api"]
    sticks(gcs, 300)
    request_version(gcs)  # behind all 300
    sticks(api, 40)  # the other socket is drained too
    one_update(h)
    assert h.vehicle.control_messages == [("MANUAL_CONTROL", h.t_us)] * 340
    assert h.link.rx_dropped == 0 and h.link.rx_errors == 0
    got = received(gcs)
    assert [(a.result, a.target_system, a.target_component) for a in version_acks(got)] == [
        (mavlink.MAV_RESULT_ACCEPTED, GCS_SYS, GCS_COMP)
    ]
    assert any(m.get_type() == "AUTOPILOT_VERSION" for m in got)


def test_command_behind_a_flood_answered_at_the_default_budget(ready):
    """Whatever the machine's speed: the command is answered by the same update, and every stick message
    either reached the vehicle or was counted as dropped (none lost in the socket's buffer)."""
    h = ready
    gcs = h.clients["gcs"]
    sticks(gcs, 300)
    request_version(gcs)
    one_update(h)
    assert [a.result for a in version_acks(received(gcs))] == [mavlink.MAV_RESULT_ACCEPTED]
    assert len(h.vehicle.control_messages) + h.link.rx_dropped == 300
    assert h.link.rx_errors == 0


def test_only_messages_to_us_reach_the_vehicle(ready):
    h = ready
    gcs, api = h.clients["gcs"], h.clients["api"]
    gcs.mav.manual_control_send(2, 0, 0, 500, 0, 0)  # another vehicle's sticks
    gcs.mav.manual_control_send(1, 100, -200, 700, 50, 1)
    ignore = 0b0000_1111_1111_1000  # position only
    for target in ((1, 1), (2, 1), (1, mavlink.MAV_COMP_ID_CAMERA)):  # us, another vehicle, another component
        api.mav.set_position_target_local_ned_send(0, *target, mavlink.MAV_FRAME_LOCAL_NED, ignore, 1, 2, -3, *[0] * 8)
    api.mav.set_position_target_global_int_send(
        0, 1, 1, mavlink.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, ignore, 473977420, 85455940, 10, 0, 0, 0, 0, 0, 0, 0, 0
    )
    api.mav.set_attitude_target_send(0, 1, 1, 0, [1, 0, 0, 0], 0, 0, 0, 0.5)
    api.mav.set_attitude_target_send(0, 3, 1, 0, [1, 0, 0, 0], 0, 0, 0, 0.5)  # another vehicle
    gcs.mav.heartbeat_send(mavlink.MAV_TYPE_QUADROTOR, mavlink.MAV_AUTOPILOT_PX4, 0, 0, 0)  # not a ground station
    gcs.mav.heartbeat_send(mavlink.MAV_TYPE_ONBOARD_CONTROLLER, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
    gcs.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
    one_update(h)
    assert sorted(t for t, _ in h.vehicle.control_messages) == sorted(
        ["MANUAL_CONTROL", "SET_POSITION_TARGET_LOCAL_NED", "SET_POSITION_TARGET_GLOBAL_INT", "SET_ATTITUDE_TARGET"]
    )
    assert {t_us for _, t_us in h.vehicle.control_messages} == {h.t_us}
    assert h.vehicle.gcs_heartbeats == [h.t_us]
    # and on the other steps poll() delivers them just the same
    gcs.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
    sticks(gcs, 1)
    time.sleep(0.05)
    h.t_us += DT_US
    h.link.poll(h.t_us)
    assert h.vehicle.gcs_heartbeats[-1] == h.t_us and h.vehicle.control_messages[-1] == ("MANUAL_CONTROL", h.t_us)


# --------------------------------------------------------------------------- the time budget


def test_a_quiet_link_is_handled_whatever_the_budget(ready, monkeypatch):
    """The first RX_MIN_HANDLED datagrams of each socket are handled in every call even with no time
    left (a link's usual traffic: a preempted or slow call loses none of it); the rest is dropped."""
    monkeypatch.setattr(rx_drain, "RX_BUDGET_S", 0.0)
    monkeypatch.setattr(rx_drain, "RX_POLL_BUDGET_S", 0.0)
    h = ready
    gcs, api = h.clients["gcs"], h.clients["api"]
    gcs.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
    gcs.mav.param_request_read_send(1, 1, b"MPC_XY_P", -1)
    sticks(gcs, 2)
    sticks(api, 5)
    one_update(h)
    assert h.vehicle.gcs_heartbeats == [h.t_us] and len(h.vehicle.control_messages) == 2 + 4
    assert [m.param_id for m in received(gcs) if m.get_type() == "PARAM_VALUE"] == ["MPC_XY_P"]
    assert h.link.rx_dropped == 1
    sticks(gcs, 1)
    time.sleep(0.05)
    h.link.poll(h.t_us + DT_US)  # a poll too
    assert len(h.vehicle.control_messages) == 7


def test_past_the_budget_sticks_are_dropped_and_the_next_call_is_fresh(ready, monkeypatch):
    monkeypatch.setattr(rx_drain, "RX_BUDGET_S", 0.0)
    monkeypatch.setattr(rx_drain, "RX_MIN_HANDLED", 0)
    h = ready
    gcs, api = h.clients["gcs"], h.clients["api"]
    sticks(gcs, 120)
    api.mav.set_attitude_target_send(0, 1, 1, 0, [1, 0, 0, 0], 0, 0, 0, 0.5)
    sticks(api, 79)
    one_update(h)  # no time: every datagram read and dropped unparsed
    assert h.vehicle.control_messages == []
    assert h.link.rx_dropped == 120 + 80
    assert h.link.rx_errors == 0
    request_version(gcs)  # a fresh command: answered by the next call, nothing stale in front of it
    one_update(h)
    assert [a.result for a in version_acks(received(gcs))] == [mavlink.MAV_RESULT_ACCEPTED]
    assert h.link.rx_dropped == 200 and h.vehicle.control_messages == []


def test_past_the_budget_only_commands_are_handled_a_few_per_sender(ready, monkeypatch):
    """Past the budget a command is handled, anything else dropped (a PARAM_REQUEST_READ too: its client
    asks again); one sender gets RX_KEEP_PER_SENDER commands a call, so another sender's still gets
    through; the commands over the counts are handled by the next call, those past the backlog dropped."""
    monkeypatch.setattr(rx_drain, "RX_BUDGET_S", 0.0)
    monkeypatch.setattr(rx_drain, "RX_MIN_HANDLED", 0)
    monkeypatch.setattr(rx_drain, "RX_KEEP_PER_SENDER", 3)
    monkeypatch.setattr(rx_drain, "RX_KEEP_MAX", 4)
    monkeypatch.setattr(rx_drain, "RX_BACKLOG_MAX", 4)
    h = ready
    gcs, api = h.clients["gcs"], h.clients["api"]
    sticks(gcs, 100)
    request_version(gcs)
    gcs.mav.param_request_read_send(1, 1, b"MPC_XY_P", -1)
    sticks(gcs, 50)
    for _ in range(6):  # 7 commands from this sender: 3 handled, 4 kept for the next call
        request_version(gcs)
    for _ in range(2):  # from another sender: 1 handled (RX_KEEP_MAX is 4 in all), 1 over the backlog
        request_version(api)
    one_update(h)
    got = received(gcs)
    assert len(version_acks(got)) == 3
    assert len(version_acks(received(api))) == 1
    assert [m.param_id for m in got if m.get_type() == "PARAM_VALUE"] == []
    assert h.vehicle.control_messages == []
    assert h.link.rx_dropped == 100 + 1 + 50 + 1
    one_update(h)  # the backlog: 3 of this sender's 4, then the last one
    assert len(version_acks(received(gcs))) == 3
    one_update(h)
    assert len(version_acks(received(gcs))) == 1
    assert h.link.rx_dropped == 152


def test_datagrams_for_other_systems_are_dropped_unparsed(ready, monkeypatch):
    """CRC-valid commands, sticks and parameter writes addressed to another system: nothing reaches the
    vehicle, nothing is answered, all counted in ``rx_foreign``; ours in the same flood are handled."""
    monkeypatch.setattr(rx_drain, "RX_BUDGET_S", GENEROUS_BUDGET_S)
    h = ready
    gcs = h.clients["gcs"]
    for _ in range(20):
        gcs.mav.command_long_send(7, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0)
        gcs.mav.manual_control_send(7, 0, 0, 900, 0, 0)
        gcs.mav.param_set_send(7, 1, b"MC_ROLLRATE_P", 0.0, mavlink.MAV_PARAM_TYPE_REAL32)
    sticks(gcs, 1)
    request_version(gcs)
    one_update(h)
    got = received(gcs)
    assert h.link.rx_foreign == 60 and h.link.rx_dropped == 0 and h.link.rx_errors == 0
    assert h.vehicle.control_messages == [("MANUAL_CONTROL", h.t_us)]
    assert [a.command for a in got if a.get_type() == "COMMAND_ACK"] == [REQUEST_MESSAGE]
    assert h.vehicle.commands == [] and [m for m in got if m.get_type() == "PARAM_VALUE"] == []


# --------------------------------------------------------------------------- damaged input


def test_damaged_datagrams_in_the_flood_do_not_stop_the_drain(ready, monkeypatch):
    monkeypatch.setattr(rx_drain, "RX_BUDGET_S", GENEROUS_BUDGET_S)
    h = ready
    gcs = h.clients["gcs"]
    encoder = mavlink.MAVLink(None, GCS_SYS, GCS_COMP)
    good = encoder.manual_control_encode(1, 0, 0, 500, 0, 0).pack(encoder)
    bad_crc = bytearray(good)
    bad_crc[-2] ^= 0x5A
    junk = [bytes(bad_crc), good[:9], good[:-3], b"\x00\x01\x02 not mavlink", b"\xfd"]
    for k in range(250):
        sticks(gcs, 1)
        if k % 10 == 0:
            gcs.write(junk[(k // 10) % len(junk)])
    request_version(gcs)
    one_update(h)
    assert len(h.vehicle.control_messages) == 250
    assert h.link.rx_errors >= 25 and h.link.rx_dropped == 0
    assert [a.result for a in version_acks(received(gcs))] == [mavlink.MAV_RESULT_ACCEPTED]
