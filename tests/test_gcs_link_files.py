"""MAVLink FTP and component metadata on GcsLink, against a pymavlink client over loopback UDP.

Every opcode of the FTP microservice (https://mavlink.io/en/services/ftp.html) is sent as a
FILE_TRANSFER_PROTOCOL message and its reply checked field by field: listings, reads, bursts,
CRC32, sessions, a resent request, and the fast NAK with its error code for everything the
read-only tree refuses.  Then COMPONENT_METADATA / COMPONENT_INFORMATION on REQUEST_MESSAGE and the
metadata files they point to, downloaded over FTP.  The link runs on simulated time
(tests/gcs_link_harness.py); the same against the real stack with MAVProxy and MAVSDK is
tests/test_e2e_mavproxy.py.
"""

from __future__ import annotations

import json
import os
import struct

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from autopilot.mavlink import component_metadata as cm  # noqa: E402
from autopilot.mavlink.file_services import file_services  # noqa: E402
from autopilot.mavlink.ftp_service import MAX_SESSIONS, SESSION_IDLE_US  # noqa: E402
from mavsim_core.mavftp import MAX_DATA, Err, FtpPayload, Op, decode, encode  # noqa: E402

from gcs_link_harness import GCS_COMP, GCS_SYS, acks, command_long  # tests/gcs_link_harness.py

DATA = os.urandom(100_000)  # a log of 100 kB: 419 packets of 239 bytes


def reference_crc32(data: bytes) -> int:
    """MAVLink's CRC32 bit by bit (reflected 0x04C11DB7, start 0, no final inversion), independent of zlib."""
    crc = 0
    for byte in data:
        crc ^= byte
        for _ in range(8):
            crc = (crc >> 1) ^ (0xEDB88320 if crc & 1 else 0)
    return crc


@pytest.fixture
def files(make_harness, tmp_path, inst):
    """(harness with FTP, connected client, the FTP service, the log directory)."""
    log_dir = tmp_path / "logs"
    (log_dir / "old").mkdir(parents=True)
    (log_dir / "2026-03-01_10-00-00.ulg").write_bytes(DATA)
    (log_dir / "exact.bin").write_bytes(b"z" * (2 * MAX_DATA))
    (tmp_path / "secret.txt").write_text("outside the tree")
    (log_dir / "link.txt").symlink_to(tmp_path / "secret.txt")
    h = make_harness(inst)
    served = file_services(h.vehicle.params, log_dir, "test_quad", lambda: h.link.now_us)
    h.link.add_service(served.ftp)
    h.link.requestable.update(served.requestable)
    return h, h.connect("gcs"), served.ftp, log_dir


def request(h, client, op: Op, path: str = "", *, seq: int = 7, session: int = 0, offset: int = 0, size=None,
            data: bytes | None = None, target_component: int = 1) -> list[FtpPayload]:  # fmt: skip
    """Send one FTP request; the replies received within one link update (250 Hz step) after it."""
    body = data if data is not None else path.encode()
    raw = bytearray(encode(FtpPayload(seq, session, op, 0, offset, body)))
    if size is not None:
        raw[4] = size
    client.mav.file_transfer_protocol_send(0, h.link.sysid, target_component, list(raw))
    got = h.pump(0.004)["gcs"]
    for m in got:  # replies are addressed to the client that asked
        if m.get_type() == "FILE_TRANSFER_PROTOCOL":
            assert (m.target_system, m.target_component) == (GCS_SYS, GCS_COMP)
    return [decode(m.payload) for m in got if m.get_type() == "FILE_TRANSFER_PROTOCOL"]


def one(replies: list[FtpPayload], req_op: Op, seq: int = 7) -> FtpPayload:
    assert len(replies) == 1, replies
    r = replies[0]
    assert (r.req_opcode, r.seq) == (req_op, seq + 1)
    return r


def nak_of(replies: list[FtpPayload], req_op: Op, seq: int = 7) -> Err:
    r = one(replies, req_op, seq)
    assert r.opcode == Op.NAK and r.size == 1
    return Err(r.data[0])


