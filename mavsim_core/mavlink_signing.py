"""MAVLink 2 message signing shared by the flight controller's link and the ``gcs`` client.

pymavlink signs and checks packets (``MAVLink.signing``, a :class:`MAVLinkSigning`); this module
adds what both ends need around it, following https://mavlink.io/en/guide/message_signing.html:

* keys: 32 bytes; :func:`key_from_text` takes 64 hexadecimal digits as the key itself and
  anything else as a passphrase hashed with SHA-256, as MAVProxy's ``signing setup`` and
  QGroundControl 4.x do, so one passphrase gives the same key in all of them;
* timestamps: 10 µs units since 2015-01-01 00:00 UTC (:func:`timestamp_now`);
* :data:`UNSIGNED_ALLOWED`: the messages accepted unsigned while signing is on, PX4's list
  (RADIO_STATUS from telemetry radios, ADSB_VEHICLE and COLLISION: traffic warnings);
* :class:`SigningState`: one link's signing state with its refusals counted by reason;
* :class:`SigningParser`: pymavlink's parser with the order of the checks fixed: pymavlink
  records a stream's timestamp *before* it compares the signature, so one forged packet with a
  high timestamp would lock the real sender's stream out; here the signature is checked first.
"""

from __future__ import annotations

import hashlib
import hmac
import string
import time

from pymavlink.dialects.v20 import common as mavlink

KEY_BYTES = 32
SIGNING_EPOCH_UNIX_S = 1420070400  # 2015-01-01 00:00:00 UTC
TICKS_PER_S = 100_000  # timestamp unit: 10 µs
NEW_STREAM_MAX_AGE_TICKS = 6_000_000  # a first packet of a stream may be one minute behind our clock
SIGNATURE_BLOCK_BYTES = 13  # link id (1), timestamp (6), signature (6)

# Accepted unsigned even when signing is on (PX4's mavlink_sign_control list).
UNSIGNED_ALLOWED = frozenset(
    {mavlink.MAVLINK_MSG_ID_RADIO_STATUS, mavlink.MAVLINK_MSG_ID_ADSB_VEHICLE, mavlink.MAVLINK_MSG_ID_COLLISION}
)


def timestamp_now(unix_s: float | None = None) -> int:
    """The signing timestamp of a wall-clock time (default: now): 10 µs ticks since 2015-01-01 UTC."""
    t = time.time() if unix_s is None else unix_s
    return max(int((t - SIGNING_EPOCH_UNIX_S) * TICKS_PER_S), 0)


def key_from_text(text: str) -> bytes:
    """A 32-byte key: ``text`` itself if it is 64 hexadecimal digits, else SHA-256 of the passphrase
    (UTF-8; the same bytes as MAVProxy's ``signing setup`` for ASCII passphrases)."""
    if len(text) == 2 * KEY_BYTES and all(c in string.hexdigits for c in text):
        return bytes.fromhex(text)
    if not text:
        raise ValueError("an empty signing key or passphrase")
    return hashlib.sha256(text.encode("utf-8")).digest()


def is_disabling_key(key: bytes) -> bool:
    """True for the all-zero key, which SETUP_SIGNING uses to turn signing off."""
    return not any(key)


def signature_ok(key: bytes, packet: bytes | bytearray) -> bool:
    """True if the 6-byte signature at the end of a signed packet is the key's (SHA-256 of key + the rest)."""
    expected = hashlib.sha256(bytes(key) + bytes(packet[:-6])).digest()[:6]
    return hmac.compare_digest(expected, bytes(packet[-6:]))


def signing_link_id(packet: bytes | bytearray) -> int:
    """The link id of a signed packet."""
    return packet[-SIGNATURE_BLOCK_BYTES]


def signing_timestamp(packet: bytes | bytearray) -> int:
    """The timestamp (10 µs ticks since 2015) of a signed packet."""
    return int.from_bytes(packet[-12:-6], "little")


