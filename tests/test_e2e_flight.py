"""End-to-end: the real simulator and flight controller, flown over real sockets, on one shared stack.

Every test here uses the real ``sitl`` and ``autopilot`` processes (through
:class:`gcs.launcher.Stack`) and talks MAVLink to the flight controller the way a
ground station does: :class:`gcs.client.VehicleClient` (pymavlink underneath) on
the API port, a second client on the ground-station port, the ``gcs`` CLI as a
subprocess.  Ground truth comes from the simulator's own UDP channel
(HIL_STATE_QUATERNION + LOCAL_POSITION_NED on 14740 + instance) and is compared
with what the vehicle reports; it never reaches the flight controller.

One max-speed stack (module scope) carries the scenarios in file order; each
flight scenario starts and ends landed and disarmed.  Durations the vehicle must
hold are simulated seconds (its clock); wall-clock values are only "give up
waiting" timeouts.  The scenarios that start their own stacks (arming before the
estimate is ready, the flight demo) are in tests/test_e2e_flight_own_stacks.py;
the helpers of both files in tests/e2e_flight_helpers.py.

Instance: a free one, leased for this file (the ``inst`` fixture of tests/conftest.py; tests/instances.py
says which ports an instance uses).
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import pytest

from gcs import geo
from gcs.client import VehicleClient, mavlink
from gcs.errors import ParamRefused, ParamUnknown
from gcs.launcher import Stack, StackError
from gcs.sim_client import SimClient

ROOT = Path(__file__).resolve().parent.parent

from mavsim_core import ports

from e2e_flight_helpers import (  # tests/e2e_flight_helpers.py
    IN_AIR,
    LANDING,
    ON_GROUND,
    WAIT_S,
    Recorder,
    arm,
    horizontal,
    text_time,
    texts_since,
    truth_after,
    wait_hovering,
    wait_text,
)

pytestmark = pytest.mark.e2e

UNKNOWN_COMMAND = 31010  # MAV_CMD_USER_1: nobody implements it


# --------------------------------------------------------------------------- fixtures


@pytest.fixture(scope="module")
def truth(inst):
    listener = SimClient(ports.sim_component_port(inst))  # ground truth on the simulator's own port
    yield listener
    listener.close()


@pytest.fixture(scope="module")
def stack(inst, truth):
    with Stack(instance=inst) as s:  # speed "max" is the default
        yield s


@pytest.fixture(scope="module")
def vehicle(stack):
    """A client on the API port (14540 + instance), once the vehicle is ready to arm."""
    with VehicleClient(stack.api_url, timeout_s=WAIT_S, idle=stack.check_alive) as c:
        c.wait_until(c.prearm_ok, WAIT_S, "ready to arm")
        c.wait_home(WAIT_S)
        yield c


@pytest.fixture
def client(vehicle):
    """The shared client, once the vehicle is landed, disarmed and ready; brought down after a failed flight."""
    vehicle.wait_until(
        lambda: vehicle.landed_and_disarmed() and vehicle.prearm_ok(),
        WAIT_S,
        "the vehicle to be on the ground, disarmed and ready",
    )
    yield vehicle
    if vehicle.armed():  # a failed flight: bring it down so the next scenario starts clean
        try:
            vehicle.land(timeout_s=10)
            vehicle.wait_until(vehicle.landed_and_disarmed, WAIT_S, "landing after a failed test")
        except Exception:
            vehicle.disarm(force=True, timeout_s=10)


# --------------------------------------------------------------------------- on the shared max-speed stack


def test_second_stack_on_a_busy_instance_is_refused(stack):
    with pytest.raises(StackError, match="already in use"):
        Stack(instance=stack.instance).start()
    assert stack.exited() == {}


def test_identity_modes_and_unknown_command(client):
    hb = client.latest("HEARTBEAT")
    assert hb.autopilot == mavlink.MAV_AUTOPILOT_PX4 and hb.type == mavlink.MAV_TYPE_QUADROTOR
    # (c) a command nobody implements is answered, not ignored
    res = client.command_long(UNKNOWN_COMMAND, 1, 2, 3, timeout_s=10)
    assert res.result == mavlink.MAV_RESULT_UNSUPPORTED
    res = client.command_long(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_ADSB_VEHICLE, timeout_s=10)
    assert res.result == mavlink.MAV_RESULT_UNSUPPORTED
    # mode changes on the ground, MAVSDK's way (DO_SET_MODE) and QGroundControl's way (SET_MODE)
    client.set_mode("AUTO.LOITER", timeout_s=10).check()
    client.wait_mode("LOITER", WAIT_S)
    posctl = 3 << 16
    client.conn.mav.set_mode_send(client.target_system, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, posctl)
    ack = client.recv("COMMAND_ACK", WAIT_S, lambda m: m.command == mavlink.MAVLINK_MSG_ID_SET_MODE)
    assert ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED
    client.wait_mode("POSCTL", WAIT_S)
    assert client.latest("HEARTBEAT").custom_mode == posctl


def test_parameters_int32_and_real32(client):
    assert client.param_get("SYS_AUTOSTART", timeout_s=10) == 4001
    assert isinstance(client.param_get("SYS_AUTOSTART"), int)
    assert client.param_get("MIS_TAKEOFF_ALT", timeout_s=10) == pytest.approx(2.5)
    try:
        assert client.param_set("MIS_TAKEOFF_ALT", 3.25, timeout_s=10) == pytest.approx(3.25)
        assert client.param_get("MIS_TAKEOFF_ALT", timeout_s=10) == pytest.approx(3.25)
        with pytest.raises(ParamRefused, match=r"MIS_TAKEOFF_ALT.*kept 3\.25.*outside range"):
            client.param_set("MIS_TAKEOFF_ALT", 500.0, timeout_s=10)
    finally:
        client.param_set("MIS_TAKEOFF_ALT", 2.5, timeout_s=10)
    with pytest.raises(ParamUnknown, match="unknown parameter NO_SUCH_PARAM"):  # PARAM_ERROR, or the STATUSTEXT
        client.param_get("NO_SUCH_PARAM", timeout_s=10.0)
    assert any("unknown parameter NO_SUCH_PARAM" in t for t in texts_since(client, 0))


def test_two_ground_stations_at_once(stack, client):
    """(d) QGroundControl's port and MAVSDK's port at the same time, each heard and obeyed."""
    with VehicleClient(stack.gcs_url, timeout_s=WAIT_S, idle=stack.check_alive) as gcs:
        for c in (gcs, client):
            c.wait_until(
                lambda c=c: c.latest("HEARTBEAT") is not None and c.latest("GLOBAL_POSITION_INT"), WAIT_S, "telemetry"
            )
            assert c.latest("HEARTBEAT").autopilot == mavlink.MAV_AUTOPILOT_PX4
        try:
            # one sets, the other reads back
            assert client.param_set("MPC_XY_CRUISE", 4.5, timeout_s=10) == pytest.approx(4.5)
            assert gcs.param_get("MPC_XY_CRUISE", timeout_s=10) == pytest.approx(4.5)
            # each gets the acknowledgement of its own command, and both are obeyed
            assert gcs.command_long(UNKNOWN_COMMAND, timeout_s=10).result == mavlink.MAV_RESULT_UNSUPPORTED
            assert client.set_mode("AUTO.LOITER", timeout_s=10).accepted
            for c in (gcs, client):
                c.wait_mode("LOITER", WAIT_S)
            assert gcs.set_mode("POSCTL", timeout_s=10).accepted
            for c in (gcs, client):
                c.wait_mode("POSCTL", WAIT_S)
        finally:
            client.param_set("MPC_XY_CRUISE", 3.0, timeout_s=10)


def test_param_set_after_another_station_changed_it(stack, client):
    """A station that saw another's change can still set the parameter (QGroundControl + MAVSDK)."""
    with VehicleClient(stack.gcs_url, timeout_s=WAIT_S, idle=stack.check_alive) as gcs:
        try:
            client.param_set("MPC_XY_CRUISE", 4.5, timeout_s=10)
            assert gcs.param_get("MPC_XY_CRUISE", timeout_s=10) == pytest.approx(4.5)
            assert gcs.param_set("MPC_XY_CRUISE", 3.5, timeout_s=10) == pytest.approx(3.5)
        finally:
            client.pump(0.2)  # (drop queued echoes so the restore below is not confused by the same bug)
            client.param_set("MPC_XY_CRUISE", 3.0, timeout_s=10)
            assert client.param_get("MPC_XY_CRUISE", timeout_s=10) == pytest.approx(3.0)


