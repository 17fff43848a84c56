"""The estimate a delayed measurement is compared with: a filter's recent states, interpolated in time.

A history is a time-ordered sequence of ``(time_us, position, velocity)`` entries (NED m and m/s,
sample time stamps in µs), one per filter run (50 Hz for the EKF).  A GPS fix describes the vehicle
``EKF2_GPS_DELAY`` before its time stamp (the receiver's latency); its innovation is taken against
the state of that time, linearly interpolated between the two runs around it, so the delay need
not be a multiple of the filter period (at 5 m/s, 10 ms of mismatch is 5 cm of false innovation).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

TOLERANCE_US = 60_000  # outside the history by more than this: no state (the caller uses the current one)


def state_at(
    history: Sequence[tuple[int, np.ndarray, np.ndarray]], time_us: int, tolerance_us: int = TOLERANCE_US
) -> tuple[np.ndarray, np.ndarray] | tuple[None, None]:
    """(position, velocity) at ``time_us``: interpolated between the entries around it, the nearest end's
    if it lies outside the history by at most ``tolerance_us``, else (None, None)."""
    n = len(history)
    if n == 0:
        return None, None
    newer = None
    for k in range(n - 1, -1, -1):  # newest first: a delayed fix is a few entries back
        entry = history[k]
        if entry[0] <= time_us:
            if newer is None:
                return (entry[1], entry[2]) if time_us - entry[0] <= tolerance_us else (None, None)
            span = newer[0] - entry[0]
            w = (time_us - entry[0]) / span if span > 0 else 0.0
            return entry[1] + w * (newer[1] - entry[1]), entry[2] + w * (newer[2] - entry[2])
        newer = entry
    oldest = history[0]
    return (oldest[1], oldest[2]) if oldest[0] - time_us <= tolerance_us else (None, None)
