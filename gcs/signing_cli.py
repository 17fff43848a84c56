"""``gcs signing`` and ``--signing-key``: MAVLink 2 message signing from the command line.

::

    gcs signing setup "a long passphrase"         # the vehicle's first key (SETUP_SIGNING, sent unsigned)
    gcs --signing-key "a long passphrase" arm     # from then on every command signed with it
    gcs --signing-key OLD signing setup NEW       # a new key: SETUP_SIGNING signed with the current one
    gcs --signing-key KEY signing disable         # the all-zero key: the vehicle stops signing
    gcs signing setup                             # a random key, printed in hex

A key is 64 hexadecimal digits, or a passphrase hashed with SHA-256 as MAVProxy's
``signing setup`` and QGroundControl 4.x do (:func:`mavsim_core.mavlink_signing.key_from_text`), so
the same passphrase works in all three.  ``--signing-key`` may also come from the environment
variable GCS_SIGNING_KEY (command lines are visible to other users in ``ps``).  With a key, ``gcs``
signs everything it sends and accepts from the vehicle only what is signed with that key.

``setup`` and ``disable`` wait until the vehicle shows the change: a message signed with the new
key (setup) or an unsigned one (disable).  Exit codes as for every ``gcs`` command: 0 done,
1 refused here (the vehicle has a key and ``--signing-key`` was not given), 3 no answer (the
vehicle did not take it: a SETUP_SIGNING that is not signed with its current key is ignored).
"""

from __future__ import annotations

import argparse
import os
import secrets
import sys

from mavsim_core.mavlink_signing import KEY_BYTES, is_disabling_key, key_from_text, timestamp_now

from .client import VehicleClient, mavlink
from .errors import EXIT_OK, EXIT_REFUSED

KEY_ENV = "GCS_SIGNING_KEY"


def _key(text: str) -> bytes:
    try:
        return key_from_text(text)
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def add_signing_key_option(parser: argparse.ArgumentParser) -> None:
    """``--signing-key KEY`` (default: $GCS_SIGNING_KEY), parsed to 32 bytes."""
    parser.add_argument(
        "--signing-key",
        type=_key,
        default=os.environ.get(KEY_ENV) or None,
        metavar="KEY",
        help="sign with this MAVLink 2 key: 64 hex digits, or a passphrase hashed with SHA-256 as MAVProxy's "
        f"'signing setup' does (default: ${KEY_ENV}); see 'gcs signing -h'",
    )


def add_signing_parser(sub: argparse._SubParsersAction) -> None:
    """The ``signing`` sub-command and its own sub-commands."""
    p = sub.add_parser("signing", help="set up or turn off MAVLink 2 message signing on the vehicle (SETUP_SIGNING)")
    ssub = p.add_subparsers(dest="signing_command", required=True, metavar="setup|disable")
    s = ssub.add_parser("setup", help="give the vehicle a key; with a key already set, --signing-key must be it")
    s.add_argument("key", nargs="?", type=_key, metavar="KEY", help="64 hex digits or a passphrase (default: random)")
    ssub.add_parser("disable", help="remove the vehicle's key (--signing-key: the current one)")


def has_signature(msg) -> bool:
    """True if the message came signed (``get_signed()`` tells only a receiver that checked it)."""
    buf = msg.get_msgbuf()
    return len(buf) > 2 and buf[0] == mavlink.PROTOCOL_MARKER_V2 and bool(buf[2] & mavlink.MAVLINK_IFLAG_SIGNED)


def run_signing_command(client: VehicleClient, args: argparse.Namespace) -> int:
    """Run ``gcs signing setup|disable``; the exit code (no answer propagates as NoAnswer, a GcsTimeout)."""
    heartbeat = client.latest("HEARTBEAT")
    if args.signing_key is None and heartbeat is not None and has_signature(heartbeat):
        print(
            f"gcs: signing {args.signing_command}: the vehicle signs its messages, so it has a key already; "
            "give the current one with --signing-key",
            file=sys.stderr,
        )
        return EXIT_REFUSED
    sysid = client.target_system
    if args.signing_command == "disable":
        _send(client, bytes(KEY_BYTES), 0)
        client.set_signing_key(None)
        _wait_for(client, signed=False, what="an unsigned message (signing off)")
        print(f"signing off on system {sysid}: it accepts unsigned commands again")
        return EXIT_OK
    key = args.key if args.key is not None else secrets.token_bytes(KEY_BYTES)
    if is_disabling_key(key):
        print("gcs: signing setup: the all-zero key turns signing off; use 'gcs signing disable'", file=sys.stderr)
        return EXIT_REFUSED
    _send(client, key, timestamp_now())
    client.set_signing_key(key)
    _wait_for(client, signed=True, what="a message signed with the new key")
    print(f"signing on for system {sysid}: commands must be signed with this key (gcs --signing-key ...)")
    if args.key is None:
        print(f"key: {key.hex()}")
    return EXIT_OK


def _send(client: VehicleClient, key: bytes, initial_timestamp: int) -> None:
    """SETUP_SIGNING to the vehicle (signed with the connection's current key, if any)."""
    client.conn.mav.setup_signing_send(client.target_system, client.target_component, list(key), initial_timestamp)


def _wait_for(client: VehicleClient, *, signed: bool, what: str) -> None:
    """Wait for a message from the vehicle that is signed (checked with the connection's key) or unsigned."""
    seen: list[bool] = []

    def note(msg) -> None:
        if has_signature(msg) == signed:
            seen.append(True)

    client.add_listener(note)
    try:
        client.wait_until(lambda: seen, None, what, describe=False)
    finally:
        client.remove_listener(note)
