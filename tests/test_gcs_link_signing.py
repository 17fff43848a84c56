"""MAVLink 2 message signing on GcsLink (autopilot/mavlink/signing.py), against pymavlink clients over loopback UDP.

Without a key everything is accepted; SETUP_SIGNING sets it (kept in the state directory, mode
0600); then only correctly signed, fresh packets are read (RADIO_STATUS also unsigned), answers
are signed, SETUP_SIGNING itself must be signed with the current key, and the all-zero key turns
signing off.  The link runs on simulated time (tests/gcs_link_harness.py); the signing clock is
the wall clock, as on a real vehicle.
"""

from __future__ import annotations

import os
import stat

import pytest

os.environ.setdefault("MAVLINK20", "1")
from pymavlink.dialects.v20 import common as mavlink  # noqa: E402

from autopilot.mavlink.signing import SigningService  # noqa: E402
from autopilot.signing_storage import load_signing  # noqa: E402
from mavsim_core.mavlink_signing import key_from_text, timestamp_now  # noqa: E402

from gcs_link_harness import GCS_COMP, GCS_SYS, acks, command_long, of_type  # tests/gcs_link_harness.py

KEY = key_from_text("correct horse battery staple")
OTHER_KEY = key_from_text("not the key")
CMD = 31010  # a command the stub vehicle accepts (any number: it records it)


@pytest.fixture
def signed_link(make_harness, tmp_path, inst):
    """``make()``: a harness whose link has the signing service, keeping its key in ``tmp_path``."""
    made = []

    def make():
        h = make_harness(inst)
        h.vehicle.results[CMD] = mavlink.MAV_RESULT_ACCEPTED
        texts: list[str] = []
        svc = SigningService(h.link.endpoints, h.link.sysid, h.link.compid, lambda sev, text: texts.append(text),
                             tmp_path / "quad_x-82.signing", log=texts.append)  # fmt: skip
        h.link.add_service(svc)
        tapped: list[str] = []
        h.link.set_traffic_tap(
            lambda now_us, ep, sent, packet: tapped.append(f"{'tx' if sent else 'rx'} {packet.hex()}")
        )
        h.texts, h.svc, h.tapped = texts, svc, tapped
        made.append(h)
        return h

    yield make
    for h in made:
        h.svc.close()
        h.close()  # (the harness fixture closes it again: idempotent)


def signer(key: bytes, sysid: int = GCS_SYS, compid: int = GCS_COMP, link_id: int = 0) -> mavlink.MAVLink:
    """An encoder that signs with ``key`` (clock: now); ``msg.pack(signer)`` gives the packet's bytes."""
    enc = mavlink.MAVLink(None, sysid, compid)
    enc.signing.secret_key, enc.signing.sign_outgoing = key, True
    enc.signing.link_id, enc.signing.timestamp = link_id, timestamp_now()
    return enc


def has_signature(msg) -> bool:
    """True if the packet carried a signature (``get_signed()`` says so only to a receiver with a key)."""
    buf = msg.get_msgbuf()
    return buf[0] == mavlink.PROTOCOL_MARKER_V2 and bool(buf[2] & mavlink.MAVLINK_IFLAG_SIGNED)


def command_packet(enc: mavlink.MAVLink, param1: float = 1.0, target_system: int = 1) -> bytes:
    return mavlink.MAVLink_command_long_message(target_system, 1, CMD, 0, param1, 0, 0, 0, 0, 0, 0).pack(enc)


def setup_signing(client, key: bytes, target_system: int = 1) -> None:
    client.mav.setup_signing_send(target_system, 1, list(key), timestamp_now())


def run_command(h, client, param1: float = 1.0) -> list:
    """Send CMD as the client is set up (signed or not); the COMMAND_ACKs that came back."""
    command_long(client, CMD, param1)
    return acks(h.pump(0.2)["gcs"], CMD)


def enable(h, client, key: bytes = KEY) -> None:
    setup_signing(client, key)
    h.pump(0.1)
    assert h.svc.enabled
    client.setup_signing(key, sign_outgoing=True, link_id=0)  # (refuses what is not signed with the key)


# --------------------------------------------------------------------------- no key, setting one


