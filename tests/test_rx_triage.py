"""autopilot/mavlink/rx_triage.py: what a datagram holds, from its MAVLink headers alone (no sockets).

The target system offset of every message that has one (pymavlink's definitions: 66 messages), read
back by unpacking a payload with only that byte set; MAVLink 2 truncation (target 0 trimmed away means
broadcast), v1 packets, signed packets, several packets in one datagram, and damage.
"""

from __future__ import annotations

import os

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v10 import common as mavlink1  # noqa: E402
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from autopilot.mavlink.rx_triage import TARGET_OFFSETS, Kind, headers, triage  # noqa: E402

US = 3


def packed(msg, sysid: int = 200, compid: int = 1, signed: bool = False) -> bytes:
    enc = mavlink.MAVLink(None, sysid, compid)
    if signed:
        enc.signing.secret_key = bytes(range(32))
        enc.signing.sign_outgoing = True
    return msg.pack(enc)


def field_value(cls, payload: bytes, field: str):
    """The value of ``field`` in an unpacked payload (arrays other than char unpack to several values)."""
    values, i = cls.unpacker.unpack(payload), 0
    for name, length in zip(cls.ordered_fieldnames, cls.array_lengths):
        if name == field:
            return values[i]
        kind = cls.fieldtypes[cls.fieldnames.index(name)]
        i += length if length and kind != "char" else 1
    raise KeyError(field)


def test_target_offsets_of_every_message():
    with_target = {
        mid for mid, cls in mavlink.mavlink_map.items() if "target_system" in cls.ordered_fieldnames or mid == 69
    }
    assert set(TARGET_OFFSETS) == with_target and len(with_target) > 50
    for mid, offset in TARGET_OFFSETS.items():
        cls = mavlink.mavlink_map[mid]
        payload = bytearray(cls.unpacker.size)
        payload[offset] = 7
        field = "target" if mid == 69 else "target_system"
        assert field_value(cls, bytes(payload), field) == 7, cls.msgname


def test_kinds_of_single_packets():
    land = mavlink.MAVLink_command_long_message(US, 1, mavlink.MAV_CMD_NAV_LAND, 0, 0, 0, 0, 0, 0, 0, 0)
    arm_other = mavlink.MAVLink_command_long_message(
        US + 1, 1, mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0, 1, 0, 0, 0, 0, 0, 0
    )
    assert triage(packed(land), US) is Kind.COMMAND
    assert triage(packed(arm_other), US) is Kind.FOREIGN
    assert triage(packed(mavlink.MAVLink_set_mode_message(US, 1, 0)), US) is Kind.COMMAND
    assert triage(packed(mavlink.MAVLink_param_request_read_message(US, 1, b"MPC_XY_P", -1)), US) is Kind.OTHER
    assert triage(packed(mavlink.MAVLink_manual_control_message(US, 0, 0, 500, 0, 0)), US) is Kind.SUPERSEDED
    assert triage(packed(mavlink.MAVLink_manual_control_message(US + 1, 0, 0, 500, 0, 0)), US) is Kind.FOREIGN
    heartbeat = mavlink.MAVLink_heartbeat_message(mavlink.MAV_TYPE_GCS, 8, 0, 0, 0, 3)  # no target: for everyone
    assert triage(packed(heartbeat), US) is Kind.SUPERSEDED
    # a command to everyone (target 0, trimmed from the end of a MAVLink 2 payload) is ours too
    broadcast = packed(mavlink.MAVLink_command_long_message(0, 0, mavlink.MAV_CMD_NAV_LAND, 0, 0, 0, 0, 0, 0, 0, 0))
    assert broadcast[1] < mavlink.MAVLink_command_long_message.unpacker.size  # truncated payload
    assert headers(broadcast) == [(mavlink.MAVLINK_MSG_ID_COMMAND_LONG, 0)]
    assert triage(broadcast, US) is Kind.COMMAND


def test_signed_v1_and_several_packets():
    land = mavlink.MAVLink_command_long_message(US, 1, mavlink.MAV_CMD_NAV_LAND, 0, 0, 0, 0, 0, 0, 0, 0)
    signed = packed(land, signed=True)
    assert signed[2] & 1 and headers(signed) == [(76, US)]
    v1_packet = mavlink1.MAVLink_param_request_read_message(US + 1, 1, b"X", -1).pack(mavlink1.MAVLink(None, 200, 1))
    assert v1_packet[0] == 0xFE and headers(v1_packet) == [(20, US + 1)]
    sticks = packed(mavlink.MAVLink_manual_control_message(US, 0, 0, 500, 0, 0))
    foreign = packed(mavlink.MAVLink_command_long_message(US + 1, 1, 400, 0, 1, 0, 0, 0, 0, 0, 0))
    assert triage(sticks + signed, US) is Kind.COMMAND
    assert triage(foreign + sticks, US) is Kind.SUPERSEDED  # the foreign packet does not count
    assert triage(foreign + v1_packet, US) is Kind.FOREIGN


def test_damage():
    land = packed(mavlink.MAVLink_command_long_message(US, 1, mavlink.MAV_CMD_NAV_LAND, 0, 0, 0, 0, 0, 0, 0, 0))
    for junk in (b"", b"\x00\x01 not mavlink", land[:9], land[:-1], land + b"\x00", b"junk" + land, b"\xfd"):
        assert triage(junk, US) is Kind.DAMAGED, junk
