"""Component metadata (https://mavlink.io/en/services/component_metadata.html): the parameter
descriptions a ground station shows, served over MAVLink FTP.

* COMPONENT_METADATA (397), and the older COMPONENT_INFORMATION (395) for clients that fall back to
  it, are sent on MAV_CMD_REQUEST_MESSAGE: the ``mftp://`` URI and CRC32 of the *general* metadata
  file (:data:`GENERAL_URI`).
* The general file (schema ``general.schema.json``, version 1) names the parameter metadata file with
  its URI and CRC32 (``metadataTypes``: COMP_METADATA_TYPE_PARAMETER).
* The parameter file follows QGroundControl's parameter metadata schema (version 1): per parameter
  ``name``, ``type`` (``Int32`` / ``Float``), ``shortDesc``, ``longDesc``, ``units``, ``min``, ``max``,
  ``default``, ``decimalPlaces``, ``rebootRequired`` and ``group`` (PX4's group names), built from the
  parameter store (declared ranges and units, the vehicle's defaults).

The files are built once at start-up (the parameter set is fixed from boot, as the protocol assumes),
uncompressed JSON (the protocol allows ``.xz``; over a local link it gains nothing), and their CRC32
is MAVLink's (:func:`mavsim_core.mavftp.crc32`), which MAVSDK and QGroundControl use as cache keys.
pymavlink 2.4.50's common dialect lacks both messages, so they are defined here with the wire format
and CRC extra of MAVLink's common.xml (tests check them against pymavlink's own generator).
"""

from __future__ import annotations

import json
import struct
from dataclasses import dataclass

from pymavlink.dialects.v20 import common as mavlink

from autopilot.parameters import ParameterStore
from mavsim_core.mavftp import crc32
from mavsim_core.param_types import ParamType

MOUNT = "component_metadata"  # the FTP directory of the files
GENERAL_FILE, PARAMETER_FILE = "general.json", "parameters.json"
GENERAL_URI = f"mftp:///{MOUNT}/{GENERAL_FILE}"
PARAMETER_URI = f"mftp:///{MOUNT}/{PARAMETER_FILE}"
COMP_METADATA_TYPE_PARAMETER = 1
MSG_ID_COMPONENT_INFORMATION, MSG_ID_COMPONENT_METADATA = 395, 397
MAX_DECIMALS = 6
# PX4's parameter groups by name prefix (QGroundControl's parameter editor lists parameters by group).
GROUPS = {
    "ATT": "Attitude Q estimator", "BAT": "Battery Calibration", "COM": "Commander", "EKF2": "EKF2",
    "FLW": "Follow target", "GF": "Geofence", "IMU": "Sensors", "LNDMC": "Land Detector",
    "LTEST": "Landing target Estimator", "MC": "Multicopter Attitude Control", "MIS": "Mission",
    "MPC": "Multicopter Position Control", "NAV": "Mission", "PLD": "Precision Land", "RTL": "Return Mode",
    "SDLOG": "SD Logging", "SYS": "System",
}  # fmt: skip


def _decimals(x: float) -> int:
    """Decimal places needed to show ``x`` (up to MAX_DECIMALS)."""
    text = f"{abs(x):.{MAX_DECIMALS}f}".rstrip("0")
    return len(text) - text.index(".") - 1


def _descriptions(description: str, reboot_required: bool) -> dict[str, str]:
    """shortDesc (up to the first colon or sentence end) and, when there is more, longDesc."""
    cut = min((i for i in (description.find(": "), description.find(". ")) if i > 0), default=-1)
    short = description[:cut] if cut > 0 else description.rstrip(".")
    long = description + (" Applies at the next start." if reboot_required else "")
    return {"shortDesc": short, "longDesc": long} if long != short else {"shortDesc": short}


def parameter_metadata(store: ParameterStore) -> dict:
    """The parameter metadata document of every parameter in ``store``."""
    params = []
    for name in store.names():
        d = store.definition(name)
        is_int = d.ptype == ParamType.INT32
        default = store.default(name)
        entry: dict = {"name": name, "type": "Int32" if is_int else "Float"}
        entry.update(_descriptions(d.description, d.reboot_required))
        if d.unit not in ("", "-"):
            entry["units"] = d.unit
        entry.update(
            min=int(d.min) if is_int else d.min,
            max=int(d.max) if is_int else d.max,
            default=int(default) if is_int else default,
            decimalPlaces=0 if is_int else max(1, *(_decimals(v) for v in (default, d.min, d.max))),
            rebootRequired=d.reboot_required,
            group=GROUPS.get(name.split("_", 1)[0], name.split("_", 1)[0]),
        )
        params.append(entry)
    return {"version": 1, "parameters": params}


def general_metadata(parameters: bytes, vendor: str, model: str, firmware: str) -> dict:
    """The general metadata document: who we are and where the parameter metadata is."""
    return {
        "version": 1,
        "vendorName": vendor,
        "modelName": model,
        "firmwareVersion": firmware,
        "metadataTypes": [{"type": COMP_METADATA_TYPE_PARAMETER, "uri": PARAMETER_URI, "fileCrc": crc32(parameters)}],
    }


@dataclass(frozen=True)
class MetadataFiles:
    """The files served under :data:`MOUNT` (name -> content) and the general file's CRC32."""

    files: dict[str, bytes]
    general_crc: int


