"""Who the flight controller says it is: AUTOPILOT_VERSION's version, custom version and unique ids.

* ``flight_custom_version``: the git commit of the running code, packed as PX4 packs its own (since
  PX4 v1.14): the commit's first 16 hex digits read as a 64-bit number, sent little-endian, whose
  lowest 3 bytes are replaced by the vendor version (patch, minor, major: this project's own
  version).  Clients show the top 5 bytes as the git hash (MAVSDK's ``flight_sw_git_hash``: the
  commit's first 10 hex digits) and the low 3 as the vendor version.  The commit is read once at
  start-up from the checkout the ``autopilot`` package runs from (``.git/HEAD`` and the branch's ref
  file or ``packed-refs``; no subprocess); an installed package has no checkout: zeros.
* ``uid`` and ``uid2`` (MAVSDK's ``hardware_uid``): stable per instance and system id, the same on
  every start, never zero.  ``uid2`` is "MAVS", the instance and the system id (big-endian 32-bit
  each) padded to 18 bytes: its first 12 bytes are the ULog's ``sys_uuid`` (autopilot.flight_recorder;
  PX4 logs its board GUID, the same bytes as its uid2).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from functools import lru_cache
from importlib import metadata
from pathlib import Path

from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink.telemetry import CAPABILITIES, DEFAULT_FLIGHT_SW_VERSION

UID_TAG = 0x4D415653  # "MAVS"
UID2_BYTES = 18
DISTRIBUTION = "mavsim-flight"  # the package whose version is the vendor version
_HASH = re.compile(r"^[0-9a-f]{40}([0-9a-f]{24})?$")  # SHA-1 (or SHA-256) object name


@dataclass(frozen=True, slots=True)
class Identity:
    """The AUTOPILOT_VERSION fields of one flight controller (see the module docstring)."""

    flight_sw_version: int = DEFAULT_FLIGHT_SW_VERSION
    middleware_sw_version: int = 0
    os_sw_version: int = 0
    board_version: int = 0
    flight_custom_version: bytes = bytes(8)
    vendor_id: int = 0
    product_id: int = 0
    uid: int = 0
    uid2: bytes = bytes(UID2_BYTES)


def git_head(root: Path) -> str | None:
    """The commit checked out in ``root`` (40 hex digits), read from its ``.git`` (a directory, or a
    worktree's ``gitdir:`` file); None when ``root`` is no checkout or the files cannot be read."""
    try:
        git = root / ".git"
        if git.is_file():  # a worktree or submodule: "gitdir: <path>"
            text = git.read_text().strip()
            if not text.startswith("gitdir:"):
                return None
            git = (root / text[len("gitdir:") :].strip()).resolve()
        head = (git / "HEAD").read_text().strip()
        if not head.startswith("ref:"):
            return head.lower() if _HASH.match(head.lower()) else None  # detached HEAD
        ref = head[len("ref:") :].strip()
        common = git
        if (git / "commondir").is_file():  # a worktree keeps its branches in the main .git
            common = (git / (git / "commondir").read_text().strip()).resolve()
        for base in (git, common):
            if (base / ref).is_file():
                value = (base / ref).read_text().strip().lower()
                return value if _HASH.match(value) else None
        for base in (git, common):
            packed = base / "packed-refs"
            if packed.is_file():
                for line in packed.read_text().splitlines():
                    parts = line.split()
                    if len(parts) == 2 and parts[1] == ref and _HASH.match(parts[0].lower()):
                        return parts[0].lower()
    except OSError:
        return None
    return None


def vendor_version() -> tuple[int, int, int]:
    """This project's version (major, minor, patch) from its installed metadata; (0, 0, 0) if unknown."""
    try:
        parts = re.findall(r"\d+", metadata.version(DISTRIBUTION))
    except metadata.PackageNotFoundError:
        return (0, 0, 0)
    nums = [min(int(p), 255) for p in parts[:3]] + [0, 0, 0]
    return (nums[0], nums[1], nums[2])


def custom_version(commit: str | None, vendor: tuple[int, int, int] = (0, 0, 0)) -> bytes:
    """The 8 bytes of ``flight_custom_version`` as PX4 packs them (module docstring); zeros without a commit
    (the vendor version is then meaningless too)."""
    if commit is None:
        return bytes(8)
    value = int(commit[:16], 16) & 0xFFFFFFFFFF000000
    major, minor, patch = vendor
    value |= major << 16 | minor << 8 | patch
    return value.to_bytes(8, "little")


@lru_cache(maxsize=1)
def running_commit() -> str | None:
    """The git commit (40 hex digits) of the code running now, None outside a checkout (read once per
    process): AUTOPILOT_VERSION's custom version and the ULog's ``ver_sw``."""
    return git_head(Path(__file__).resolve().parents[2])  # autopilot/mavlink/identity.py -> the checkout's root


def running_custom_version() -> bytes:
    """``flight_custom_version`` of the code running now."""
    return custom_version(running_commit(), vendor_version())


def instance_uid(instance: int, sysid: int) -> int:
    """AUTOPILOT_VERSION.uid: "MAVS" << 32 | instance << 8 | system id (non-zero, stable)."""
    return (UID_TAG << 32) | (instance & 0xFFFFFF) << 8 | (sysid & 0xFF)


def instance_uid2(instance: int, sysid: int) -> bytes:
    """AUTOPILOT_VERSION.uid2 (18 bytes): "MAVS", instance, system id (big-endian uint32 each), zeros."""
    raw = b"".join((x & 0xFFFFFFFF).to_bytes(4, "big") for x in (UID_TAG, instance, sysid))
    return raw.ljust(UID2_BYTES, b"\x00")


def instance_identity(instance: int, sysid: int, **given: object) -> Identity:
    """The identity of ``instance`` / ``sysid``: the running code's custom version and this instance's ids,
    unless given (``given``: any :class:`Identity` field)."""
    fields: dict[str, object] = dict(
        flight_custom_version=running_custom_version(),
        uid=instance_uid(instance, sysid),
        uid2=instance_uid2(instance, sysid),
    )
    fields.update({k: v for k, v in given.items() if v is not None})
    return Identity(**fields)  # type: ignore[arg-type]


def autopilot_version(identity: Identity, capabilities: int = CAPABILITIES) -> mavlink.MAVLink_message:
    """AUTOPILOT_VERSION of ``identity`` with ``capabilities`` (MAV_PROTOCOL_CAPABILITY bits: by default what
    the link implements, :data:`autopilot.mavlink.telemetry.CAPABILITIES`)."""
    return mavlink.MAVLink_autopilot_version_message(
        capabilities=capabilities,
        flight_sw_version=identity.flight_sw_version,
        middleware_sw_version=identity.middleware_sw_version,
        os_sw_version=identity.os_sw_version,
        board_version=identity.board_version,
        flight_custom_version=list(identity.flight_custom_version[:8].ljust(8, b"\x00")),
        middleware_custom_version=[0] * 8,
        os_custom_version=[0] * 8,
        vendor_id=identity.vendor_id,
        product_id=identity.product_id,
        uid=identity.uid,
        uid2=list(identity.uid2[:UID2_BYTES].ljust(UID2_BYTES, b"\x00")),
    )
