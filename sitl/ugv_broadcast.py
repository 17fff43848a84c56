"""The ground vehicle's telemetry radio: its GPS position and velocity as FOLLOW_TARGET, to the flight controller.

With ``SIM_UGV_FLW`` = 1 the UGV sends FOLLOW_TARGET (message 144) at ``SIM_UGV_FLW_HZ`` of simulated
time (5 Hz by default, as a GPS receiver's fixes) to the flight controller's API-side socket (UDP
14640+N, :func:`mavsim_core.ports.api_local_port`; ``sitl --ugv-radio-port``), as a ground vehicle
with a GPS and a telemetry radio would, so the multicopter can follow it in AUTO.FOLLOW_TARGET: the
approach that starts the vision landing on its deck.  It sends as the UGV's own MAVLink identity,
the vehicle's system id (1+N) with component 52 (the ids of its truth on the simulator's port).

The message: ``timestamp`` the simulated time (ms), ``est_capabilities`` POS | VEL | ATT_RATES,
``lat``/``lon`` (degE7) and ``alt`` (m AMSL) of the deck's centre (where the marker is), ``vel`` its
velocity over ground (m/s NED), ``attitude_q`` its heading as a (w, x, y, z) quaternion; acceleration,
rates and covariances unknown (NaN).  The values are the simulator's truth: the radio models the
link, not a GPS error.

The socket is the radio's own (an ephemeral port): the flight controller takes it for a client and
sends it telemetry, which the radio drops unread (a small receive buffer, drained on each send).
No clock: :meth:`UgvRadio.step` is called with the simulated time.
"""

from __future__ import annotations

import math
import socket
from typing import Callable

from pymavlink.dialects.v20 import common as mavlink

from mavsim_core.geodesy import ned_to_geodetic
from sitl.param_server import UGV_COMPID
from sitl.sim_settings import UgvSettings
from sitl.ugv_world import UgvTruth

CAPABILITIES = 1 | 2 | 8  # est_capabilities: POS, VEL, ATT + RATES
RX_BUFFER_BYTES = 4096  # the flight controller's telemetry to this socket is dropped
NAN3 = [math.nan] * 3


def follow_target_message(t: UgvTruth, home: tuple[float, float, float]) -> mavlink.MAVLink_follow_target_message:
    """FOLLOW_TARGET for the UGV's truth; ``home``: (lat deg, lon deg, alt m AMSL) of the truth frame's origin."""
    lat, lon, alt = ned_to_geodetic(t.deck_pos_ned_m, *home)
    half = 0.5 * t.yaw_rad
    return mavlink.MAVLink_follow_target_message(
        t.time_us // 1000,
        CAPABILITIES,
        round(lat * 1e7),
        round(lon * 1e7),
        alt,
        [float(v) for v in t.vel_ned_m_s],
        NAN3,
        [math.cos(half), 0.0, 0.0, math.sin(half)],
        NAN3,
        NAN3,
        0,
    )


class UgvRadio:
    """Sends the UGV's FOLLOW_TARGET to ``dest`` while ``settings.follow_target`` is 1 (module docstring)."""

    def __init__(
        self, settings: UgvSettings, dest: tuple[str, int], sysid: int, home: tuple[float, float, float]
    ) -> None:
        self.settings, self.dest, self.home = settings, dest, home
        self.sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        self.sock.setblocking(False)
        try:
            self.sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, RX_BUFFER_BYTES)
        except OSError:
            pass
        self.sock.bind(("0.0.0.0", 0))
        self.mav = mavlink.MAVLink(None, sysid, UGV_COMPID)
        self.next_us = 0
        self.sent = 0
        self.tx_errors = 0

    def step(self, time_us: int, truth: Callable[[], UgvTruth | None]) -> None:
        """Send if enabled and due at simulated ``time_us``; ``truth()`` gives the UGV's state (called only then)."""
        if not self.settings.follow_target or time_us < self.next_us:
            return
        state = truth()
        if state is None:
            return
        period_us = max(1, round(1e6 / self.settings.follow_rate_hz))
        self.next_us = (time_us // period_us + 1) * period_us
        self._drain()
        data = follow_target_message(state, self.home).pack(self.mav)
        self.mav.seq = (self.mav.seq + 1) % 256
        try:
            self.sock.sendto(data, self.dest)
            self.sent += 1
        except OSError:  # nobody listening yet, buffer full: a radio loses packets
            self.tx_errors += 1

    def _drain(self) -> None:
        for _ in range(64):
            try:
                self.sock.recv(65536)
            except OSError:
                return

    def close(self) -> None:
        self.sock.close()