def metadata_files(store: ParameterStore, vendor: str, model: str, firmware: str) -> MetadataFiles:
    """Build the component metadata files (``firmware``: ``major.minor.patch``)."""
    parameters = json.dumps(parameter_metadata(store), indent=1).encode()
    general = json.dumps(general_metadata(parameters, vendor, model, firmware), indent=1).encode()
    return MetadataFiles({GENERAL_FILE: general, PARAMETER_FILE: parameters}, crc32(general))


def firmware_version(flight_sw_version: int) -> str:
    """``major.minor.patch`` of AUTOPILOT_VERSION's ``flight_sw_version`` (PX4's byte layout)."""
    return f"{flight_sw_version >> 24 & 0xFF}.{flight_sw_version >> 16 & 0xFF}.{flight_sw_version >> 8 & 0xFF}"


# ---------------------------------------------------------------------- the two messages


def _uri(text: str) -> bytes:
    raw = text.encode()
    if len(raw) >= 100:
        raise ValueError(f"URI longer than 99 bytes: {text}")
    return raw


class ComponentMetadataMessage(mavlink.MAVLink_message):
    """COMPONENT_METADATA (397): the general metadata file's URI and CRC32."""

    id = MSG_ID_COMPONENT_METADATA
    msgname = "COMPONENT_METADATA"
    fieldnames = ordered_fieldnames = ["time_boot_ms", "file_crc", "uri"]
    fieldtypes = ["uint32_t", "uint32_t", "char"]
    fielddisplays_by_name: dict[str, str] = {}
    fieldenums_by_name: dict[str, str] = {}
    fieldunits_by_name = {"time_boot_ms": "ms"}
    native_format = bytearray(b"<IIc")
    orders = [0, 1, 2]
    lengths = [1, 1, 1]
    array_lengths = [0, 0, 100]
    crc_extra = 182
    unpacker = struct.Struct("<II100s")
    instance_field = None
    instance_offset = -1

    def __init__(self, time_boot_ms: int, file_crc: int, uri: str) -> None:
        super().__init__(self.id, self.msgname)
        self._fieldnames = self.fieldnames
        self._instance_field, self._instance_offset = None, -1
        self.time_boot_ms, self.file_crc, self.uri = time_boot_ms, file_crc, uri

    def pack(self, mav: mavlink.MAVLink, force_mavlink1: bool = False) -> bytes:
        payload = self.unpacker.pack(self.time_boot_ms, self.file_crc, _uri(self.uri))
        return self._pack(mav, self.crc_extra, payload, force_mavlink1=force_mavlink1)


class ComponentInformationMessage(mavlink.MAVLink_message):
    """COMPONENT_INFORMATION (395, deprecated for COMPONENT_METADATA): the general metadata file's URI
    and CRC32, no peripherals file."""

    id = MSG_ID_COMPONENT_INFORMATION
    msgname = "COMPONENT_INFORMATION"
    fieldnames = [
        "time_boot_ms", "general_metadata_file_crc", "general_metadata_uri", "peripherals_metadata_file_crc",
        "peripherals_metadata_uri",
    ]  # fmt: skip
    ordered_fieldnames = [
        "time_boot_ms", "general_metadata_file_crc", "peripherals_metadata_file_crc", "general_metadata_uri",
        "peripherals_metadata_uri",
    ]  # fmt: skip
    fieldtypes = ["uint32_t", "uint32_t", "char", "uint32_t", "char"]
    fielddisplays_by_name: dict[str, str] = {}
    fieldenums_by_name: dict[str, str] = {}
    fieldunits_by_name = {"time_boot_ms": "ms"}
    native_format = bytearray(b"<IIIcc")
    orders = [0, 1, 3, 2, 4]
    lengths = [1, 1, 1, 1, 1]
    array_lengths = [0, 0, 0, 100, 100]
    crc_extra = 0
    unpacker = struct.Struct("<III100s100s")
    instance_field = None
    instance_offset = -1

    def __init__(self, time_boot_ms: int, general_metadata_file_crc: int, general_metadata_uri: str) -> None:
        super().__init__(self.id, self.msgname)
        self._fieldnames = self.fieldnames
        self._instance_field, self._instance_offset = None, -1
        self.time_boot_ms = time_boot_ms
        self.general_metadata_file_crc, self.general_metadata_uri = general_metadata_file_crc, general_metadata_uri
        self.peripherals_metadata_file_crc, self.peripherals_metadata_uri = 0, ""

    def pack(self, mav: mavlink.MAVLink, force_mavlink1: bool = False) -> bytes:
        payload = self.unpacker.pack(
            self.time_boot_ms, self.general_metadata_file_crc, 0, _uri(self.general_metadata_uri), b""
        )
        return self._pack(mav, self.crc_extra, payload, force_mavlink1=force_mavlink1)


def metadata_message(msg_id: int, general_crc: int, now_us: int) -> mavlink.MAVLink_message | None:
    """COMPONENT_METADATA or COMPONENT_INFORMATION (by ``msg_id``) at simulated time ``now_us``; None for
    another id."""
    time_boot_ms = now_us // 1000 & 0xFFFFFFFF
    if msg_id == MSG_ID_COMPONENT_METADATA:
        return ComponentMetadataMessage(time_boot_ms, general_crc, GENERAL_URI)
    if msg_id == MSG_ID_COMPONENT_INFORMATION:
        return ComponentInformationMessage(time_boot_ms, general_crc, GENERAL_URI)
    return None
