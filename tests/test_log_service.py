"""The MAVLink log protocol service (autopilot/mavlink/log_service.py) on its own: requests in, replies out.

The service's handlers get pymavlink messages and answer through the endpoint they came in on;
here that endpoint records what it was given.  The same protocol against the real stack, with
MAVSDK's LogFiles plugin and pymavlink, is tests/test_e2e_logs.py.
"""

from __future__ import annotations

import os
import time
from pathlib import Path

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from autopilot.mavlink.log_service import BURST_BYTES, LogService, list_logs  # noqa: E402


class RecordingEndpoint:
    """What the service needs of a link endpoint: a name and send()."""

    def __init__(self, name: str = "gcs") -> None:
        self.name = name
        self.sent: list = []

    def send(self, msg) -> None:
        self.sent.append(msg)

    def take(self) -> list:
        out, self.sent = self.sent, []
        return out


def _logs(tmp_path: Path) -> dict[str, bytes]:
    """Three flights of instance 0 (two in the same second), one of instance 2, and files that are no logs."""
    files = {
        "2026-03-01_10-00-00.ulg": bytes(range(256)) * 4,  # 1024 bytes
        "2026-03-01_10-00-00_2.ulg": b"x" * 180,  # exactly two LOG_DATA
        "2026-03-02_09-30-00.ulg": os.urandom(100_000),
        "2026-03-01_11-00-00_i2.ulg": b"other instance",
        "notes.ulg": b"not a flight log name",
        "2026-03-01_10-00-00.tlog": b"tlog",
        "2026-03-01_10-00-00.fc.npy": b"npy",
    }
    for name, data in files.items():
        (tmp_path / name).write_bytes(data)
    return files


def _request_data(svc, ep, log_id, ofs, count):
    svc.handlers()["LOG_REQUEST_DATA"](ep, mavlink.MAVLink_log_request_data_message(1, 1, log_id, ofs, count))


def _download(svc, ep, log_id, ofs=0, count=0xFFFFFFFF) -> tuple[bytes, int]:
    """(the bytes received, the number of updates it took)."""
    _request_data(svc, ep, log_id, ofs, count)
    data, updates = bytearray(), 0
    while True:
        got = ep.take()
        for m in got:
            assert m.get_type() == "LOG_DATA" and m.id == log_id and m.ofs == ofs + len(data)
            data += bytes(m.data[: m.count])
        if not got and updates:
            return bytes(data), updates - 1
        svc.update(0)
        updates += 1


def test_listing_is_this_instances_logs_oldest_first(tmp_path):
    _logs(tmp_path)
    names = [f.path.name for f in list_logs(tmp_path, 0)]
    assert names == ["2026-03-01_10-00-00.ulg", "2026-03-01_10-00-00_2.ulg", "2026-03-02_09-30-00.ulg"]
    assert [f.path.name for f in list_logs(tmp_path, 2)] == ["2026-03-01_11-00-00_i2.ulg"]
    assert list_logs(tmp_path / "missing", 0) == [] and list_logs(None, 0) == []

    svc, ep = LogService(tmp_path, 0), RecordingEndpoint()
    svc.handlers()["LOG_REQUEST_LIST"](ep, mavlink.MAVLink_log_request_list_message(1, 1, 0, 0xFFFF))
    assert ep.take() == []  # sent from update(), in the link's batch
    svc.update(0)
    entries = ep.take()
    assert [(e.id, e.num_logs, e.last_log_num, e.size) for e in entries] == [
        (0, 3, 2, 1024),
        (1, 3, 2, 180),
        (2, 3, 2, 100_000),
    ]
    assert entries[0].time_utc == int(time.mktime((2026, 3, 1, 10, 0, 0, 0, 0, -1)))  # arming, local time named

    svc.handlers()["LOG_REQUEST_LIST"](ep, mavlink.MAVLink_log_request_list_message(1, 1, 1, 1))  # a missed entry
    svc.update(0)
    assert [e.id for e in ep.take()] == [1]


