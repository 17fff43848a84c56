"""MAVLink 2 message signing on the ground-station link (SETUP_SIGNING, message 256), as PX4 does it.

A :class:`~autopilot.mavlink.link_service.LinkService` over the signing state of both endpoints
(:class:`mavsim_core.mavlink_signing.SigningState`, each endpoint's encoder and parser share one):

* **No key** (the default): nothing is signed, everything is accepted, as PX4 without a key.
* **SETUP_SIGNING** addressed to this system (``target_system`` = ours, not broadcast;
  ``target_component`` ours or 0, as MAVProxy sends it) sets the key on *both* endpoints, with
  the outgoing timestamp at least its ``initial_timestamp`` and the wall clock.  Who may send it
  (the spec wants a secure channel; PX4 since 1.17 accepts it on any link while no key is set):
  while no key is set it is accepted unsigned from anyone who can reach the link ("trust on first
  use": set the key before the vehicle is reachable by others); once a key is set it is accepted
  only correctly signed with the current key, since the link refuses everything else before it
  is read.  So only a holder of the current key can change or remove it.
* **An all-zero key** turns signing off and forgets the key (the spec names "all-zero key and
  zero timestamp"; any timestamp is taken here, since an all-zero key protects nothing).
* **With a key** every packet sent on either endpoint is signed (link id 0 "gcs", 1 "api"), and
  a received packet is read only if it is correctly signed, newer than the last packet of its
  (link id, system, component) stream (a stream new to us may be up to one minute behind our
  clock), or its message is RADIO_STATUS, ADSB_VEHICLE or COLLISION (PX4's list of messages
  accepted unsigned).  Everything else, MAVLink 1 included, is dropped unread and unanswered,
  counted by reason (:attr:`SigningService.refused`), and summed up in a STATUSTEXT warning at
  most every REPORT_INTERVAL_US.  The stream timestamps are shared by both endpoints, so a
  packet captured on one port cannot be replayed on the other.

The key and the signing clock are kept in the state directory (:mod:`autopilot.signing_storage`):
written at once when a key is set (the file removed when signing is turned off), the clock again
every SAVE_INTERVAL_S of wall time and at exit; loaded at start-up.  Without a state directory
the key lasts until the process ends.  The key never appears in parameters, logs or STATUSTEXTs
(the link leaves SETUP_SIGNING out of the .tlog).
"""

from __future__ import annotations

import atexit
import threading
from pathlib import Path
from typing import TYPE_CHECKING, Callable, Sequence

from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink.link_service import Handler, ServiceCommand
from autopilot.signing_storage import load_signing, remove_signing, save_signing
from mavsim_core.mavlink_signing import SigningState, is_disabling_key

if TYPE_CHECKING:
    from autopilot.mavlink.endpoint import LinkEndpoint

REPORT_INTERVAL_US = 10_000_000  # simulated µs between two "refused" warnings at most
SAVE_INTERVAL_S = 60.0  # wall seconds between two writes of the signing clock (the spec: at least once a minute)


