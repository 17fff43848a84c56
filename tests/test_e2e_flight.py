"""End-to-end: the real simulator and flight controller, flown over real sockets, on one shared stack.

Every test here uses the real ``sitl`` and ``autopilot`` processes (through
:class:`gcs.launcher.Stack`) and talks MAVLink to the flight controller the way a
ground station does: :class:`gcs.client.VehicleClient` (pymavlink underneath) on
the ground-station port, a second client on the API port, the ``gcs`` CLI as a
subprocess.  Ground truth comes from the simulator's own UDP channel
(HIL_STATE_QUATERNION + LOCAL_POSITION_NED on 14740 + instance) and is compared
with what the vehicle reports; it never reaches the flight controller.

One max-speed stack (module scope) carries the scenarios in file order; each
flight scenario starts and ends landed and disarmed.  The flights come first and
are flown in simulated time (``stepped_flight_fixture``, issue 33): the simulator
is held and the test moves the hold on, every command is sent between two steps,
so every figure of a flight (a height, a drift, a delay) is the same in every run.
Then the hold is lifted (``free``) for the clients that act in wall time and
assert no figure of a flight: the parameter protocol (a set is echoed at the
vehicle's next link update, so it needs the simulation to run), two ground
stations at once and the ``gcs`` CLI.  Wall-clock values are only "give up
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

ROOT = Path(__file__).resolve().parent.parent

from e2e_flight_helpers import (  # tests/e2e_flight_helpers.py
    IN_AIR,
    LANDING,
    ON_GROUND,
    WAIT_S,
    Recorder,
    SteppedFlight,
    horizontal,
    record_figure,
    stepped_flight_fixture,
    text_time,
    texts_since,
)

pytestmark = pytest.mark.e2e

UNKNOWN_COMMAND = 31010  # MAV_CMD_USER_1: nobody implements it
DISARM_DELAY_S = 3.0  # COM_DISARM_LAND at start-up (default 2 s): the landed vehicle disarms this much later

# --------------------------------------------------------------------------- fixtures

# One stack, held from its start and flown in simulated time; its client on the ground-station port.
flight = stepped_flight_fixture(params={"COM_DISARM_LAND": DISARM_DELAY_S}, then_free=True)


@pytest.fixture(scope="module")
def stack(flight) -> Stack:
    """The flight's :class:`Stack`."""
    return flight.stack


@pytest.fixture
def f(flight):
    """The flight in simulated time, once the vehicle is landed, disarmed and ready; brought down after a
    failed flight."""
    assert not flight.free, "the stepped flights come before the hold is lifted (file order)"
    c = flight.client
    flight.until(
        lambda: c.landed_and_disarmed() and c.prearm_ok() and c.home() is not None,
        60.0,
        "the vehicle to be on the ground, disarmed and ready",
        0.5,
    )
    yield flight
    if c.armed():  # a failed flight: bring it down so the next scenario starts clean
        try:
            flight.land()
        except Exception:
            c.disarm(force=True, timeout_s=10)


@pytest.fixture(scope="module")
def free(flight) -> VehicleClient:
    """The same stack with its hold lifted (the simulation at full speed, as a user's): its client."""
    flight.run_free()
    return flight.client


@pytest.fixture
def client(free):
    """The free stack's client, once the vehicle is landed, disarmed and ready; brought down after a failed flight."""
    vehicle = free
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


def arm(f: SteppedFlight) -> None:
    f.client.arm(timeout_s=10).check()
    f.until(f.client.armed, 5.0, "armed")


def hovering(f: SteppedFlight, alt_m: float) -> None:
    """Until the take-off is over: mode LOITER, near the altitude, not climbing."""
    c = f.client
    f.until(lambda: c.mode_name() == "LOITER" and c.takeoff_done(alt_m, 0.5), 60.0, f"hover at {alt_m:g} m")


def truth_at_s(f: SteppedFlight, sim_time_s: float):
    """The first truth sample at or after this vehicle time (already arrived: the flight is held after it)."""
    return f.truth_since(round(sim_time_s * 1000.0))[0]