def test_takeoff_hover_land_and_automatic_disarm(client, truth):
    """(b) + (f): take off to 5 m, hold 10 s, land; the vehicle disarms by itself.  Truth agrees."""
    home = client.wait_home(WAIT_S)
    disarm_delay_s = 3.0
    client.param_set("COM_DISARM_LAND", disarm_delay_s, timeout_s=10)
    try:
        ground = truth.latest()
        assert ground is not None, "no ground truth on UDP 14740 + instance"
        assert abs(ground.vel_ned_m_s[2]) < 0.05
        arm(client)
        n_texts = len(client.statustexts)
        client.takeoff(home.alt_amsl_m + 5.0, timeout_s=10).check()
        wait_hovering(client, 5.0)
        assert client.relative_alt_m() == pytest.approx(5.0, abs=0.5)

        with Recorder(client, ("GLOBAL_POSITION_INT", "LOCAL_POSITION_NED", "ATTITUDE")) as rec:
            client.wait_sim_time(10.0, WAIT_S, "10 s of hover")
        gpi, lpn = rec.of("GLOBAL_POSITION_INT"), rec.of("LOCAL_POSITION_NED")
        assert len(gpi) >= 40 and len(lpn) >= 40  # 5 Hz for 10 simulated seconds
        alts = [m.relative_alt / 1000.0 for m in gpi]
        assert max(abs(a - 5.0) for a in alts) <= 0.3
        assert max(abs(-m.z - (-lpn[0].z)) for m in lpn) <= 0.3
        drift = max(math.hypot(m.x - lpn[0].x, m.y - lpn[0].y) for m in lpn)
        assert drift < 0.5
        start = (gpi[0].lat * 1e-7, gpi[0].lon * 1e-7, 0.0)
        assert max(horizontal(geo.global_to_ned(*start, m.lat * 1e-7, m.lon * 1e-7, 0.0), (0, 0)) for m in gpi) < 0.5
        assert max(abs(m.roll) + abs(m.pitch) for m in rec.of("ATTITUDE")) < math.radians(5)
        assert client.mode_name() == "LOITER" and client.landed_state() == IN_AIR

        # (f) ground truth: nearest simulated instants (within 10 ms), height above the ground truth had before take-off
        pairs = [(m.relative_alt / 1000.0, truth.at(m.time_boot_ms)) for m in gpi]
        pairs = [(alt, t) for alt, t in pairs if t is not None]
        assert len(pairs) >= 0.8 * len(gpi)
        for alt, t in pairs:
            assert -(t.pos_ned_m[2] - ground.pos_ned_m[2]) == pytest.approx(alt, abs=0.3)
        true_drift = max(horizontal(t.pos_ned_m, pairs[0][1].pos_ned_m) for _, t in pairs)
        assert true_drift < 0.5
        att = truth.latest_state
        assert att is not None and att.time_usec > 0
        w, x, y, z = att.attitude_quaternion
        assert 1 - 2 * (x * x + y * y) > math.cos(math.radians(5))  # truly level (body z near vertical)

        with Recorder(client, ("EXTENDED_SYS_STATE", "HEARTBEAT")) as rec:
            client.land(timeout_s=10).check()
            client.wait_until(client.landed_and_disarmed, WAIT_S, "landing and the automatic disarm")
        states = [m.landed_state for m in rec.of("EXTENDED_SYS_STATE")]
        assert LANDING in states and states[-1] == ON_GROUND
        # ON_GROUND was reported while still armed: landed first, then disarmed by itself
        seq = [
            (
                m.get_type(),
                m.landed_state
                if m.get_type() == "EXTENDED_SYS_STATE"
                else bool(m.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED),
            )
            for _, m in rec.msgs
        ]
        first_ground = seq.index(("EXTENDED_SYS_STATE", ON_GROUND))
        assert ("HEARTBEAT", True) in seq[first_ground:]
        texts = texts_since(client, n_texts)
        assert "Landing detected" in texts and "Disarmed (landed)" in texts
        assert not any("Disarmed (command)" in t for t in texts)
        delay = text_time(client, n_texts, "Disarmed (landed)") - text_time(client, n_texts, "Landing detected")
        assert delay == pytest.approx(disarm_delay_s, abs=0.25)  # COM_DISARM_LAND, in simulated seconds
        landed = truth_after(client, truth, text_time(client, n_texts, "Disarmed (landed)"))
        assert landed.pos_ned_m[2] == pytest.approx(ground.pos_ned_m[2], abs=0.05)  # really on its legs
        assert horizontal(landed.pos_ned_m, ground.pos_ned_m) < 1.0
    finally:
        client.param_set("COM_DISARM_LAND", 2.0, timeout_s=10)