def test_no_logs_is_one_entry_with_num_logs_zero(tmp_path):
    for log_dir in (tmp_path, None):  # an empty directory, or logging off
        svc, ep = LogService(log_dir, 0), RecordingEndpoint()
        svc.handlers()["LOG_REQUEST_LIST"](ep, mavlink.MAVLink_log_request_list_message(1, 1, 0, 0xFFFF))
        svc.update(0)
        assert [(e.id, e.num_logs, e.size) for e in ep.take()] == [(0, 0, 0)]


def test_download_whole_logs_and_ranges(tmp_path):
    files = _logs(tmp_path)
    svc, ep = LogService(tmp_path, 0), RecordingEndpoint()
    data, _ = _download(svc, ep, 0)
    assert data == files["2026-03-01_10-00-00.ulg"]
    data, _ = _download(svc, ep, 1)
    assert data == b"x" * 180
    big = files["2026-03-02_09-30-00.ulg"]
    data, updates = _download(svc, ep, 2)
    assert data == big and updates == -(-len(big) // BURST_BYTES)  # in bursts of BURST_BYTES per update
    assert svc.bytes_sent == 1024 + 180 + 100_000
    data, _ = _download(svc, ep, 2, ofs=46080, count=46080)  # one of MAVSDK's chunks
    assert data == big[46080 : 2 * 46080]
    data, _ = _download(svc, ep, 2, ofs=99_990, count=46080)  # a request past the end is cut at the end
    assert data == big[99_990:]
    _request_data(svc, ep, 2, 0, 0xFFFFFFFF)
    svc.update(0)
    assert {m.ofs % 90 for m in ep.take()} == {0}  # whole LOG_DATA per burst: every offset on the 90-byte grid
    svc.update(0)
    assert {m.ofs % 90 for m in ep.take()} == {0}


def test_bad_requests_get_an_empty_log_data(tmp_path):
    _logs(tmp_path)
    svc, ep = LogService(tmp_path, 0), RecordingEndpoint()
    for log_id, ofs in ((7, 0), (0, 1024), (0, 5000)):  # unknown id, offset at and past the end
        _request_data(svc, ep, log_id, ofs, 90)
        svc.update(0)
        assert [(m.id, m.ofs, m.count) for m in ep.take()] == [(log_id, ofs, 0)]
        svc.update(0)
        assert ep.take() == []


def test_request_end_stops_a_transfer_and_endpoints_are_apart(tmp_path):
    files = _logs(tmp_path)
    svc, gcs, api = LogService(tmp_path, 0), RecordingEndpoint("gcs"), RecordingEndpoint("api")
    _request_data(svc, gcs, 2, 0, 0xFFFFFFFF)
    data, _ = _download(svc, api, 0)  # the other endpoint's download goes on beside it
    assert data == files["2026-03-01_10-00-00.ulg"]
    assert gcs.take()  # the first burst went out meanwhile
    svc.handlers()["LOG_REQUEST_END"](gcs, mavlink.MAVLink_log_request_end_message(1, 1))
    svc.update(0)
    assert gcs.take() == []


def test_erase_keeps_the_log_being_written_and_other_instances(tmp_path):
    _logs(tmp_path)
    writing = tmp_path / "2026-03-02_09-30-00.ulg"
    svc, ep = LogService(tmp_path, 0, writing=lambda: writing), RecordingEndpoint()
    svc.handlers()["LOG_ERASE"](ep, mavlink.MAVLink_log_erase_message(1, 1))
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "2026-03-01_11-00-00_i2.ulg",
        "2026-03-02_09-30-00.ulg",
        "notes.ulg",
    ]
    svc.handlers()["LOG_REQUEST_LIST"](ep, mavlink.MAVLink_log_request_list_message(1, 1, 0, 0xFFFF))
    svc.update(0)
    assert [(e.id, e.num_logs) for e in ep.take()] == [(0, 1)]  # numbered from 0 again