# --------------------------------------------------------------------------- in simulated time


def test_second_stack_on_a_busy_instance_is_refused(stack):
    with pytest.raises(StackError, match="already in use"):
        Stack(instance=stack.instance).start()
    assert stack.exited() == {}


def test_identity_modes_and_unknown_command(f):
    client = f.client
    hb = client.latest("HEARTBEAT")
    assert hb.autopilot == mavlink.MAV_AUTOPILOT_PX4 and hb.type == mavlink.MAV_TYPE_QUADROTOR
    # (c) a command nobody implements is answered, not ignored (while held: at once)
    res = client.command_long(UNKNOWN_COMMAND, 1, 2, 3, timeout_s=10)
    assert res.result == mavlink.MAV_RESULT_UNSUPPORTED
    res = client.command_long(mavlink.MAV_CMD_REQUEST_MESSAGE, mavlink.MAVLINK_MSG_ID_ADSB_VEHICLE, timeout_s=10)
    assert res.result == mavlink.MAV_RESULT_UNSUPPORTED
    # mode changes on the ground, MAVSDK's way (DO_SET_MODE) and QGroundControl's way (SET_MODE)
    client.set_mode("AUTO.LOITER", timeout_s=10).check()
    f.mode_is("LOITER")
    posctl = 3 << 16
    client.conn.mav.set_mode_send(client.target_system, mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, posctl)
    ack = client.recv("COMMAND_ACK", WAIT_S, lambda m: m.command == mavlink.MAV_CMD_DO_SET_MODE)  # as PX4's
    assert ack is not None and ack.result == mavlink.MAV_RESULT_ACCEPTED
    f.mode_is("POSCTL")
    assert client.latest("HEARTBEAT").custom_mode == posctl


