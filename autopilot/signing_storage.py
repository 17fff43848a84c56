"""The MAVLink 2 signing key and its last timestamp across restarts (``--state-dir``).

One file per vehicle and instance, ``DIR/<vehicle>-<instance>.signing``, beside the parameter
and plan files, readable by its owner only (mode 0600: it holds the secret)::

    # MAVLink 2 signing key of quad_x instance 0: keep it secret
    key 3f2a...(64 hexadecimal digits)
    timestamp 31536000000000

``timestamp`` is the signing clock (10 µs ticks since 2015-01-01 UTC) when the file was written:
at start-up the link's clock starts at the larger of it and the wall clock, as the signing spec
asks, so a wall clock set back cannot make old packets valid again.  Written atomically (a
crash leaves the old or the new file); no file means no key (signing off).  The key is never
written anywhere else: not in parameters, logs or STATUSTEXTs.
"""

from __future__ import annotations

import os
from pathlib import Path

from mavsim_core.mavlink_signing import KEY_BYTES
from params.param_file import atomic_write_text


def signing_file(state_dir: str | Path, vehicle_name: str, instance: int) -> Path:
    """Where the signing key of a vehicle and instance is kept."""
    return Path(state_dir) / f"{vehicle_name}-{instance}.signing"


def save_signing(path: Path, key: bytes, timestamp: int, what: str = "the vehicle") -> None:
    """Write the key and timestamp atomically, readable by the owner only (the temporary file that
    replaces the old one is created with mode 0600)."""
    text = f"# MAVLink 2 signing key of {what}: keep it secret\nkey {key.hex()}\ntimestamp {int(timestamp)}\n"
    atomic_write_text(path, text)
    os.chmod(path, 0o600)  # (already so; says it where it is checked)


def remove_signing(path: Path) -> None:
    """Forget the key (signing disabled): remove the file if there is one."""
    try:
        path.unlink()
    except FileNotFoundError:
        pass


def load_signing(path: Path) -> tuple[bytes, int] | None:
    """(key, timestamp) saved in ``path``, None when there is no file; ValueError saying what is wrong
    with a broken one."""
    if not path.exists():
        return None
    try:
        lines = path.read_text().splitlines()
    except (OSError, UnicodeDecodeError) as exc:
        raise ValueError(f"{path}: {exc}") from exc
    fields = dict(line.split(None, 1) for line in lines if line.strip() and not line.startswith("#") and " " in line)
    try:
        key = bytes.fromhex(fields["key"].strip())
        timestamp = int(fields.get("timestamp", "0"))
    except (KeyError, ValueError) as exc:
        raise ValueError(f"{path}: no 'key <64 hex digits>' line or a bad timestamp ({exc})") from exc
    if len(key) != KEY_BYTES or timestamp < 0:
        raise ValueError(f"{path}: the key must be {KEY_BYTES} bytes and the timestamp >= 0")
    return key, timestamp
