"""MAVLink FTP and component metadata on the link (docs/ftp_and_metadata.md): wired once at start-up.

The FTP tree (:class:`autopilot.mavlink.ftp_files.FileTree`), read-only:

* ``/log``: the flight logs directory (``--log-dir``; absent with ``--no-log``);
* ``/component_metadata``: ``general.json`` and ``parameters.json``
  (:mod:`autopilot.mavlink.component_metadata`).

COMPONENT_METADATA and COMPONENT_INFORMATION are answered to MAV_CMD_REQUEST_MESSAGE through the
link's ``requestable`` table.
"""

from __future__ import annotations

import functools
from pathlib import Path
from typing import TYPE_CHECKING

from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink import component_metadata as cm
from autopilot.mavlink.ftp_files import FileTree
from autopilot.mavlink.ftp_service import FtpService
from autopilot.mavlink.telemetry import DEFAULT_FLIGHT_SW_VERSION
from autopilot.parameters import ParameterStore

if TYPE_CHECKING:
    from autopilot.mavlink.endpoint import LinkEndpoint
    from autopilot.mavlink.link import GcsLink

VENDOR = "mavsim"
LOG_MOUNT = "log"


def add_file_services(
    link: GcsLink,
    params: ParameterStore,
    log_dir: Path | None,
    model: str,
    flight_sw_version: int = DEFAULT_FLIGHT_SW_VERSION,
) -> FtpService:
    """Serve FTP over ``link`` (``log_dir``: the flight logs, None without) and the component metadata of
    ``params`` (``model``: the vehicle's name); returns the FTP service."""
    meta = cm.metadata_files(params, VENDOR, model, cm.firmware_version(flight_sw_version))
    service = FtpService(FileTree({LOG_MOUNT: log_dir}, {cm.MOUNT: meta.files}), lambda: link.now_us)
    link.add_service(service)

    def send(ep: LinkEndpoint, msg_id: int) -> int:
        msg = cm.metadata_message(msg_id, meta.general_crc, link.now_us)
        assert msg is not None
        ep.send(msg)
        return mavlink.MAV_RESULT_ACCEPTED

    for msg_id in (cm.MSG_ID_COMPONENT_METADATA, cm.MSG_ID_COMPONENT_INFORMATION):
        link.requestable[msg_id] = functools.partial(send, msg_id=msg_id)
    return service