def listing(h, client, path: str) -> list[str]:
    """Every entry of ``path`` (ListDirectory from index 0 until NAK EOF)."""
    entries, seq = [], 20
    while True:
        r = one(request(h, client, Op.LIST_DIRECTORY, path, seq=seq, offset=len(entries)), Op.LIST_DIRECTORY, seq)
        if r.opcode == Op.NAK:
            assert r.data[0] == Err.EOF
            return entries
        assert r.data.endswith(b"\0") and r.size <= MAX_DATA
        entries += [e.decode() for e in r.data[:-1].split(b"\0")]
        seq += 1


def download(h, client, path: str, session: int = 3) -> bytes:
    """Open, burst-read to the end, terminate; the file's bytes (checks sizes and burst sequence)."""
    r = one(request(h, client, Op.OPEN_FILE_RO, path, seq=40, session=session), Op.OPEN_FILE_RO, 40)
    assert r.opcode == Op.ACK and r.session == session and r.size == 4
    (size,) = struct.unpack("<I", r.data)
    req = encode(FtpPayload(41, session, Op.BURST_READ_FILE, 0, 0, b""))
    client.mav.file_transfer_protocol_send(0, h.link.sysid, 1, list(req))
    packets = []
    while not packets or not packets[-1].burst_complete:
        got = h.pump(0.1, until=lambda m: m.get_type() == "FILE_TRANSFER_PROTOCOL" and m.payload[6])["gcs"]
        packets += [decode(m.payload) for m in got if m.get_type() == "FILE_TRANSFER_PROTOCOL"]
        assert got, "the burst stopped"
    assert [p.seq for p in packets] == [42 + k for k in range(len(packets))]  # request seq + 1 + k
    assert all(p.opcode == Op.ACK and p.req_opcode == Op.BURST_READ_FILE for p in packets)
    assert [p.offset for p in packets] == [k * MAX_DATA for k in range(len(packets))]
    data = b"".join(p.data for p in packets)
    assert len(data) == size
    assert (
        one(request(h, client, Op.TERMINATE_SESSION, seq=60, session=session), Op.TERMINATE_SESSION, 60).opcode
        == Op.ACK
    )
    return data


# --------------------------------------------------------------------------- directories and reads


def test_list_root_log_dir_and_metadata(files):
    h, client, _, log_dir = files
    assert listing(h, client, "/") == ["Dlog", "Dcomponent_metadata"]
    logs = listing(h, client, "/log")
    assert logs == ["Dold", f"F2026-03-01_10-00-00.ulg\t{len(DATA)}", f"Fexact.bin\t{2 * MAX_DATA}"]  # no link out
    assert listing(h, client, "log/") == logs  # PX4's relative paths, trailing slash
    assert listing(h, client, "/log/old") == []
    meta = listing(h, client, "/component_metadata")
    assert [e.split("\t")[0] for e in meta] == ["Fgeneral.json", "Fparameters.json"]


def test_long_listing_comes_in_chunks_from_the_requested_index(files):
    h, client, _, log_dir = files
    names = [f"flight_{k:03d}_with_a_long_name.ulg" for k in range(60)]
    for name in names:
        (log_dir / name).write_bytes(b"x" * len(name))
    got = listing(h, client, "/log")
    assert got[3:] == [f"F{n}\t{len(n)}" for n in names]  # every entry once, in order, across chunks


def test_list_errors(files):
    h, client, _, _ = files
    assert nak_of(request(h, client, Op.LIST_DIRECTORY, "/nope"), Op.LIST_DIRECTORY) == Err.FILE_NOT_FOUND
    assert nak_of(request(h, client, Op.LIST_DIRECTORY, "/log/exact.bin"), Op.LIST_DIRECTORY) == Err.FAIL
    assert nak_of(request(h, client, Op.LIST_DIRECTORY, "/log/../.."), Op.LIST_DIRECTORY) == Err.FILE_NOT_FOUND


