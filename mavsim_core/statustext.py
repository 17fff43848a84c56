"""STATUSTEXT chunking (MAVLink 2): a text of any length as 50-byte chunks sharing an id.

Used by every MAVLink component of the stack (the flight controller and the simulator's
parameter service).  Receivers join chunks with the same ``id`` in ``chunk_seq`` order and
take a chunk without a NUL (a full 50 bytes) as "more to come".
"""

from __future__ import annotations

from pymavlink.dialects.v20 import common as mavlink

STATUSTEXT_LEN = 50  # bytes of text in one STATUSTEXT
UINT16_MAX = 65535


def split_statustext(text: str) -> list[bytes]:
    """Cut a text into STATUSTEXT chunks of at most 50 bytes (UTF-8, never inside a character).

    A multi-chunk text whose last chunk is full gets an empty terminating chunk, since
    receivers take a chunk without a NUL as "more to come".
    """
    chunks: list[bytes] = []
    current = b""
    for ch in text:
        b = ch.encode("utf-8")
        if len(current) + len(b) > STATUSTEXT_LEN:
            chunks.append(current)
            current = b""
        current += b
    chunks.append(current)
    if len(chunks) > 1 and len(chunks[-1]) == STATUSTEXT_LEN:
        chunks.append(b"")
    return chunks


class StatustextChunker:
    """STATUSTEXT messages for a text: one, or its 50-byte chunks sharing an id (1..65535, cycling)."""

    def __init__(self) -> None:
        self._id = 0

    def messages(self, severity: int, text: str) -> list[mavlink.MAVLink_statustext_message]:
        chunks = split_statustext(text)
        chunk_id = 0
        if len(chunks) > 1:
            self._id = self._id % UINT16_MAX + 1
            chunk_id = self._id
        return [mavlink.MAVLink_statustext_message(severity, chunk, chunk_id, seq) for seq, chunk in enumerate(chunks)]