def test_takeoff_hover_land_and_automatic_disarm(f):
    """(b) + (f): take off to 5 m, hold 10 s, land; the vehicle disarms by itself.  Truth agrees."""
    client = f.client
    home = client.home()
    assert client.param_get("COM_DISARM_LAND", timeout_s=10) == pytest.approx(DISARM_DELAY_S)  # (start-up file)
    ground = f.truth_now()
    assert ground is not None, "no ground truth on UDP 14740 + instance"
    assert abs(ground.vel_ned_m_s[2]) < 0.05
    arm(f)
    n_texts = len(client.statustexts)
    client.takeoff(home.alt_amsl_m + 5.0, timeout_s=10).check()
    hovering(f, 5.0)
    assert client.relative_alt_m() == pytest.approx(5.0, abs=0.5)

    with Recorder(client, ("GLOBAL_POSITION_INT", "LOCAL_POSITION_NED", "ATTITUDE")) as rec:
        f.wait(10.0)  # 10 s of hover
    gpi, lpn = rec.of("GLOBAL_POSITION_INT"), rec.of("LOCAL_POSITION_NED")
    assert len(gpi) >= 40 and len(lpn) >= 40  # 5 Hz for 10 simulated seconds
    record_figure("hover_alt_error_m", max(abs(m.relative_alt / 1000.0 - 5.0) for m in gpi), 0.3, unit="m")
    record_figure("hover_local_z_spread_m", max(abs(m.z - lpn[0].z) for m in lpn), 0.3, unit="m")
    drift = max(math.hypot(m.x - lpn[0].x, m.y - lpn[0].y) for m in lpn)
    record_figure("hover_local_drift_m", drift, 0.5, unit="m")
    start = (gpi[0].lat * 1e-7, gpi[0].lon * 1e-7, 0.0)
    gps_drift = max(horizontal(geo.global_to_ned(*start, m.lat * 1e-7, m.lon * 1e-7, 0.0), (0, 0)) for m in gpi)
    record_figure("hover_global_drift_m", gps_drift, 0.5, unit="m")
    tilt = max(abs(m.roll) + abs(m.pitch) for m in rec.of("ATTITUDE"))
    record_figure("hover_roll_plus_pitch_deg", math.degrees(tilt), 5.0, unit="deg")
    assert client.mode_name() == "LOITER" and client.landed_state() == IN_AIR

    # (f) ground truth: nearest simulated instants (within 10 ms), height above the ground truth had before take-off
    pairs = [(m.relative_alt / 1000.0, f.truth.at(m.time_boot_ms)) for m in gpi]
    pairs = [(alt, t) for alt, t in pairs if t is not None]
    assert len(pairs) >= 0.8 * len(gpi)
    true_alt_error = max(abs(-(t.pos_ned_m[2] - ground.pos_ned_m[2]) - alt) for alt, t in pairs)
    record_figure("hover_reported_vs_true_alt_m", true_alt_error, 0.3, unit="m")
    true_drift = max(horizontal(t.pos_ned_m, pairs[0][1].pos_ned_m) for _, t in pairs)
    record_figure("hover_true_drift_m", true_drift, 0.5, unit="m")
    att = f.truth.state_at(f.now_ms, within_ms=0)
    assert att is not None and att.time_usec > 0
    w, x, y, z = att.attitude_quaternion
    true_tilt = math.degrees(math.acos(min(1.0, 1 - 2 * (x * x + y * y))))  # body z from the vertical
    record_figure("hover_true_tilt_deg", true_tilt, 5.0, unit="deg")  # truly level

    with Recorder(client, ("EXTENDED_SYS_STATE", "HEARTBEAT")) as rec:
        client.land(timeout_s=10).check()
        f.until(client.landed_and_disarmed, 60.0, "landing and the automatic disarm", 0.25)
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
    # COM_DISARM_LAND, in simulated seconds
    record_figure("auto_disarm_delay_error_s", abs(delay - DISARM_DELAY_S), 0.25, unit="s")
    landed = truth_at_s(f, text_time(client, n_texts, "Disarmed (landed)"))
    # really on its legs
    record_figure("landed_height_error_m", abs(landed.pos_ned_m[2] - ground.pos_ned_m[2]), 0.05, unit="m")
    record_figure("landed_offset_m", horizontal(landed.pos_ned_m, ground.pos_ned_m), 1.0, unit="m")


def test_mavproxy_takeoff_goto_and_return_to_launch(f):
    """(g) NAV_TAKEOFF param7 = 5 (below home) climbs 5 m, with an explanation; (h) RTL from 10 m away."""
    client = f.client
    ground = f.truth_now()
    arm(f)
    n_texts = len(client.statustexts)
    client.takeoff(5.0, timeout_s=10).check()  # what MAVProxy's "takeoff 5" sends
    f.text_seen(n_texts, "below home")
    assert any("5 m above home" in t for t in texts_since(client, n_texts))
    hovering(f, 5.0)
    assert client.relative_alt_m() == pytest.approx(5.0, abs=0.5)

    client.goto_ned(8.0, -6.0, -5.0, timeout_s=10).check()
    f.until(lambda: client.arrived(8.0, -6.0, 0.5, 0.3), 60.0, "arrival 10 m away")
    away = f.truth_now()
    goal = (ground.pos_ned_m[0] + 8.0, ground.pos_ned_m[1] - 6.0)
    record_figure("goto_arrival_true_error_m", horizontal(away.pos_ned_m, goal), 1.0, unit="m")

    return_alt = client.param_get("RTL_RETURN_ALT", timeout_s=10)
    with Recorder(client, ("GLOBAL_POSITION_INT",)) as rec:
        client.return_to_launch(timeout_s=10).check()
        f.mode_is("RTL")
        f.until(client.landed_and_disarmed, 120.0, "return, landing and disarm", 0.25)
    top = max(m.relative_alt / 1000.0 for m in rec.of("GLOBAL_POSITION_INT"))
    record_figure("rtl_top_vs_return_alt_m", abs(top - return_alt), 0.5, unit="m")
    n, e, _ = client.position_ned()
    record_figure("rtl_landed_from_home_m", math.hypot(n, e), 1.0, unit="m")
    assert "Disarmed (landed)" in texts_since(client, n_texts)
    back = truth_at_s(f, text_time(client, n_texts, "Disarmed (landed)"))
    record_figure("rtl_landed_true_offset_m", horizontal(back.pos_ned_m, ground.pos_ned_m), 1.0, unit="m")
    # on its legs when it disarmed
    record_figure("rtl_landed_height_error_m", abs(back.pos_ned_m[2] - ground.pos_ned_m[2]), 0.05, unit="m")


