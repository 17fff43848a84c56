"""MAVLink FTP and component metadata (docs/ftp_and_metadata.md): built once at start-up, served by the link.

The FTP tree (:class:`autopilot.mavlink.ftp_files.FileTree`), read-only:

* ``/log``: the flight logs directory (``--log-dir``; absent with ``--no-log``);
* ``/component_metadata``: ``general.json`` and ``parameters.json``
  (:mod:`autopilot.mavlink.component_metadata`).

COMPONENT_METADATA and COMPONENT_INFORMATION are answered to MAV_CMD_REQUEST_MESSAGE: the process adds
:attr:`FileServices.ftp` to the link's services and :attr:`FileServices.requestable` to its ``requestable``
table (``autopilot/link_setup.py``).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Callable

from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink import component_metadata as cm
from autopilot.mavlink.ftp_files import FileTree
from autopilot.mavlink.ftp_service import FtpService
from autopilot.mavlink.telemetry import DEFAULT_FLIGHT_SW_VERSION
from autopilot.parameters import ParameterStore

if TYPE_CHECKING:
    from autopilot.mavlink.endpoint import LinkEndpoint

VENDOR = "mavsim"
LOG_MOUNT = "log"


@dataclass(frozen=True)
class FileServices:
    """The FTP service, and the component metadata messages (message id -> ``send(endpoint)`` -> MAV_RESULT)."""

    ftp: FtpService
    requestable: dict[int, Callable[[LinkEndpoint], int]]


def file_services(
    params: ParameterStore,
    log_dir: Path | None,
    model: str,
    now_us: Callable[[], int],
    flight_sw_version: int = DEFAULT_FLIGHT_SW_VERSION,
) -> FileServices:
    """FTP (``log_dir``: the flight logs, None without) and the component metadata of ``params`` (``model``: the
    vehicle's name); ``now_us()``: the link's simulated time (µs)."""
    meta = cm.metadata_files(params, VENDOR, model, cm.firmware_version(flight_sw_version))
    service = FtpService(FileTree({LOG_MOUNT: log_dir}, {cm.MOUNT: meta.files}), now_us)

    def send(ep: LinkEndpoint, msg_id: int) -> int:
        msg = cm.metadata_message(msg_id, meta.general_crc, now_us())
        assert msg is not None
        ep.send(msg)
        return mavlink.MAV_RESULT_ACCEPTED

    ids = (cm.MSG_ID_COMPONENT_METADATA, cm.MSG_ID_COMPONENT_INFORMATION)
    return FileServices(service, {msg_id: functools.partial(send, msg_id=msg_id) for msg_id in ids})