def test_without_a_key_everything_is_accepted_and_nothing_signed(signed_link):
    h = signed_link()
    c = h.connect()
    (ack,) = run_command(h, c)
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED and not has_signature(ack)
    c.setup_signing(OTHER_KEY, sign_outgoing=True, allow_unsigned_callback=lambda mav, mid: True, link_id=0)
    assert len(run_command(h, c, 2.0)) == 1  # a signed packet is read too (no key to check it against)
    assert [p[0] for _, p, _ in h.vehicle.commands] == [1.0, 2.0]
    assert h.svc.refused == {"unsigned": 0, "bad_signature": 0, "replayed": 0}
    assert not (h.svc.path).exists()


def test_setup_signing_sets_the_key_and_keeps_it_in_the_state_dir(signed_link):
    h = signed_link()
    c = h.connect()
    enable(h, c)
    assert "MAVLink signing on (key from 255/190)" in h.texts
    assert load_signing(h.svc.path)[0] == KEY
    assert stat.S_IMODE(os.stat(h.svc.path).st_mode) == 0o600
    assert not any(KEY.hex() in t for t in h.texts) and not any(KEY.hex() in p for p in h.tapped)  # not logged
    got = h.pump(1.1)["gcs"]
    assert of_type(got, "HEARTBEAT") and all(m.get_signed() for m in got)  # all signed, all check out with KEY


# --------------------------------------------------------------------------- with a key


def test_unsigned_command_has_no_effect_and_no_answer(signed_link):
    h = signed_link()
    c = h.connect()
    enable(h, c)
    c.disable_signing()
    assert run_command(h, c) == []
    assert h.vehicle.commands == [] and h.svc.refused["unsigned"] == 1
    assert h.link.rx_errors == 0  # refused, not counted as damage
    h.pump(0.1)
    assert any(t.startswith("MAVLink signing: refused 1 messages (unsigned 1,") for t in h.texts)


def test_signed_command_works_and_the_answer_is_signed(signed_link):
    h = signed_link()
    c = h.connect()
    enable(h, c)
    (ack,) = run_command(h, c, 3.0)  # c checks signatures with KEY: the ack passed
    assert ack.result == mavlink.MAV_RESULT_ACCEPTED and ack.get_signed()
    assert [p[0] for _, p, _ in h.vehicle.commands] == [3.0]


def test_replayed_stale_and_wrongly_signed_packets_are_refused(signed_link):
    h = signed_link()
    c = h.connect()
    enable(h, c)
    packet = command_packet(signer(KEY), 4.0)
    c.write(packet)
    c.write(packet)  # replayed
    h.pump(0.1)
    c.write(command_packet(signer(OTHER_KEY), 5.0))  # another key
    stale = signer(KEY, sysid=200)  # a new stream, but two minutes behind the clock
    stale.signing.timestamp -= 2 * 60 * 100_000
    c.write(command_packet(stale, 6.0))
    c.write(mavlink.MAVLink_command_long_message(1, 1, CMD, 0, 7.0, 0, 0, 0, 0, 0, 0).pack(signer(KEY), True))  # v1
    h.pump(0.1)
    assert [p[0] for _, p, _ in h.vehicle.commands] == [4.0]
    assert h.svc.refused == {"unsigned": 1, "bad_signature": 1, "replayed": 2}


def test_a_forged_timestamp_does_not_lock_out_the_real_sender(signed_link):
    """A packet with a far future timestamp and a bad signature leaves the stream's clock alone."""
    h = signed_link()
    c = h.connect()
    enable(h, c)
    forger = signer(OTHER_KEY)  # same stream (link 0, 255/190) as the client
    forger.signing.timestamp += 10**9
    c.write(command_packet(forger, 8.0))
    h.pump(0.1)
    assert len(run_command(h, c, 9.0)) == 1
    assert [p[0] for _, p, _ in h.vehicle.commands] == [9.0]


def test_radio_status_is_accepted_unsigned(signed_link):
    h = signed_link()
    c = h.connect()
    enable(h, c)
    radio = mavlink.MAVLink(None, 51, 68)  # a SiK radio ('3', 'D')
    c.write(mavlink.MAVLink_radio_status_message(180, 170, 90, 80, 75, 4, 3).pack(radio))
    c.write(mavlink.MAVLink_ping_message(0, 0, 0, 0).pack(radio))
    h.pump(0.1)
    rx = [bytes.fromhex(p[3:]) for p in h.tapped if p.startswith("rx")]
    received = {pkt[7] | pkt[8] << 8 | pkt[9] << 16 for pkt in rx if pkt[5] == 51}
    assert received == {mavlink.MAVLINK_MSG_ID_RADIO_STATUS}  # the PING was refused
    assert h.svc.refused["unsigned"] == 1


