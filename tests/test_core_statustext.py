"""mavsim_core.statustext: a text of any length as STATUSTEXT chunks of at most 50 bytes.

Receivers join chunks with the same ``id`` in ``chunk_seq`` order and take a chunk without a
NUL (a full 50 bytes) as "more to come"; a single-message text has id 0.
"""

from __future__ import annotations

import os

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import common as mavlink

from mavsim_core.statustext import STATUSTEXT_LEN, StatustextChunker, split_statustext


@pytest.mark.parametrize(
    "length, sizes",
    [
        (0, [0]),
        (1, [1]),
        (49, [49]),
        (50, [50]),  # one message: no terminator needed
        (51, [50, 1]),
        (99, [50, 49]),
        (100, [50, 50, 0]),  # the last chunk is full: an empty chunk ends the text
        (150, [50, 50, 50, 0]),
        (151, [50, 50, 50, 1]),
    ],
)
def test_chunk_sizes(length, sizes):
    chunks = split_statustext("x" * length)
    assert [len(c) for c in chunks] == sizes
    assert b"".join(chunks) == b"x" * length


def test_utf8_is_never_cut_inside_a_character():
    for text in ("a" + "\u20ac" * 40, "\u00e9" * 60, "\U0001f681 helicopter " * 8, "x" * 48 + "\u20ac" + "y"):
        chunks = split_statustext(text)
        assert all(len(c) <= STATUSTEXT_LEN for c in chunks)
        assert [c.decode("utf-8") for c in chunks]  # each chunk decodes on its own
        assert b"".join(chunks).decode("utf-8") == text
    # "x" * 48 + a 3-byte euro sign: 51 bytes, so the euro sign starts the second chunk
    assert [len(c) for c in split_statustext("x" * 48 + "\u20ac")] == [48, 3]


def received(msgs: list) -> str:
    """What a MAVLink 2 receiver reassembles: chunks of one id joined in chunk_seq order, up to the NUL."""
    joined = b"".join(
        bytes(m.text) if isinstance(m.text, bytes) else m.text.encode() for m in sorted(msgs, key=lambda m: m.chunk_seq)
    )
    return joined.split(b"\0", 1)[0].decode("utf-8")


def test_messages_share_an_id_and_reassemble_after_the_wire():
    chunker = StatustextChunker()
    text = "Preflight Fail: " + "the quick brown fox jumps over the lazy dog " * 3
    msgs = chunker.messages(mavlink.MAV_SEVERITY_CRITICAL, text)
    assert len(msgs) == 3
    assert {m.id for m in msgs} == {1} and [m.chunk_seq for m in msgs] == [0, 1, 2]
    assert all(m.severity == mavlink.MAV_SEVERITY_CRITICAL for m in msgs)
    sender, receiver = mavlink.MAVLink(None, 1, 1), mavlink.MAVLink(None, 255, 190)
    wire = b"".join(m.pack(sender) for m in msgs)
    parsed = receiver.parse_buffer(wire)
    assert [p.get_type() for p in parsed] == ["STATUSTEXT"] * 3
    assert received(parsed) == text


def test_single_message_has_id_0_and_does_not_use_an_id():
    chunker = StatustextChunker()
    (msg,) = chunker.messages(mavlink.MAV_SEVERITY_INFO, "Takeoff detected")
    assert (msg.id, msg.chunk_seq, msg.text) == (0, 0, "Takeoff detected")
    assert {m.id for m in chunker.messages(mavlink.MAV_SEVERITY_INFO, "y" * 60)} == {1}  # the first id is 1


def test_ids_count_up_and_wrap_from_65535_to_1():
    chunker = StatustextChunker()
    ids = [chunker.messages(mavlink.MAV_SEVERITY_INFO, "z" * 70)[0].id for _ in range(3)]
    assert ids == [1, 2, 3]
    chunker._id = 65534  # as after 65534 long texts
    ids = [chunker.messages(mavlink.MAV_SEVERITY_INFO, "z" * 70)[0].id for _ in range(3)]
    assert ids == [65535, 1, 2]  # never 0: that means "not chunked"
