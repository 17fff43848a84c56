"""When the deck's next turn change is due: the rhythm of its manoeuvres, so that a landing does not dock into one.

Why (issue 34, figure-8 of 2 m lobes at 2 m/s, calm, 30 landings, kept truth logs): 12 of the 15 failures had the
deck reverse its turn (+1 -> -1.6 rad/s) in the last 0.15-0.5 s before the first foot touched, the feet 9-36 cm
above it; the vehicle, square to the deck until then, touched 20-36 deg off square and left feet over the edge.
quad_x cannot follow such a reversal: with the chase's tilt taking most of the motors' range it yaws at 0.3-0.4
rad/s^2, and stopping a 2 rad/s difference takes it 5 s.  What it can do is not start the last second then.

A turn change: the deck's turn rate (rad/s, clockwise from above; the deck model's, as precland's TurnRate gives
it) more than CHANGE_RAD_S away from the rate its current segment settled on, for CONFIRM_S in a row; the change is
dated to the first sample away.  The next change is expected one segment later: the latest change plus the time
between the two before it (a figure-8's lobes, a track driven again; a random path's next leg may differ, which
only costs a landing the wait).  A change not seen OVERDUE_S after it was due is no longer expected.

Pure: time is an input (microseconds).
"""

from __future__ import annotations

import math
from collections import deque

CHANGE_RAD_S = 0.5  # a turn rate this far from the segment's: a change (a 3 m arc at 2 m/s turns at 0.67 rad/s)
CONFIRM_S = 0.1  # ... held this long
SETTLE_S = 0.3  # the segment's rate follows the turn rate over this time constant (s) while no change is under way
OVERDUE_S = 0.5  # an expected change not seen this long after it was due is dropped
MIN_SEGMENT_S = 1.0  # two changes closer than this are one (the deck model settling on the new turn)


class TurnRhythm:
    """See the module docstring: feed :meth:`add` each new turn rate, ask :meth:`clear`."""

    def __init__(self) -> None:
        self._changes: deque[int] = deque(maxlen=3)  # times (us) of the latest changes
        self._rate: float | None = None  # the current segment's turn rate, rad/s
        self._last_us: int | None = None
        self._away_since_us: int | None = None  # first sample away from the segment's rate

    def add(self, t_us: int, turn_rad_s: float) -> None:
        """The deck's turn rate (rad/s) at ``t_us``; samples out of time order or not finite are ignored."""
        if not math.isfinite(turn_rad_s) or (self._last_us is not None and t_us <= self._last_us):
            return
        dt_s = 0.0 if self._last_us is None else (t_us - self._last_us) * 1e-6
        self._last_us = t_us
        if self._rate is None:
            self._rate = turn_rad_s
            return
        if abs(turn_rad_s - self._rate) <= CHANGE_RAD_S:
            self._away_since_us = None
            self._rate += (turn_rad_s - self._rate) * min(1.0, dt_s / SETTLE_S)
            return
        if self._away_since_us is None:
            self._away_since_us = t_us
        if (t_us - self._away_since_us) * 1e-6 >= CONFIRM_S:
            if not self._changes or (self._away_since_us - self._changes[-1]) * 1e-6 >= MIN_SEGMENT_S:
                self._changes.append(self._away_since_us)
            self._rate, self._away_since_us = turn_rad_s, None

    def next_change_us(self, now_us: int) -> int | None:
        """When the next turn change is expected (us), None when no rhythm is known or the expected one is
        overdue by OVERDUE_S."""
        if len(self._changes) < 2:
            return None
        due = self._changes[-1] + (self._changes[-1] - self._changes[-2])
        return None if (now_us - due) * 1e-6 > OVERDUE_S else due

    def steady_s(self, now_us: int) -> float:
        """How long (s) since the latest turn change was dated (infinite before the first, 0 while one is under
        way)."""
        if self._away_since_us is not None:
            return 0.0
        return math.inf if not self._changes else max(0.0, (now_us - self._changes[-1]) * 1e-6)

    def clear(self, now_us: int, span_s: float) -> bool:
        """True when no turn change is expected within ``span_s`` from now (nor one overdue by less than
        OVERDUE_S)."""
        due = self.next_change_us(now_us)
        return due is None or (due - now_us) * 1e-6 > span_s