def test_mavproxy_takeoff_goto_and_return_to_launch(client, truth):
    """(g) NAV_TAKEOFF param7 = 5 (below home) climbs 5 m, with an explanation; (h) RTL from 10 m away."""
    ground = truth.latest()
    arm(client)
    n_texts = len(client.statustexts)
    client.takeoff(5.0, timeout_s=10).check()  # what MAVProxy's "takeoff 5" sends
    wait_text(client, n_texts, "below home")
    assert any("5 m above home" in t for t in texts_since(client, n_texts))
    wait_hovering(client, 5.0)
    assert client.relative_alt_m() == pytest.approx(5.0, abs=0.5)

    client.goto_ned(8.0, -6.0, -5.0, timeout_s=10).check()
    client.wait_until(lambda: client.arrived(8.0, -6.0, 0.5, 0.3), WAIT_S, "arrival 10 m away")
    away = truth.latest()
    assert horizontal(away.pos_ned_m, (ground.pos_ned_m[0] + 8.0, ground.pos_ned_m[1] - 6.0)) < 1.0

    return_alt = client.param_get("RTL_RETURN_ALT", timeout_s=10)
    with Recorder(client, ("GLOBAL_POSITION_INT",)) as rec:
        client.return_to_launch(timeout_s=10).check()
        client.wait_mode("RTL", WAIT_S)
        client.wait_until(client.landed_and_disarmed, WAIT_S, "return, landing and disarm")
    assert max(m.relative_alt / 1000.0 for m in rec.of("GLOBAL_POSITION_INT")) == pytest.approx(return_alt, abs=0.5)
    n, e, _ = client.position_ned()
    assert math.hypot(n, e) < 1.0
    assert "Disarmed (landed)" in texts_since(client, n_texts)
    back = truth_after(client, truth, text_time(client, n_texts, "Disarmed (landed)"))
    assert horizontal(back.pos_ned_m, ground.pos_ned_m) < 1.0
    assert back.pos_ned_m[2] == pytest.approx(ground.pos_ned_m[2], abs=0.05)  # on its legs when it disarmed


