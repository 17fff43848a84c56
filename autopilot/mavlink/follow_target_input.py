"""FOLLOW_TARGET (message 144) on the ground-station link -> the target AUTO.FOLLOW_TARGET flies after.

A :class:`~autopilot.mavlink.link_service.LinkService`: every FOLLOW_TARGET that arrives on either
endpoint (MAVSDK's FollowMe, a ground station's own GPS, the simulated ground vehicle's broadcast
to the API-side socket) is decoded by :func:`decode_follow_target` into a
:class:`~autopilot.navigation.follow_target_estimator.FollowTargetFix`, stamped with the simulated
time (the link's) and the wall clock of its arrival, and handed to the commander's inputs
(:meth:`autopilot.commander.external_inputs.ExternalInputs.on_follow_target`, which keeps the
sender being followed until it falls silent).

What is read, as PX4 reads it: ``lat``/``lon`` (degE7) and ``alt`` (m AMSL) when est_capabilities
has bit 0 (POS); ``vel`` (m/s NED) when its three values are finite (MAVSDK fills them from its
TargetLocation but sets only the POS bit); the heading from ``attitude_q`` (w, x, y, z) when bit 3
(ATT + RATES) is set and the quaternion is finite.  ``timestamp``, ``acc``, ``rates``,
``position_cov`` and ``custom_state`` are not used (MAVSDK sends a timestamp of 0).

FOLLOW_TARGET has no answer in the protocol: a message that cannot be used (no POS bit, a position
out of range or 0, 0, a non-finite altitude) is dropped, counted in ``refused``, and said once
per sender and reason as a STATUSTEXT warning.
"""

from __future__ import annotations

import math
import time
from typing import Callable, Protocol

import numpy as np
from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink.link_service import Handler, ServiceCommand
from autopilot.navigation.follow_target_estimator import FollowTargetFix

CAP_POS, CAP_VEL, CAP_ACCEL, CAP_ATT_RATES = 1, 2, 4, 8  # est_capabilities bits


class FollowTargetReceiver(Protocol):
    def on_follow_target(self, fix: FollowTargetFix) -> bool: ...


def _yaw(q: list[float]) -> float:
    """Heading (rad from north) of a (w, x, y, z) quaternion FRD -> NED, NaN if it is not a rotation."""
    w, x, y, z = (float(v) for v in q)
    if not all(math.isfinite(v) for v in (w, x, y, z)) or w * w + x * x + y * y + z * z < 1e-6:
        return math.nan
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def decode_follow_target(msg: mavlink.MAVLink_message, now_us: int, wall_s: float) -> FollowTargetFix | str:
    """The fix of a FOLLOW_TARGET received at ``now_us`` (simulated µs) and ``wall_s``, or why it is unusable."""
    caps = int(msg.est_capabilities)
    if not caps & CAP_POS:
        return "no position (est_capabilities bit 0 clear)"
    if not (-900_000_000 <= msg.lat <= 900_000_000 and -1_800_000_000 <= msg.lon <= 1_800_000_000):
        return f"position out of range (lat {msg.lat}, lon {msg.lon} degE7)"
    if msg.lat == 0 and msg.lon == 0:
        return "position 0, 0 (no fix)"
    if not math.isfinite(msg.alt):
        return "altitude not finite"
    vel = np.array([float(v) for v in msg.vel])
    if not np.all(np.isfinite(vel)):
        vel = np.full(3, math.nan)
    yaw = _yaw(msg.attitude_q) if caps & CAP_ATT_RATES else math.nan
    source = (msg.get_srcSystem(), msg.get_srcComponent())
    return FollowTargetFix(now_us, wall_s, source, msg.lat * 1e-7, msg.lon * 1e-7, float(msg.alt), vel, yaw, caps)


class FollowTargetInput:
    """The FOLLOW_TARGET service (see the module docstring): ``receiver`` gets each usable fix;
    ``now_us()`` is the link's simulated time; ``say(severity, text)`` a STATUSTEXT."""

    def __init__(
        self,
        receiver: FollowTargetReceiver,
        now_us: Callable[[], int],
        say: Callable[[int, str], None],
        wall_clock: Callable[[], float] = time.monotonic,
    ) -> None:
        self.receiver, self.now_us, self.say, self.wall_clock = receiver, now_us, say, wall_clock
        self.received = 0  # usable messages
        self.ignored = 0  # usable, from a sender other than the one followed (still fresh)
        self.refused = 0  # unusable
        self._said: set[tuple[tuple[int, int], str]] = set()

    def handlers(self) -> dict[str, Handler]:
        return {"FOLLOW_TARGET": self._on_follow_target}

    def commands(self) -> dict[int, ServiceCommand]:
        return {}

    def update(self, now_us: int) -> None:
        pass

    def _on_follow_target(self, ep: object, msg: mavlink.MAVLink_message) -> None:
        fix = decode_follow_target(msg, self.now_us(), self.wall_clock())
        if isinstance(fix, str):
            self.refused += 1
            key = ((msg.get_srcSystem(), msg.get_srcComponent()), fix)
            if key not in self._said:
                self._said.add(key)
                self.say(mavlink.MAV_SEVERITY_WARNING, f"FOLLOW_TARGET from {key[0][0]}/{key[0][1]} ignored: {fix}")
            return
        self.received += 1
        if not self.receiver.on_follow_target(fix):
            self.ignored += 1
