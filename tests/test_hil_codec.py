"""The lockstep link's fast MAVLink path gives exactly what pymavlink gives."""

from __future__ import annotations

import random

import pytest
from pymavlink.dialects.v20 import common as mavlink

from mavsim_core.sim_api_codec import MessageLayout, StreamParser

FAST = (mavlink.MAVLink_hil_sensor_message, mavlink.MAVLink_hil_actuator_controls_message)


def _sensor(k: int) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_hil_sensor_message(
        4000 * k, 0.1 * k, -0.2, -9.8, 0.01, -0.02, 0.003 * k, 0.21, 0.0, 0.43, 955.5, 0.0, 5.0 + k, 20.0, 0x1FFF, 0
    )


def _actuators(k: int, armed: bool = True) -> mavlink.MAVLink_message:
    controls = [0.5 + 0.01 * k, 0.51, 0.0, 0.49] + [0.0] * 12
    return mavlink.MAVLink_hil_actuator_controls_message(4000 * k, controls, 128 if armed else 0, 0)


def _gps(k: int) -> mavlink.MAVLink_message:
    return mavlink.MAVLink_hil_gps_message(4000 * k, 3, 473977420, 85455940, 488000, 30, 40, 0, 0, 0, 0, 0, 12, 0, 0)


@pytest.mark.parametrize("make", [_sensor, _actuators, lambda k: _actuators(k, armed=False)])
def test_encode_matches_pymavlink_pack(make):
    ours, theirs = mavlink.MAVLink(None, 1, 51), mavlink.MAVLink(None, 1, 51)
    layout = MessageLayout(type(make(0)))
    for k in range(300):  # the sequence number wraps past 255
        msg = make(k)
        expected = msg.pack(theirs)
        theirs.seq = (theirs.seq + 1) % 256
        values = [getattr(msg, name) for name in msg.fieldnames]
        assert layout.encode(ours, values) == expected
    assert ours.seq == theirs.seq


def test_stream_parser_matches_pymavlink_on_split_mixed_and_damaged_streams():
    rng = random.Random(1)
    tx = mavlink.MAVLink(None, 1, 51)
    stream = bytearray()
    for k in range(200):
        for msg in (_gps(k) if k % 7 == 0 else None, _sensor(k), _actuators(k)):
            if msg is not None:
                stream += msg.pack(tx)
                tx.seq = (tx.seq + 1) % 256
        if k % 50 == 25:
            stream += b"\x00\x13garbage\xfd"  # stray bytes, one of them a start marker
        if k == 120:
            damaged = bytearray(_sensor(k).pack(tx))
            damaged[20] ^= 0xFF
            stream += damaged

    def run(parse) -> list:  # chunked differently on each run: the result must not depend on it
        out, i = [], 0
        while i < len(stream):
            step = rng.choice([1, 3, 17, 64, 300])
            out.extend(parse(bytes(stream[i : i + step])))
            i += step
        return out

    reference = mavlink.MAVLink(None, 1, 1)
    reference.robust_parsing = True
    expected = run(lambda data: reference.parse_buffer(data) or [])
    slow = mavlink.MAVLink(None, 1, 1)
    slow.robust_parsing = True
    got = run(StreamParser(slow, FAST).parse)
    good = [m for m in expected if m.get_type() != "BAD_DATA"]
    assert [m.get_type() for m in got if m.get_type() != "BAD_DATA"] == [m.get_type() for m in good]
    # A stray start marker makes pymavlink read a bogus header and skip what follows it; the
    # fast path hands such bytes to pymavlink, so it loses exactly the same packets.
    assert len(good) > 400
    for a, b in zip([m for m in got if m.get_type() != "BAD_DATA"], good):
        assert a.to_dict() == b.to_dict()
        assert (a.get_srcSystem(), a.get_srcComponent(), a.get_seq()) == (
            b.get_srcSystem(),
            b.get_srcComponent(),
            b.get_seq(),
        )
    assert any(m.get_type() == "BAD_DATA" for m in got)  # the damage is reported, as pymavlink does