# --------------------------------------------------------------------------- changing, keeping, removing the key


def test_setup_signing_must_be_signed_with_the_current_key(signed_link):
    h = signed_link()
    c = h.connect()
    enable(h, c)
    c.disable_signing()
    setup_signing(c, OTHER_KEY)  # unsigned: refused
    h.pump(0.1)
    assert load_signing(h.svc.path)[0] == KEY and h.svc.setups == 1
    c.setup_signing(KEY, sign_outgoing=True, link_id=0)
    setup_signing(c, OTHER_KEY, target_system=0)  # signed but broadcast: refused
    h.pump(0.1)
    assert "SETUP_SIGNING from 255/190 refused: broadcast" in h.texts
    setup_signing(c, OTHER_KEY)  # signed with the current key: the key changes
    h.pump(0.1)
    assert load_signing(h.svc.path)[0] == OTHER_KEY and h.svc.setups == 2
    c.setup_signing(OTHER_KEY, sign_outgoing=True, link_id=0)
    assert len(run_command(h, c)) == 1


def test_the_key_is_loaded_by_a_new_link_with_the_same_state_dir(signed_link):
    h = signed_link()
    c = h.connect()
    enable(h, c)
    at_setup = load_signing(h.svc.path)[1]
    h.pump(0.2)
    h.svc.close()
    h.close()
    assert load_signing(h.svc.path)[1] > at_setup  # the signing clock is written again at the end
    h2 = signed_link()
    assert h2.svc.enabled and h2.texts[0].startswith("[autopilot] MAVLink signing ON: key loaded from")
    c2 = h2.connect()
    got = h2.pump(0.2)["gcs"]
    assert got and all(has_signature(m) for m in got)
    assert run_command(h2, c2) == []  # unsigned: refused
    c2.setup_signing(KEY, sign_outgoing=True, link_id=0)
    (ack,) = run_command(h2, c2, 10.0)
    assert ack.get_signed() and [p[0] for _, p, _ in h2.vehicle.commands] == [10.0]


def test_the_all_zero_key_turns_signing_off(signed_link):
    h = signed_link()
    c = h.connect()
    enable(h, c)
    c.mav.setup_signing_send(1, 1, [0] * 32, 0)  # signed with the current key
    h.pump(0.1)
    assert not h.svc.enabled and not h.svc.path.exists()
    assert "MAVLink signing off (key removed by 255/190)" in h.texts
    c.disable_signing()
    (ack,) = run_command(h, c, 11.0)
    assert not has_signature(ack) and [p[0] for _, p, _ in h.vehicle.commands] == [11.0]


def test_a_broken_key_file_is_reported_and_ignored(signed_link, tmp_path):
    (tmp_path / "quad_x-82.signing").write_text("key 1234\n")
    h = signed_link()
    assert not h.svc.enabled
    assert h.texts[0].startswith("[autopilot] MAVLink signing: ignoring a broken key file, signing is OFF")


# --------------------------------------------------------------------------- keys as users type them


def test_a_passphrase_gives_the_key_mavproxy_and_gcs_use(monkeypatch):
    """SHA-256 of the passphrase, as MAVProxy's 'signing setup' (tests/test_e2e_signing.py runs MAVProxy itself)."""
    from gcs.__main__ import build_parser

    sha256_abc = "ba7816bf8f01cfea414140de5dae2223b00361a396177a9cb410ff61f20015ad"  # FIPS 180-2's example
    assert key_from_text("abc").hex() == sha256_abc
    passphrase = "correct horse battery staple"
    assert build_parser().parse_args(["--signing-key", passphrase, "arm"]).signing_key == KEY
    assert key_from_text(KEY.hex()) == KEY and key_from_text(KEY.hex().upper()) == KEY  # 64 hex digits: the key
    with pytest.raises(ValueError):
        key_from_text("")
    monkeypatch.setenv("GCS_SIGNING_KEY", passphrase)
    assert build_parser().parse_args(["arm"]).signing_key == KEY