def test_open_read_and_terminate(files):
    h, client, svc, _ = files
    r = one(request(h, client, Op.OPEN_FILE_RO, "/log/2026-03-01_10-00-00.ulg\0", session=5), Op.OPEN_FILE_RO)
    assert (r.opcode, r.session, r.size, struct.unpack("<I", r.data)[0]) == (Op.ACK, 5, 4, len(DATA))
    for offset, n in ((0, MAX_DATA), (1000, 10), (len(DATA) - 5, 100)):
        r = one(request(h, client, Op.READ_FILE, seq=8, session=5, offset=offset, size=n, data=b""), Op.READ_FILE, 8)
        assert (r.opcode, r.offset, r.data) == (Op.ACK, offset, DATA[offset : offset + n])
    eof = request(h, client, Op.READ_FILE, seq=9, session=5, offset=len(DATA), size=MAX_DATA, data=b"")
    assert nak_of(eof, Op.READ_FILE, 9) == Err.EOF
    assert one(request(h, client, Op.TERMINATE_SESSION, seq=10, session=5), Op.TERMINATE_SESSION, 10).opcode == Op.ACK
    assert svc.open_sessions == 0
    closed = request(h, client, Op.READ_FILE, seq=11, session=5, size=10, data=b"")
    assert nak_of(closed, Op.READ_FILE, 11) == Err.INVALID_SESSION
    assert nak_of(request(h, client, Op.TERMINATE_SESSION, seq=12, session=5), Op.TERMINATE_SESSION, 12) == (
        Err.INVALID_SESSION
    )


def test_burst_read_whole_files(files):
    h, client, _, _ = files
    assert download(h, client, "/log/2026-03-01_10-00-00.ulg") == DATA
    assert download(h, client, "/log/exact.bin", session=0) == b"z" * (2 * MAX_DATA)
    # a burst from the end: EOF
    one(request(h, client, Op.OPEN_FILE_RO, "/log/exact.bin", seq=70), Op.OPEN_FILE_RO, 70)
    at_end = request(h, client, Op.BURST_READ_FILE, seq=71, offset=2 * MAX_DATA, size=MAX_DATA, data=b"")
    assert nak_of(at_end, Op.BURST_READ_FILE, 71) == Err.EOF


def test_crc32(files):
    h, client, _, _ = files
    assert reference_crc32(b"123456789") == 0x2DFD2D88  # MAVLink's CRC32 (not ISO's 0xCBF43926)
    r = one(request(h, client, Op.CALC_FILE_CRC32, "/log/2026-03-01_10-00-00.ulg"), Op.CALC_FILE_CRC32)
    assert (r.opcode, r.size, struct.unpack("<I", r.data)[0]) == (Op.ACK, 4, reference_crc32(DATA))
    missing = request(h, client, Op.CALC_FILE_CRC32, "/log/none.ulg")
    assert nak_of(missing, Op.CALC_FILE_CRC32) == Err.FILE_NOT_FOUND


# --------------------------------------------------------------------------- refusals, at once


@pytest.mark.parametrize(
    "op, path, err",
    [
        (Op.OPEN_FILE_RO, "@PARAM/param.pck?withdefaults=1", Err.FILE_NOT_FOUND),  # MAVProxy's first request
        (Op.OPEN_FILE_RO, "/log/link.txt", Err.FILE_NOT_FOUND),  # a link out of the tree
        (Op.OPEN_FILE_RO, "/log/old", Err.FAIL),  # a directory
        (Op.CREATE_FILE, "/log/new.txt", Err.FILE_PROTECTED),
        (Op.CREATE_FILE, "/nowhere/new.txt", Err.FILE_NOT_FOUND),
        (Op.OPEN_FILE_WO, "/log/exact.bin", Err.FILE_PROTECTED),
        (Op.CREATE_DIRECTORY, "/log/newdir", Err.FILE_PROTECTED),
        (Op.REMOVE_FILE, "/log/exact.bin", Err.FILE_PROTECTED),
        (Op.REMOVE_FILE, "/log/none.bin", Err.FILE_NOT_FOUND),
        (Op.REMOVE_DIRECTORY, "/log/old", Err.FILE_PROTECTED),
        (Op.TRUNCATE_FILE, "/component_metadata/general.json", Err.FILE_PROTECTED),
        (Op.RENAME, "/log/exact.bin\0/log/moved.bin", Err.FILE_PROTECTED),
        (Op.WRITE_FILE, "", Err.INVALID_SESSION),
        (16, "/", Err.UNKNOWN_COMMAND),  # ListDirectoryWithTime (an ArduPilot extension)
        (200, "", Err.UNKNOWN_COMMAND),
    ],
)
def test_refusals_are_immediate_naks(files, op, path, err):
    h, client, _, log_dir = files
    before = sorted(p.name for p in log_dir.iterdir())
    assert nak_of(request(h, client, op, path), op) == err  # within the one update after the request
    assert sorted(p.name for p in log_dir.iterdir()) == before
    assert (log_dir / "exact.bin").read_bytes() == b"z" * (2 * MAX_DATA)


