"""A retransmitted COMMAND_LONG gets its first answer again (autopilot/mavlink/command_retries.py).

Pure: a fake wall clock, no sockets.  The link's use of it is tested end to end in
tests/test_e2e_gcs_lossy.py (a NAV_TAKEOFF resent while the vehicle climbs).
"""

from __future__ import annotations

import math

from autopilot.mavlink.command_retries import RETRANSMIT_WINDOW_S, RetransmittedCommands

TAKEOFF, ARM = 22, 400
ACCEPTED, DENIED = 0, 2
GCS, OTHER = (255, 190), (254, 1)
NAN = math.nan
PARAMS = (NAN, 0.0, 0.0, NAN, NAN, NAN, 500.0)


class Clock:
    def __init__(self) -> None:
        self.t = 100.0

    def __call__(self) -> float:
        return self.t


def test_a_copy_with_confirmation_gets_the_earlier_result():
    clock = Clock()
    r = RetransmittedCommands(clock)
    assert r.earlier_result(GCS, TAKEOFF, PARAMS, 1) is None  # nothing carried out yet
    r.carried_out(GCS, TAKEOFF, PARAMS, ACCEPTED)
    clock.t += 0.5
    assert r.earlier_result(GCS, TAKEOFF, PARAMS, 1) == ACCEPTED  # NaN params equal NaN params
    assert r.earlier_result(GCS, TAKEOFF, PARAMS, 255) == ACCEPTED


def test_first_transmissions_others_and_old_results_are_carried_out():
    clock = Clock()
    r = RetransmittedCommands(clock)
    r.carried_out(GCS, TAKEOFF, PARAMS, DENIED)
    assert r.earlier_result(GCS, TAKEOFF, PARAMS, 0) is None  # confirmation 0: a new command
    assert r.earlier_result(OTHER, TAKEOFF, PARAMS, 1) is None  # another sender's
    assert r.earlier_result(GCS, ARM, PARAMS, 1) is None  # another command
    assert r.earlier_result(GCS, TAKEOFF, PARAMS[:6] + (501.0,), 1) is None  # other params
    assert r.earlier_result(GCS, TAKEOFF, PARAMS, 1) == DENIED
    clock.t += RETRANSMIT_WINDOW_S + 0.1
    assert r.earlier_result(GCS, TAKEOFF, PARAMS, 1) is None  # too old: carried out again
    r.carried_out(GCS, ARM, (1.0,) + (0.0,) * 6, ACCEPTED)  # only the last command of a sender is kept
    assert r.earlier_result(GCS, TAKEOFF, PARAMS, 1) is None


def test_the_table_forgets_old_senders():
    clock = Clock()
    r = RetransmittedCommands(clock)
    for sysid in range(1, 70):
        r.carried_out((sysid, 1), ARM, PARAMS, ACCEPTED)
        clock.t += 1.0
    assert len(r._last) <= 64 and r.earlier_result((69, 1), ARM, PARAMS, 1) == ACCEPTED
