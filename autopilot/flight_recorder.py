"""Flight logs of the flight-controller process: one ``.tlog`` and one ULog per arming.

``autopilot --log-dir DIR`` (default ``./logs``) writes, for every arming:

* ``DIR/<date>_<time>[_i<instance>].tlog``: every MAVLink message the ground-station
  link sent and received (:mod:`mavsim_core.tlog`), from ``PREARM_S`` before arming
  (so the arm command is in it) until ``POST_DISARM_S`` after disarming.  The link
  has two UDP endpoints (ground stations, APIs) that mostly carry the same
  telemetry; the API endpoint's copy of a message the ground-station endpoint has
  just sent with the same content is left out, so each message is logged once.
* ``DIR/<same stem>.ulg``: the flight as PX4 logs it (ULog, :mod:`autopilot.ulog_topics`): estimates,
  setpoints, motor outputs, modes and the precision landing, for pyulog, Flight Review, PlotJuggler
  and ``gcs plot``, served over MAVLink by :mod:`autopilot.mavlink.log_service`; ``SDLOG_MODE`` -1
  leaves it out (the tlog is still written).

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

from autopilot import ulog_topics
from autopilot.parameters import ParamDef, param
from autopilot.topics import ImuSample
from mavsim_core import ports, tlog
from mavsim_core.log_naming import flight_stem
from mavsim_core.param_types import ParamType

PREARM_S = 10.0  # simulated seconds of link traffic before arming kept in the flight's tlog
PREARM_MAX_PACKETS = 20_000  # bound on that buffer whatever the clock does
POST_DISARM_S = 1.0  # simulated seconds logged after disarming (the disarm ack, heartbeats)
STATUSTEXT_ID = 253  # MAVLink message id: the vehicle's STATUSTEXTs become the ULog's logged strings
ARM_TEXTS_US = 1_000_000  # the vehicle's STATUSTEXTs of the last second before arming go into the ULog too

# The parameters this module reads (listed in autopilot/param_catalogue.py).
PARAMS: tuple[ParamDef, ...] = (
    param(
        "SDLOG_MODE", 0, -1, 0, "", "ULog flight log (.ulg): -1 none, 0 from arming until disarming (PX4's other "
        "modes are not supported); read at each arming", ParamType.INT32,
    ),
)  # fmt: skip


def _say(text: str) -> None:
    print(f"[autopilot] {text}", flush=True)


class FlightRecorder:
    """Watches arming; writes the tlog (fed by :meth:`tap`) and the ULog (fed by :meth:`on_step`).

    Wire it with ``link.set_traffic_tap(recorder.tap)`` and call ``recorder.on_step(imu)``
    after every ``FlightController.step``; :meth:`close` at exit.  ``sysid`` (default: the
    instance's) and ``sys_uuid`` identify the vehicle in the ULog.
    """

    def __init__(
        self,
        log_dir: str | Path,
        fc,
        instance: int = 0,
        say: Callable[[str], None] = _say,
        epoch_s: Callable[[], float] = time.time,
        sysid: int | None = None,
        sys_uuid: str | None = None,
    ) -> None:
        self.log_dir = Path(log_dir)
        self.fc = fc
        self.instance = instance
        self.say = say
        self._epoch_s = epoch_s
        self.log_dir.mkdir(parents=True, exist_ok=True)
        self._pre: deque[tuple[int, bytes]] = deque(maxlen=PREARM_MAX_PACKETS)
        self._prearm_us = int(PREARM_S * 1e6)
        self._tlog: tlog.TlogWriter | None = None
        self._clock: tlog.SimEpochClock | None = None
        self._close_at_us: int | None = None
        self._gcs_sent: dict[int, bytes] = {}  # message id -> payload last sent on the "gcs" endpoint
        self.flights: list[str] = []  # stems of the flights logged so far
        self.disabled = False
        self.sysid = sysid if sysid is not None else ports.system_id(instance)
        self.sys_uuid = sys_uuid or f"4d415653{instance:08x}{self.sysid:08x}"  # "MAVS", instance, system id
        self._ulog: ulog_topics.FlightULog | None = None
        fc.params.subscribe(self._on_param)

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
                    if ip[0] == STATUSTEXT_ID and self._ulog is not None:
                        self._ulog.statustext(now_us, ip[1])
            if self._tlog is not None and self._clock is not None:  # (both made together)
                self._tlog.write(self._clock(now_us), packet)
            else:
                pre = self._pre
                pre.append((now_us, bytes(packet)))
                while now_us - pre[0][0] > self._prearm_us:
                    pre.popleft()
        except Exception as exc:  # never let logging take the flight controller down
            self._fail(exc)

    def on_step(self, imu: ImuSample | None = None) -> None:
        """After each control step (``imu``: its raw sample, for the ULog): start, record or end the flight's logs."""
        if self.disabled:
            return
        try:
            now = self.fc.last_us or 0
            armed = self.fc.commander.status.armed
            if armed and (self._tlog is None or self._close_at_us is not None):
                self._close()  # re-armed during the tail of the previous flight: a new flight
                self._open(now)
            elif not armed and self._tlog is not None and self._close_at_us is None:
                self._close_at_us = now + int(POST_DISARM_S * 1e6)
            if self._tlog is not None:  # a flight's files are open (the ULog too unless SDLOG_MODE is -1)
                if self._ulog is not None:
                    self._ulog.record(imu)
                if self._close_at_us is not None and now >= self._close_at_us:
                    self._close()
        except Exception as exc:
            self._fail(exc)

    # -- files ----------------------------------------------------------------------
    def _on_param(self, name: str, value: float) -> None:
        """A parameter changed: a 'P' message in the ULog being written."""
        if self._ulog is not None and not self.disabled:
            try:
                self._ulog.parameter_changed(name, value)
            except Exception as exc:
                self._fail(exc)

    @property
    def active(self) -> bool:
        return self._tlog is not None

    @property
    def writing(self) -> Path | None:
        """The ULog being written now (the log service lists it and never erases it), or None."""
        return self._ulog.path if self._ulog is not None else None

    def _open(self, now_us: int) -> None:
        epoch = self._epoch_s()
        stem = flight_stem(self.log_dir, epoch, self.instance, (tlog.SUFFIX, ulog_topics.SUFFIX))
        self._clock = tlog.SimEpochClock(now_us, int(epoch * 1e6))
        self._tlog = tlog.TlogWriter(self.log_dir / (stem + tlog.SUFFIX))
        self._close_at_us = None
        if self.fc.params.get("SDLOG_MODE") >= 0:
            self._ulog = ulog_topics.FlightULog(
                self.log_dir / (stem + ulog_topics.SUFFIX),
                self.fc,
                now_us,
                int(epoch * 1e6),
                self.sysid,
                sys_uuid=self.sys_uuid,
            )
        for t_us, packet in self._pre:
            self._tlog.write(self._clock(t_us), packet)
            if self._ulog is not None and now_us - t_us <= ARM_TEXTS_US:
                ip = tlog.packet_id_and_payload(packet)
                if ip is not None and ip[0] == STATUSTEXT_ID and packet[5] == self.sysid:  # ours: "Armed"...
                    self._ulog.statustext(t_us, ip[1])
        self._pre.clear()
        self.flights.append(stem)
        suffixes = ",".join((tlog.SUFFIX,) + ((ulog_topics.SUFFIX,) if self._ulog else ()))
        self.say(f"logging the flight to {self.log_dir / stem}{{{suffixes}}}")

    def _close(self) -> None:
        t, u = self._tlog, self._ulog
        self._tlog = self._ulog = None
        self._close_at_us = None
        try:
            if t is not None:
                t.close()
        finally:
            if u is not None:
                u.close()
                self.say(f"flight log closed: {u.path} ({u.writer.bytes_written} bytes)")

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