def test_write_to_an_open_file_and_bad_sizes(files):
    h, client, _, _ = files
    one(request(h, client, Op.OPEN_FILE_RO, "/log/exact.bin", session=2), Op.OPEN_FILE_RO)
    write = request(h, client, Op.WRITE_FILE, seq=8, session=2, data=b"data")
    assert nak_of(write, Op.WRITE_FILE, 8) == Err.FILE_PROTECTED
    bad = request(h, client, Op.READ_FILE, seq=9, session=2, size=MAX_DATA + 1, data=b"")
    assert nak_of(bad, Op.READ_FILE, 9) == Err.INVALID_DATA_SIZE
    assert one(request(h, client, Op.NONE, seq=10), Op.NONE, 10).opcode == Op.ACK


def test_not_for_us_is_not_answered(files):
    h, client, _, _ = files
    assert request(h, client, Op.LIST_DIRECTORY, "/", target_component=42) == []


# --------------------------------------------------------------------------- sessions


def test_resent_request_gets_the_same_reply_without_running_again(files):
    h, client, svc, _ = files
    first = request(h, client, Op.OPEN_FILE_RO, "/log/exact.bin", seq=30, session=1)
    again = request(h, client, Op.OPEN_FILE_RO, "/log/exact.bin", seq=30, session=1)  # the ACK was "lost"
    assert again == first and first[0].opcode == Op.ACK and svc.open_sessions == 1
    term = request(h, client, Op.TERMINATE_SESSION, seq=31, session=1)
    assert request(h, client, Op.TERMINATE_SESSION, seq=31, session=1) == term  # not InvalidSession
    assert term[0].opcode == Op.ACK and svc.open_sessions == 0


def test_reset_sessions(files):
    h, client, svc, _ = files
    for s in (0, 1):
        one(request(h, client, Op.OPEN_FILE_RO, "/log/exact.bin", seq=s, session=s), Op.OPEN_FILE_RO, s)
    assert svc.open_sessions == 2
    assert one(request(h, client, Op.RESET_SESSIONS, seq=5), Op.RESET_SESSIONS, 5).opcode == Op.ACK
    assert svc.open_sessions == 0
    gone = request(h, client, Op.READ_FILE, seq=6, session=1, size=10, data=b"")
    assert nak_of(gone, Op.READ_FILE, 6) == Err.INVALID_SESSION


