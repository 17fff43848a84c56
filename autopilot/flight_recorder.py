"""Flight logs of the flight-controller process: one ``.tlog`` and one control-rate log per arming.

``autopilot --log-dir DIR`` (default ``./logs``) writes, for every arming:

* ``DIR/<date>_<time>[_i<instance>].tlog``: every MAVLink message the ground-station
  link sent and received (:mod:`mavsim_core.tlog`), from ``PREARM_S`` before arming
  (so the arm command is in it) until ``POST_DISARM_S`` after disarming.  The link
  has two UDP endpoints (ground stations, APIs) that mostly carry the same
  telemetry; the API endpoint's copy of a message the ground-station endpoint has
  just sent with the same content is left out, so each message is logged once.
* ``DIR/<same stem>.fc.npy``: setpoints, estimates and motor outputs of every
  control step (:mod:`autopilot.flight_log`).

Names use the local wall-clock time of arming (like QGroundControl's tlogs); a
second flight in the same second gets ``_2``, ``_3``...  This is process-loop code:
it touches files and the wall clock (only to name files and anchor tlog times),
never the controllers.  Logging never stops the flight: any I/O error is reported
once and logging is switched off.
"""

from __future__ import annotations

import sys
import time
from collections import deque
from pathlib import Path
from typing import Callable

from autopilot import flight_log
from mavsim_core import tlog
from mavsim_core.log_naming import flight_stem

PREARM_S = 10.0  # simulated seconds of link traffic before arming kept in the flight's tlog
PREARM_MAX_PACKETS = 20_000  # bound on that buffer whatever the clock does
POST_DISARM_S = 1.0  # simulated seconds logged after disarming (the disarm ack, heartbeats)


def _say(text: str) -> None:
    print(f"[autopilot] {text}", flush=True)


class FlightRecorder:
    """Watches arming; writes the tlog (fed by :meth:`tap`) and the control log (fed by :meth:`on_step`).

    Wire it with ``link.set_traffic_tap(recorder.tap)`` and call ``recorder.on_step()``
    after every ``FlightController.step``; :meth:`close` at exit.
    """

    def __init__(
        self,
        log_dir: str | Path,
        fc,
        instance: int = 0,
        every: int = 1,
        say: Callable[[str], None] = _say,
        epoch_s: Callable[[], float] = time.time,
    ) -> None:
        self.log_dir = Path(log_dir)
        self.fc = fc
        self.instance = instance
        self.every = every
        self.say = say
        self._epoch_s = epoch_s
        self.log_dir.mkdir(parents=True, exist_ok=True)
        self._pre: deque[tuple[int, bytes]] = deque(maxlen=PREARM_MAX_PACKETS)
        self._prearm_us = int(PREARM_S * 1e6)
        self._tlog: tlog.TlogWriter | None = None
        self._flog: flight_log.FlightLogWriter | None = None
        self._clock: tlog.SimEpochClock | None = None
        self._close_at_us: int | None = None
        self._gcs_sent: dict[int, bytes] = {}  # message id -> payload last sent on the "gcs" endpoint
        self.flights: list[str] = []  # stems of the flights logged so far
        self.disabled = False

    # -- inputs ---------------------------------------------------------------------
    def tap(self, now_us: int, endpoint: str, sent: bool, packet: bytes) -> None:
        """GcsLink traffic tap (see :meth:`autopilot.mavlink.link.GcsLink.set_traffic_tap`)."""
        if self.disabled:
            return
        try:
            if sent:
                ip = tlog.packet_id_and_payload(packet)
                if ip is not None:
                    if endpoint == "gcs":
                        self._gcs_sent[ip[0]] = ip[1]
                    elif self._gcs_sent.get(ip[0]) == ip[1]:
                        return  # the API endpoint's copy of what the ground stations just got
            if self._tlog is not None:
                self._tlog.write(self._clock(now_us), packet)
            else:
                pre = self._pre
                pre.append((now_us, bytes(packet)))
                while now_us - pre[0][0] > self._prearm_us:
                    pre.popleft()
        except Exception as exc:  # never let logging take the flight controller down
            self._fail(exc)

    def on_step(self) -> None:
        """After each control step: start, record or end the flight's logs."""
        if self.disabled:
            return
        try:
            now = self.fc.last_us or 0
            armed = self.fc.commander.status.armed
            if armed and (self._flog is None or self._close_at_us is not None):
                self._close()  # re-armed during the tail of the previous flight: a new flight
                self._open(now)
            elif not armed and self._flog is not None and self._close_at_us is None:
                self._close_at_us = now + int(POST_DISARM_S * 1e6)
            if self._flog is not None:
                self._flog.record()
                if self._close_at_us is not None and now >= self._close_at_us:
                    self._close()
        except Exception as exc:
            self._fail(exc)

    # -- files ----------------------------------------------------------------------
    @property
    def active(self) -> bool:
        return self._flog is not None

    def _open(self, now_us: int) -> None:
        epoch = self._epoch_s()
        stem = flight_stem(self.log_dir, epoch, self.instance, (tlog.SUFFIX, flight_log.SUFFIX))
        self._clock = tlog.SimEpochClock(now_us, int(epoch * 1e6))
        self._tlog = tlog.TlogWriter(self.log_dir / (stem + tlog.SUFFIX))
        self._flog = flight_log.FlightLogWriter(self.log_dir / (stem + flight_log.SUFFIX), self.fc, self.every)
        self._close_at_us = None
        for t_us, packet in self._pre:
            self._tlog.write(self._clock(t_us), packet)
        self._pre.clear()
        self.flights.append(stem)
        self.say(f"logging the flight to {self.log_dir / stem}{{{tlog.SUFFIX},{flight_log.SUFFIX}}}")

    def _close(self) -> None:
        t, f = self._tlog, self._flog
        self._tlog = self._flog = None
        self._close_at_us = None
        try:
            if t is not None:
                t.close()
        finally:
            if f is not None:
                f.close()
                self.say(f"flight log closed: {f.path} ({f.writer.rows_written} rows)")

    def _fail(self, exc: BaseException) -> None:
        self.disabled = True
        print(f"[autopilot] flight logging stopped: {exc!r}", file=sys.stderr, flush=True)
        try:
            self._close()
        except Exception:
            pass

    def close(self) -> None:
        """Close the current flight's files (at exit)."""
        try:
            self._close()
        except Exception as exc:
            print(f"[autopilot] closing the flight log failed: {exc!r}", file=sys.stderr, flush=True)