class SigningService:
    """SETUP_SIGNING and the signing state of the link's endpoints (see the module docstring).

    ``path``: the state file (None: nothing kept); ``what``: how the file names the vehicle;
    ``send_statustext(severity, text)``: the link's; ``log``: start-up and storage messages.
    Counters: :attr:`refused` (by reason), ``setups`` (keys set), ``disables``.
    """

    def __init__(
        self,
        endpoints: Sequence[LinkEndpoint],
        sysid: int,
        compid: int,
        send_statustext: Callable[[int, str], None],
        path: Path | None = None,
        *,
        what: str = "the vehicle",
        log: Callable[[str], None] = lambda text: print(text, flush=True),
    ) -> None:
        self.states: list[SigningState] = [ep.signing for ep in endpoints]
        for link_id, state in enumerate(self.states):
            state.link_id = link_id
        self.sysid, self.compid = sysid, compid
        self.send_statustext = send_statustext
        self.path, self.what, self.log = path, what, log
        self.setups = 0
        self.disables = 0
        self._reported = 0  # refusals already reported
        self._next_report_us = 0
        self._lock = threading.Lock()  # the key and the file, between the link's thread and the saver
        self._stop = threading.Event()
        self._saved_timestamp = 0
        self._load()
        self._saver: threading.Thread | None = None
        if path is not None:
            self._saver = threading.Thread(target=self._save_regularly, name="signing-saver", daemon=True)
            self._saver.start()
            atexit.register(self.close)

    # ------------------------------------------------------------------ LinkService

    def handlers(self) -> dict[str, Handler]:
        return {"SETUP_SIGNING": self._on_setup_signing}

    def commands(self) -> dict[int, ServiceCommand]:
        return {}

    def update(self, now_us: int) -> None:
        """Keep the outgoing timestamps up with the wall clock; warn about refused packets now and then."""
        for state in self.states:
            state.keep_up_with_clock()
        if now_us + REPORT_INTERVAL_US < self._next_report_us:  # the simulated clock restarted
            self._next_report_us = now_us
        total = sum(state.refused for state in self.states)  # (all reasons; by reason only to report them)
        if total > self._reported and now_us >= self._next_report_us:
            refused = self.refused
            new = total - self._reported
            self._reported = total
            self._next_report_us = now_us + REPORT_INTERVAL_US
            self.send_statustext(
                mavlink.MAV_SEVERITY_WARNING,
                f"MAVLink signing: refused {new} messages (unsigned {refused['unsigned']}, wrong signature "
                f"{refused['bad_signature']}, replayed or old {refused['replayed']} since start)",
            )

    # ------------------------------------------------------------------ state

    @property
    def enabled(self) -> bool:
        """True while a key is set (everything sent is signed, unsigned input refused)."""
        return self.states[0].enabled

    @property
    def refused(self) -> dict[str, int]:
        """Packets refused since start on both endpoints, by reason."""
        return {
            "unsigned": sum(s.refused_unsigned for s in self.states),
            "bad_signature": sum(s.refused_bad_signature for s in self.states),
            "replayed": sum(s.refused_replayed for s in self.states),
        }

    def close(self) -> None:
        """Stop the saver and write the signing clock (idempotent; also run at exit)."""
        self._stop.set()
        if self._saver is not None and self._saver is not threading.current_thread():
            self._saver.join(timeout=5.0)
        self._save_timestamp()

    def _apply(self, key: bytes | None, timestamp: int = 0) -> None:
        """The key (None: none) on every endpoint, with one table of stream timestamps for all."""
        streams: dict = {}
        for state in self.states:
            state.set_key(key, timestamp)
            state.stream_timestamps = streams

    def _clock(self) -> int:
        return max(state.timestamp for state in self.states)

    def _load(self) -> None:
        if self.path is None:
            return
        try:
            saved = load_signing(self.path)
        except ValueError as exc:
            self.log(f"[autopilot] MAVLink signing: ignoring a broken key file, signing is OFF: {exc}")
            return
        if saved is None:
            self.log(f"[autopilot] MAVLink signing off (no key in {self.path})")
            return
        key, timestamp = saved
        self._apply(key, timestamp)
        self._saved_timestamp = timestamp
        self.log(f"[autopilot] MAVLink signing ON: key loaded from {self.path}; unsigned commands are refused")

    # ------------------------------------------------------------------ SETUP_SIGNING

    def _on_setup_signing(self, ep: LinkEndpoint, msg: mavlink.MAVLink_message) -> None:
        sender = f"{msg.get_srcSystem()}/{msg.get_srcComponent()}"
        if msg.target_system != self.sysid:  # (the link passes broadcasts, to 0, on; a key is never broadcast)
            self.send_statustext(mavlink.MAV_SEVERITY_WARNING, f"SETUP_SIGNING from {sender} refused: broadcast")
            return
        if self.enabled and not msg.get_signed():  # (the parser refuses these already; never take one)
            return
        raw = bytes(msg.secret_key)
        key = None if is_disabling_key(raw) else raw
        if key is None:
            self.disables += 1
            text = f"MAVLink signing off (key removed by {sender})"
        else:
            self.setups += 1
            text = f"MAVLink signing on (key from {sender})"
        with self._lock:
            self._apply(key, int(msg.initial_timestamp))
            self._store(key)
        self.send_statustext(mavlink.MAV_SEVERITY_NOTICE, text)  # (signed with the new key, if any)

    # ------------------------------------------------------------------ storage

    def _store(self, key: bytes | None) -> None:
        """The file after a change of key (caller holds the lock)."""
        if self.path is None:
            return
        try:
            if key is None:
                remove_signing(self.path)
            else:
                timestamp = self._clock()
                save_signing(self.path, key, timestamp, self.what)
                self._saved_timestamp = timestamp
        except OSError as exc:
            self.log(f"[autopilot] MAVLink signing: cannot update {self.path}: {exc}")
            self.send_statustext(mavlink.MAV_SEVERITY_ERROR, "MAVLink signing: key not saved (see the autopilot log)")

    def _save_timestamp(self) -> None:
        """Write the signing clock if a key is set and the clock moved since the last write."""
        with self._lock:
            key = self.states[0].secret_key
            timestamp = self._clock()
            if self.path is None or key is None or timestamp <= self._saved_timestamp:
                return
            try:
                save_signing(self.path, key, timestamp, self.what)
                self._saved_timestamp = timestamp
            except OSError as exc:
                self.log(f"[autopilot] MAVLink signing: cannot save the signing clock to {self.path}: {exc}")

    def _save_regularly(self) -> None:
        while not self._stop.wait(SAVE_INTERVAL_S):
            self._save_timestamp()
