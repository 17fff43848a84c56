"""The lockstep link's fast MAVLink path gives exactly what pymavlink gives."""

from __future__ import annotations

import random

import pytest
from pymavlink.dialects.v20 import common as mavlink

from mavsim_core.sim_api_codec import MessageLayout, StreamParser, numeric_layout, x25_crc

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


def _edge_sensor(k: int) -> mavlink.MAVLink_message:
    """HIL_SENSOR with edge values: all zeros (the payload trims to one byte), NaN, infinities, the integer limits."""
    inf, nan = float("inf"), float("nan")
    rows = [
        (0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0, 0),
        (2**64 - 1, nan, inf, -inf, -0.0, 1e-45, 3.4e38, -3.4e38, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 2**32 - 1, 255),
        (1, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0, 1),  # only the last byte set
    ]
    return mavlink.MAVLink_hil_sensor_message(*rows[k % len(rows)])


def _edge_actuators(k: int) -> mavlink.MAVLink_message:
    controls = [float("nan"), -1.0, 1.0, float("inf")] + [0.0] * 12 if k % 2 else [0.0] * 16
    return mavlink.MAVLink_hil_actuator_controls_message(k % 2 * (2**64 - 1), controls, 255 * (k % 2), 2**64 - 1)


@pytest.mark.parametrize("make", [_edge_sensor, _edge_actuators, _gps])
def test_encode_matches_pymavlink_pack_on_edge_values(make):
    ours, theirs = mavlink.MAVLink(None, 255, 255), mavlink.MAVLink(None, 255, 255)
    layout = MessageLayout(type(make(0)))
    for k in range(6):
        msg = make(k)
        expected = msg.pack(theirs)
        theirs.seq = (theirs.seq + 1) % 256
        assert layout.encode(ours, [getattr(msg, name) for name in msg.fieldnames]) == expected


@pytest.mark.parametrize("make", [_edge_sensor, _edge_actuators, _sensor])
def test_decode_gives_the_message_pymavlink_gives(make):
    tx = mavlink.MAVLink(None, 7, 9)
    layout = MessageLayout(type(make(0)))
    for k in range(6):
        packet = make(k).pack(tx)
        tx.seq = (tx.seq + 1) % 256
        rx = mavlink.MAVLink(None, 1, 1)
        (theirs,) = rx.parse_buffer(packet)
        ours = layout.decode(bytearray(packet), packet[1])
        assert type(ours) is type(theirs)
        # NaN != NaN: compare the values' bytes (repr), every field and the header pymavlink reads
        assert repr(ours.to_dict()) == repr(theirs.to_dict())
        assert ours.get_header().__dict__ == theirs.get_header().__dict__
        assert ours.get_msgbuf() == theirs.get_msgbuf()
        assert ours._fieldnames == theirs._fieldnames and ours.get_type() == theirs.get_type()


def test_x25_crc_is_pymavlinks_crc():
    rng = random.Random(5)
    for n in (0, 1, 2, 61, 280):
        data = bytes(rng.randrange(256) for _ in range(n))
        assert x25_crc(data) == mavlink.x25crc(data).crc


_INT_RANGES = {
    f"{s}int{b}_t": ((0, 2**b - 1) if s == "u" else (-(2 ** (b - 1)), 2 ** (b - 1) - 1))
    for s in ("u", "")
    for b in (8, 16, 32, 64)
}


def _random_value(rng: random.Random, fieldtype: str, k: int):
    """A value of a MAVLink field type: the type's limits on the first rounds, then random ones."""
    if fieldtype in ("float", "double"):
        return (0.0, -1e30, 3.25e-3)[k] if k < 3 else rng.uniform(-1e6, 1e6)
    lo, hi = _INT_RANGES[fieldtype.replace("_mavlink_version", "")]
    return (lo, hi, 0)[k] if k < 3 else rng.randint(lo, hi)


def test_numeric_layouts_encode_every_numeric_message_as_pymavlink_packs_it():
    rng = random.Random(11)
    ours, theirs = mavlink.MAVLink(None, 42, 1), mavlink.MAVLink(None, 42, 1)
    classes = sorted(mavlink.mavlink_map.values(), key=lambda c: c.id)
    layouts = [(cls, numeric_layout(cls)) for cls in classes]
    assert sum(1 for _, layout in layouts if layout is not None) > 150
    assert numeric_layout(mavlink.MAVLink_statustext_message) is None  # char arrays: pymavlink packs those
    for cls, layout in layouts:
        if layout is None:
            continue
        for k in range(5):
            values = []
            for name, ftype, n in zip(cls.fieldnames, cls.fieldtypes, [cls.array_lengths[w] for w in cls.orders]):
                draw = [_random_value(rng, ftype, k) for _ in range(max(n, 1))]
                values.append(draw if n else draw[0])
            msg = cls(*values)
            expected = msg.pack(theirs)
            theirs.seq = (theirs.seq + 1) % 256
            assert layout.encode(ours, values) == expected, cls.msgname
            assert layout.values_of(msg) == tuple(values), cls.msgname  # what the ground link's send() encodes


def test_decode_gives_what_pymavlink_gives_for_every_message_the_flight_controller_frames_fast():
    """Each class the flight controller's simulator link frames by the fast path (its sensors, GPS, battery, the
    camera's LANDING_TARGET, the gimbal's attitude), with random values and the types' limits, trimmed or not."""
    from autopilot.mavlink.sim_link import FAST_FROM_SIM

    rng = random.Random(12)
    tx = mavlink.MAVLink(None, 1, 100)
    for cls in FAST_FROM_SIM:
        layout = numeric_layout(cls)
        assert layout is not None, cls.msgname
        for k in range(8):
            values = []
            for ftype, n in zip(cls.fieldtypes, [cls.array_lengths[w] for w in cls.orders]):
                draw = [_random_value(rng, ftype, k) if k != 3 else 0 for _ in range(max(n, 1))]  # k 3: all zeros
                values.append(draw if n else draw[0])
            packet = cls(*values).pack(tx)
            tx.seq = (tx.seq + 1) % 256
            (theirs,) = mavlink.MAVLink(None, 1, 1).parse_buffer(packet)
            (ours,) = StreamParser(mavlink.MAVLink(None, 1, 1), FAST_FROM_SIM).parse(packet)
            assert type(ours) is type(theirs)
            assert repr(ours.to_dict()) == repr(theirs.to_dict()), cls.msgname
            assert ours.get_header().__dict__ == theirs.get_header().__dict__
            assert ours.get_msgbuf() == theirs.get_msgbuf()