class SigningState(mavlink.MAVLinkSigning):
    """One link's signing state (key, outgoing timestamp and link id, the senders' stream timestamps)
    shared by its encoder and parser, with the refusals counted by reason.

    No key (the default): nothing is signed and nothing is checked.  With a key every packet sent
    is signed and a packet received is accepted only if correctly signed and newer than the last
    one of its stream, or, unsigned or not, if its message is in :data:`UNSIGNED_ALLOWED`.
    """

    def __init__(self, link_id: int = 0) -> None:
        super().__init__()
        self.link_id = link_id
        self.allow_unsigned_callback = self._allow_unsigned
        self.refused_unsigned = 0  # unsigned packets (MAVLink 1 included) not in UNSIGNED_ALLOWED
        self.refused_bad_signature = 0  # signed with another key, or damaged
        self.refused_replayed = 0  # correctly signed but not newer than the stream's last (or a stale new stream)
        self._check_failed = False  # the packet being decoded failed SigningParser.check_signature

    @property
    def enabled(self) -> bool:
        return self.secret_key is not None

    @property
    def refused(self) -> int:
        """Packets refused so far, all reasons."""
        return self.refused_unsigned + self.refused_bad_signature + self.refused_replayed

    def set_key(self, key: bytes | None, timestamp: int = 0) -> None:
        """Sign with ``key`` from now on (None or all zeros: stop signing and checking); the outgoing
        timestamp becomes the largest of ``timestamp``, the current one and the clock.  The senders'
        stream timestamps are forgotten: they belonged to the old key."""
        if key is None or is_disabling_key(key):
            self.secret_key, self.sign_outgoing = None, False
        else:
            if len(key) != KEY_BYTES:
                raise ValueError(f"a signing key has {KEY_BYTES} bytes, not {len(key)}")
            self.secret_key, self.sign_outgoing = bytes(key), True
        self.stream_timestamps: dict[tuple[int, int, int], int] = {}
        self.timestamp: int = max(int(self.timestamp), int(timestamp), timestamp_now())

    def keep_up_with_clock(self) -> None:
        """Move the outgoing timestamp up to the wall clock (pymavlink only adds one per packet)."""
        now = timestamp_now()
        if now > self.timestamp:
            self.timestamp = now

    def _allow_unsigned(self, mav: mavlink.MAVLink, msg_id: int) -> bool:
        """pymavlink's callback for a packet that is unsigned or failed the check: accept it or not."""
        failed, self._check_failed = self._check_failed, False
        if msg_id in UNSIGNED_ALLOWED:
            return True
        if not failed:  # (a failed check was counted by its reason already)
            self.refused_unsigned += 1
        return False


class SigningParser(mavlink.MAVLink):
    """pymavlink's parser whose signature check follows the spec's order (signature, then timestamp).

    Its ``signing`` must be a :class:`SigningState` (``parser.signing = state``); bad packets come
    back as BAD_DATA "Invalid signature" with ``robust_parsing``, counted in the state by reason.
    """

    signing: SigningState

    def check_signature(self, msgbuf: bytearray, srcSystem: int, srcComponent: int) -> bool:
        state = self.signing
        assert state.secret_key is not None
        if not signature_ok(state.secret_key, msgbuf):
            state.refused_bad_signature += 1
            state._check_failed = True
            return False
        timestamp = signing_timestamp(msgbuf)
        stream = (signing_link_id(msgbuf), srcSystem, srcComponent)
        last = state.stream_timestamps.get(stream)
        if last is not None:
            stale = timestamp <= last  # a replay, or older than what the stream already sent
        else:
            stale = timestamp + NEW_STREAM_MAX_AGE_TICKS < state.timestamp
        if stale:
            state.refused_replayed += 1
            state._check_failed = True
            return False
        state.stream_timestamps[stream] = timestamp
        state.timestamp = max(state.timestamp, timestamp)
        return True