def test_sessions_per_client_and_their_limit(files):
    h, gcs, svc, _ = files
    api = h.connect("api")  # another client using the same session number
    api.mav.file_transfer_protocol_send(
        0, h.link.sysid, 1, list(encode(FtpPayload(1, 0, Op.OPEN_FILE_RO, 0, 0, b"/log/exact.bin")))
    )
    h.pump(0.004)
    one(request(h, gcs, Op.OPEN_FILE_RO, "/component_metadata/general.json", seq=1), Op.OPEN_FILE_RO, 1)
    assert svc.open_sessions == 2  # one each
    for s in range(1, MAX_SESSIONS - 1):
        one(request(h, gcs, Op.OPEN_FILE_RO, "/log/exact.bin", seq=10 + s, session=s), Op.OPEN_FILE_RO, 10 + s)
    assert svc.open_sessions == MAX_SESSIONS
    full = request(h, gcs, Op.OPEN_FILE_RO, "/log/exact.bin", seq=50, session=99)
    assert nak_of(full, Op.OPEN_FILE_RO, 50) == Err.NO_SESSIONS_AVAILABLE
    h.pump(SESSION_IDLE_US / 1e6)  # all idle now: the oldest makes room
    assert (
        one(request(h, gcs, Op.OPEN_FILE_RO, "/log/exact.bin", seq=51, session=99), Op.OPEN_FILE_RO, 51).opcode
        == Op.ACK
    )
    assert svc.open_sessions == MAX_SESSIONS


# --------------------------------------------------------------------------- component metadata


def requested(h, client, msg_id: int):
    """REQUEST_MESSAGE ``msg_id``: (the COMMAND_ACK result, the raw message received)."""
    command_long(client, mavlink.MAV_CMD_REQUEST_MESSAGE, msg_id, target_system=h.link.sysid)
    got = h.pump(0.1, until=lambda m: m.get_type() == "COMMAND_ACK")["gcs"]
    ack = acks(got, mavlink.MAV_CMD_REQUEST_MESSAGE)
    msgs = [m for m in got if m.get_type() == f"UNKNOWN_{msg_id}"]  # not in pymavlink's common dialect
    return ack[0].result, msgs


def unpack(raw, cls):
    """A v2 packet of ``cls``: its CRC checked with the CRC extra of MAVLink's definition, its fields."""
    from pymavlink.generator.mavcrc import x25crc

    buf = bytes(raw.data)
    assert buf[0] == 0xFD and buf[7] | buf[8] << 8 | buf[9] << 16 == cls.id
    crc = x25crc(buf[1:-2])
    crc.accumulate(bytes([cls.crc_extra]))
    assert crc.crc == struct.unpack("<H", buf[-2:])[0]
    return cls.unpacker.unpack(buf[10:-2].ljust(cls.unpacker.size, b"\0"))


def test_component_metadata_points_to_the_files(files):
    h, client, _, _ = files
    result, msgs = requested(h, client, cm.MSG_ID_COMPONENT_METADATA)
    assert result == mavlink.MAV_RESULT_ACCEPTED and len(msgs) == 1
    _, general_crc, uri = unpack(msgs[0], cm.ComponentMetadataMessage)
    assert uri.rstrip(b"\0") == b"mftp:///component_metadata/general.json"
    general = download(h, client, "/component_metadata/general.json")
    assert reference_crc32(general) == general_crc
    doc = json.loads(general)
    assert doc["version"] == 1 and doc["firmwareVersion"].count(".") == 2
    (entry,) = doc["metadataTypes"]
    assert entry["type"] == 1 and entry["uri"] == "mftp:///component_metadata/parameters.json"
    parameters = download(h, client, entry["uri"][len("mftp://") :])
    assert reference_crc32(parameters) == entry["fileCrc"]
    params = {p["name"]: p for p in json.loads(parameters)["parameters"]}
    store = h.vehicle.params
    assert set(params) == set(store.names())
    for name, p in params.items():
        d = store.definition(name)
        assert (p["min"], p["max"], p["default"]) == (d.min, d.max, store.default(name))
        assert p["type"] == ("Int32" if d.ptype == "INT32" else "Float") and p["shortDesc"]
    # the deprecated message QGroundControl falls back to
    result, msgs = requested(h, client, cm.MSG_ID_COMPONENT_INFORMATION)
    assert result == mavlink.MAV_RESULT_ACCEPTED
    _, crc, peripherals_crc, uri, peripherals_uri = unpack(msgs[0], cm.ComponentInformationMessage)
    assert (crc, uri.rstrip(b"\0"), peripherals_uri.rstrip(b"\0")) == (
        general_crc,
        b"mftp:///component_metadata/general.json",
        b"",
    )