# --------------------------------------------------------------------------- in wall time, the hold lifted


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
    with VehicleClient(stack.api_url, timeout_s=WAIT_S, idle=stack.check_alive) as api:
        for c in (api, client):
            c.wait_until(
                lambda c=c: c.latest("HEARTBEAT") is not None and c.latest("GLOBAL_POSITION_INT"), WAIT_S, "telemetry"
            )
            assert c.latest("HEARTBEAT").autopilot == mavlink.MAV_AUTOPILOT_PX4
        try:
            # one sets, the other reads back
            assert client.param_set("MPC_XY_CRUISE", 4.5, timeout_s=10) == pytest.approx(4.5)
            assert api.param_get("MPC_XY_CRUISE", timeout_s=10) == pytest.approx(4.5)
            # each gets the acknowledgement of its own command, and both are obeyed
            assert api.command_long(UNKNOWN_COMMAND, timeout_s=10).result == mavlink.MAV_RESULT_UNSUPPORTED
            assert client.set_mode("AUTO.LOITER", timeout_s=10).accepted
            for c in (api, client):
                c.wait_mode("LOITER", WAIT_S)
            assert api.set_mode("POSCTL", timeout_s=10).accepted
            for c in (api, client):
                c.wait_mode("POSCTL", WAIT_S)
        finally:
            client.param_set("MPC_XY_CRUISE", 3.0, timeout_s=10)


def test_param_set_after_another_station_changed_it(stack, client):
    """A station that saw another's change can still set the parameter (QGroundControl + MAVSDK)."""
    with VehicleClient(stack.api_url, timeout_s=WAIT_S, idle=stack.check_alive) as api:
        try:
            client.param_set("MPC_XY_CRUISE", 4.5, timeout_s=10)
            assert api.param_get("MPC_XY_CRUISE", timeout_s=10) == pytest.approx(4.5)
            assert api.param_set("MPC_XY_CRUISE", 3.5, timeout_s=10) == pytest.approx(3.5)
        finally:
            client.pump(0.2)  # (drop queued echoes so the restore below is not confused by the same bug)
            client.param_set("MPC_XY_CRUISE", 3.0, timeout_s=10)
            assert client.param_get("MPC_XY_CRUISE", timeout_s=10) == pytest.approx(3.0)


def run_gcs(stack: Stack, client: VehicleClient, *args: str, timeout_s: float = 120.0) -> subprocess.CompletedProcess:
    """``python -m gcs --url <the stack's API port> -i I ...`` as a user runs it.

    ``client`` keeps listening meanwhile (a UDP socket left unread overflows within a wall second
    at max speed) and afterwards waits for a fresh HEARTBEAT and EXTENDED_SYS_STATE, so its view
    of the vehicle is current.
    """
    cmd = [sys.executable, "-m", "gcs", "--url", stack.api_url, "-i", str(stack.instance)]
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


def test_gcs_cli_flight(stack, client):
    """(e) status, arm, takeoff 3, a refused disarm in the air, land: exit codes and visible effects.

    Each command's process starts in wall time while the simulation runs at full speed, so when it acts is
    the machine's: asserted are exit codes, words and states that last (armed, hovering at 3 m, landed)."""
    # The simulation runs many times faster than real time: keep the vehicle from disarming for want of a
    # take-off while the next command's process starts, however long that takes (COM_DISARM_PRFLT off).
    client.param_set("COM_DISARM_PRFLT", -1.0, timeout_s=10)
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
