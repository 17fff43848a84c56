"""End-to-end fuzz: random and hostile MAVLink at both ground-station ports while hovering (issue 18, "Done when").

Real ``sitl`` and ``autopilot`` processes (``--speed max``); the vehicle takes off and holds in AUTO.LOITER;
then :class:`mavlink_fuzz.Fuzzer` (tests/mavlink_fuzz.py, seeded) sends :data:`FRAMES` CRC-valid frames spread
over every message type of the common dialect (NaN, infinities and extremes in float fields, edge values in
integers; half addressed to ``stack.sysid``) and :data:`JUNK` junk datagrams, alternately to the flight
controller's "gcs" and "api" UDP ports, from one socket.  What must hold, as a user would check it:

- no crash: both processes alive, no traceback in the flight controller's log;
- no parameter changed: the full PARAM list (a ground station's download) is the same before and after;
- no mode or arming change: every HEARTBEAT during and after says armed, AUTO.LOITER;
- the hover held: the simulator's truth stays within :data:`HOVER_TOL_M` of where it was;
- what must be refused is refused: no COMMAND_ACK ACCEPTED for a command the vehicle acts on (all sent with an
  infinity in a parameter) nor for a SET_MODE (all with a custom mode PX4 does not have).

Which messages are sent only in refusable form, and the two left out (SETUP_SIGNING, LOG_ERASE: valid ones
legitimately change state), is explained in tests/mavlink_fuzz.py.
"""

from __future__ import annotations

import math
import socket
import time

import pytest
from mavlink_fuzz import MUST_REFUSE_ACKS, Fuzzer
from pymavlink.dialects.v20 import common as mavlink

from gcs.client import VehicleClient
from gcs.launcher import Stack
from gcs.sim_client import SimClient
from mavsim_core import ports

from e2e_flight_helpers import CLIENT_SPEED, Recorder  # tests/e2e_flight_helpers.py

pytestmark = pytest.mark.e2e
WAIT_S = 120.0  # wall-clock safety net of each wait
ALT_M = 5.0
HOVER_TOL_M = 0.4
FRAMES, JUNK = 10_000, 3_000
BURST = 40  # datagrams sent between two looks at the replies (a steady stream, not a flood)
SEED = 18


def param_values(client: VehicleClient) -> dict[str, tuple[float, int]]:
    """Every parameter's value and MAV_PARAM_TYPE, as a ground station downloads them."""
    return {p.name: (p.value, p.mav_type) for p in client.param_list(timeout_s=WAIT_S)}


def drain_acks(sock: socket.socket, parser: mavlink.MAVLink, acks: list) -> None:
    """Read what the flight controller answered the fuzzer; keep the COMMAND_ACKs."""
    while True:
        try:
            data = sock.recv(65536)
        except BlockingIOError:
            return
        for msg in parser.parse_buffer(data) or []:
            if msg.get_type() == "COMMAND_ACK":
                acks.append(msg)


def test_fuzzing_both_ports_while_hovering_changes_nothing(inst):
    with (
        Stack(instance=inst, speed=CLIENT_SPEED, flight_logs=False) as stack,
        SimClient(ports.sim_component_port(inst)) as truth,
        VehicleClient(stack.api_url, timeout_s=WAIT_S, idle=stack.check_alive) as client,
    ):
        truth.wait_connected()
        client.wait_until(client.prearm_ok, WAIT_S, "ready to arm")
        client.arm().check()
        client.takeoff(client.wait_home().alt_amsl_m + ALT_M).check()
        client.wait_until(lambda: client.mode_name() == "LOITER" and client.takeoff_done(ALT_M), WAIT_S, "hover")
        client.wait_sim_time(2.0)
        before = param_values(client)
        real32 = [name for name, (_, kind) in before.items() if kind == mavlink.MAV_PARAM_TYPE_REAL32]
        start = truth.now()  # (caught up: latest() may be seconds of simulated time behind on a loaded machine)
        hover, start_ms = start.pos_ned_m, start.time_ms

        fuzzer = Fuzzer(SEED, stack.sysid, real32)
        targets = [("127.0.0.1", ports.gcs_local_port(inst)), ("127.0.0.1", ports.api_local_port(inst))]
        sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
        sock.setblocking(False)
        parser = mavlink.MAVLink(None)
        parser.robust_parsing = True
        acks: list = []
        sent = 0
        t0 = time.monotonic()
        with Recorder(client, ("HEARTBEAT",)) as rec:
            try:
                for k, data in enumerate(fuzzer.datagrams(FRAMES, JUNK)):
                    sock.sendto(data, targets[k % 2])
                    sent += 1
                    if k % BURST == BURST - 1:
                        client.pump(0.002)
                        drain_acks(sock, parser, acks)
                wall_s = time.monotonic() - t0
                client.wait_sim_time(3.0)
                drain_acks(sock, parser, acks)
            finally:
                sock.close()
            stack.check_alive()
            states = {
                (m.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED != 0, m.custom_mode) for m in rec.of("HEARTBEAT")
            }
        truth.caught_up()  # the path up to now, not to where the reader had got
        path = truth.since(start_ms)
        worst = max(math.dist(s.pos_ned_m, hover) for s in path)
        after = param_values(client)
        log = stack.log_path("autopilot").read_text(errors="replace")
        said = [t.text for t in client.statustexts if t.severity <= mavlink.MAV_SEVERITY_WARNING or "Mode" in t.text]

    accepted = [a for a in acks if a.command in MUST_REFUSE_ACKS and a.result == mavlink.MAV_RESULT_ACCEPTED]
    print(
        f"fuzz: {sent} datagrams ({FRAMES} frames of {len(fuzzer.sent_types)} message types, {JUNK} junk) in "
        f"{wall_s:.1f} s wall; {len(acks)} COMMAND_ACKs; hover within {worst:.3f} m over {len(path)} truth samples"
    )
    assert len(fuzzer.sent_types) == len(fuzzer.types)  # every message type of the dialect went out
    assert "Traceback" not in log, log[log.index("Traceback") - 200 :][:3000]
    assert states == {(True, 4 << 16 | 3 << 24)}, f"HEARTBEAT (armed, custom_mode) seen: {states}; said {said[-8:]}"
    changed = {n: (before[n], after.get(n)) for n in before if after.get(n) != before[n]}
    assert not changed and set(after) == set(before), f"parameters changed: {changed}"
    assert not accepted, f"accepted what must be refused: {[(a.command, a.result) for a in accepted][:10]}"
    assert worst < HOVER_TOL_M, f"the hover moved {worst:.2f} m"