def run_gcs(stack: Stack, client: VehicleClient, *args: str, timeout_s: float = 120.0) -> subprocess.CompletedProcess:
    """``python -m gcs --url <the stack's own ground-station port> -i I ...`` as a user runs it.

    ``client`` keeps listening meanwhile (a UDP socket left unread overflows within a wall second
    at max speed) and afterwards waits for a fresh HEARTBEAT and EXTENDED_SYS_STATE, so its view
    of the vehicle is current.
    """
    cmd = [sys.executable, "-m", "gcs", "--url", stack.gcs_url, "-i", str(stack.instance)]
    cmd += args
    proc = subprocess.Popen(cmd, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        client.wait_until(lambda: proc.poll() is not None, timeout_s, f"{' '.join(cmd[2:])} to finish")
        out, err = proc.communicate()
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    fresh: set[str] = set()

    def note(msg) -> None:
        fresh.add(msg.get_type())

    client.add_listener(note)
    try:
        client.wait_until(lambda: {"HEARTBEAT", "EXTENDED_SYS_STATE"} <= fresh, WAIT_S, "fresh telemetry")
    finally:
        client.remove_listener(note)
    return subprocess.CompletedProcess(cmd, proc.returncode, out, err)


def test_gcs_cli_flight(stack, client, truth):
    """(e) status, arm, takeoff 3, a refused disarm in the air, land: exit codes and visible effects."""
    # The simulation runs several times faster than real time: keep the vehicle from disarming
    # for want of a take-off while the next command's process starts.
    client.param_set("COM_DISARM_PRFLT", 60.0, timeout_s=10)
    try:
        p = run_gcs(stack, client, "status", "--once")
        assert p.returncode == 0, p.stderr
        line = p.stdout
        assert client.mode_name() in line and "disarmed" in line
        assert "alt   0.00 m" in line or "alt  -0.0" in line or "alt   0.0" in line, line
        assert "batt 16." in line  # 4 cells, nearly full

        p = run_gcs(stack, client, "arm")
        assert p.returncode == 0, p.stderr
        assert "armed" in p.stdout
        client.wait_armed(True, WAIT_S)

        p = run_gcs(stack, client, "takeoff", "3")
        assert p.returncode == 0, p.stderr
        assert "m above home (mode" in p.stdout
        assert client.relative_alt_m() == pytest.approx(3.0, abs=0.5)
        assert client.landed_state() in (IN_AIR, mavlink.MAV_LANDED_STATE_TAKEOFF)

        p = run_gcs(stack, client, "disarm")
        assert p.returncode == 1
        assert "disarm refused: DENIED" in p.stderr and "Disarm denied: vehicle in air" in p.stderr
        client.wait_sim_time(1.0, WAIT_S)
        assert client.armed() and client.relative_alt_m() == pytest.approx(3.0, abs=0.5)

        p = run_gcs(stack, client, "status", "--once")
        assert p.returncode == 0 and "ARMED" in p.stdout

        p = run_gcs(stack, client, "land")
        assert p.returncode == 0, p.stderr
        assert "landed and disarmed" in p.stdout
        client.wait_armed(False, WAIT_S)
        assert client.on_ground() is True and client.relative_alt_m() == pytest.approx(0.0, abs=0.3)
    finally:
        client.param_set("COM_DISARM_PRFLT", 10.0, timeout_s=10)
