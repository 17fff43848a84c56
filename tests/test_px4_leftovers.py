"""Issue 36's leftovers on the commander and at start-up, with nothing running (the link's side:
tests/test_gcs_link_px4_leftovers.py; stick expo: tests/test_stick_expo.py):

- GET_HOME_POSITION is a row of the link's: TEMPORARILY_REJECTED before home, with a STATUSTEXT why;
- after DO_FLIGHTTERMINATION the pre-arm failures say why arming is refused, so SYS_STATUS's PREARM_CHECK
  bit is unhealthy (what MAVSDK's ``health.is_armable`` reads) until a reboot;
- COM_FLIGHT_UUID counts the armings, is saved with the parameters (``--state-dir``) and the next start
  continues it;
- MAV_SYS_ID: 1+N for instance N, a saved value used at the next start, ``--sysid`` over both.
"""

from __future__ import annotations

import dataclasses

from pymavlink.dialects.v20 import common as mavlink

from autopilot.__main__ import _resolve_ports, build_parser
from autopilot.commander.commander import Commander
from autopilot.mavlink import commands
from autopilot.mavlink.telemetry_more import flight_information
from autopilot.mavlink.vehicle_interface import telemetry_snapshot
from autopilot.param_catalogue import default_store
from autopilot.param_storage import ParamSaver, prepare_parameters
from autopilot.system_id import set_instance_default, system_id_at_start
from autopilot.telemetry_extras import FLIGHT_UUID_MAX, FlightTimes, count_flight
from autopilot.topics import ActuatorStatus

from test_commander import ACCEPTED, DENIED, NAN7, Bench

C = mavlink
PREARM = mavlink.MAV_SYS_STATUS_PREARM_CHECK
TERMINATED = "flight terminated (reboot to clear)"


# --------------------------------------------------------------------------- GET_HOME_POSITION


class FakeLink:
    def __init__(self, result: int) -> None:
        self.result, self.requests, self.said = result, [], []

    def request_message(self, msg_id: int, param2: float) -> int:
        self.requests.append(msg_id)
        return self.result

    def say(self, severity: int, text: str) -> None:
        self.said.append((severity, text))


def test_get_home_position_is_a_link_row_sending_home_position():
    link = FakeLink(C.MAV_RESULT_TEMPORARILY_REJECTED)  # before home is set: rejected for now, and why
    assert commands.run(C.MAV_CMD_GET_HOME_POSITION, NAN7, 0, link, None) == C.MAV_RESULT_TEMPORARILY_REJECTED
    assert link.said == [(C.MAV_SEVERITY_WARNING, "Home position not set: waiting for a position fix")]
    link.result = ACCEPTED
    assert commands.run(C.MAV_CMD_GET_HOME_POSITION, NAN7, 0, link, None) == ACCEPTED
    assert link.requests == [C.MAVLINK_MSG_ID_HOME_POSITION] * 2
    assert len(link.said) == 1  # nothing to say once home is there


# --------------------------------------------------------------------------- DO_FLIGHTTERMINATION


def armable(cmd: Commander) -> bool:
    """MAVSDK's ``health.is_armable``: SYS_STATUS's onboard_control_sensors_health has MAV_SYS_STATUS_PREARM_CHECK."""
    actuators = ActuatorStatus(cmd.now_us, (0.0,) * 4, 0.0, 0.0, 0.0)
    snap = telemetry_snapshot(cmd.status, actuators, None, None, False)
    assert snap.sensors_present & PREARM
    return bool(snap.sensors_health & PREARM)


def test_after_flight_termination_the_prearm_checks_say_why_arming_is_refused():
    b = Bench()
    b.run(1.0)
    assert b.cmd.status.prearm_failures == () and armable(b.cmd)
    assert b.command(C.MAV_CMD_DO_FLIGHTTERMINATION, 1) == ACCEPTED
    b.run(0.1)
    assert b.cmd.status.prearm_failures == (TERMINATED,)  # the reason a ground station lists
    assert not armable(b.cmd)  # MAVSDK: not armable
    assert b.arm() == DENIED and b.texts()[-1] == "Arming denied: " + TERMINATED
    assert b.command(C.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, 1) == ACCEPTED
    b.run(1.0)
    assert b.cmd.status.prearm_failures == () and armable(b.cmd)
    assert b.arm() == ACCEPTED


def test_termination_is_listed_with_the_other_reasons():
    b = Bench()
    b.gps = None
    b.run(1.0)
    b.command(C.MAV_CMD_DO_FLIGHTTERMINATION, 1)
    b.run(0.1)
    fails = b.cmd.status.prearm_failures
    assert "no 3D GPS fix" in fails and fails[-1] == TERMINATED


# --------------------------------------------------------------------------- COM_FLIGHT_UUID


def arm_and_disarm(b: Bench) -> None:
    assert b.arm() == ACCEPTED
    b.run(0.1)
    assert b.disarm() == ACCEPTED
    b.run(0.1)


def test_the_flight_number_counts_armings_and_survives_a_restart(tmp_path):
    state = tmp_path / "quad_x-0.params"
    b = Bench()
    saver = ParamSaver(b.params, state, vehicle_name="quad_x")
    b.run(1.0)
    times = FlightTimes(lambda: int(b.params.get("COM_FLIGHT_UUID")))
    times.update(b.cmd.status)
    assert times.extras(None, 0).flight_number == 0  # no flight yet
    for flight in (1, 2):
        arm_and_disarm(b)
        assert b.params.get("COM_FLIGHT_UUID") == flight
    times.update(b.cmd.status)
    assert flight_information(dataclasses.replace(_snapshot(), extras=times.extras(None, 0)), 0).flight_uuid == 2
    assert saver.save()  # what the parameter service does after each change
    saver.close()
    # the next start: the saved state, then the count goes on
    b2 = Bench()
    prepare_parameters(b2.params, state_path=state, log=lambda text: None)
    assert b2.params.get("COM_FLIGHT_UUID") == 2
    b2.run(1.0)
    arm_and_disarm(b2)
    assert b2.params.get("COM_FLIGHT_UUID") == 3


def test_the_flight_number_wraps_within_int32():
    params = default_store()
    params.set("COM_FLIGHT_UUID", FLIGHT_UUID_MAX)
    assert count_flight(params) == 1 and params.get("COM_FLIGHT_UUID") == 1


def _snapshot():
    b = Bench()
    return telemetry_snapshot(b.cmd.status, ActuatorStatus(0, (), 0.0, 0.0, 0.0), None, None, False)


# --------------------------------------------------------------------------- MAV_SYS_ID


def start(instance: int, state=None, sysid: int | None = None):
    """The parameters and system id of a start of ``autopilot -i instance`` (``--state-dir``, ``--sysid``)."""
    argv = ["-i", str(instance)] + ([] if sysid is None else ["--sysid", str(sysid)])
    args = build_parser().parse_args(argv)
    _resolve_ports(args)
    params = default_store()
    set_instance_default(params, args.instance)
    prepare_parameters(params, state_path=state, log=lambda text: None)
    got, note = system_id_at_start(params, args.sysid)
    return params, got, note


def test_mav_sys_id_is_1_plus_n_and_a_saved_value_is_used_at_the_next_start(tmp_path):
    state = tmp_path / "quad_x-4.params"
    params, sysid, note = start(4, state)
    assert (sysid, params.get("MAV_SYS_ID"), note) == (5, 5, None)  # PX4 SITL's 1+N
    assert "MAV_SYS_ID" not in params.changed()  # the default: nothing to save
    params.set("MAV_SYS_ID", 42)  # a ground station's PARAM_SET: stored and reported, used ...
    saver = ParamSaver(params, state, vehicle_name="quad_x")
    assert saver.save()
    saver.close()
    params, sysid, _ = start(4, state)
    assert (sysid, params.get("MAV_SYS_ID")) == (42, 42)  # ... from the next start
    assert start(4)[1] == 5  # without --state-dir nothing is kept
    params, sysid, _ = start(4, state, sysid=9)  # --sysid wins, and MAV_SYS_ID takes it
    assert (sysid, params.get("MAV_SYS_ID")) == (9, 9)
    params, sysid, note = start(4, state, sysid=253)  # beyond MAV_SYS_ID's 1..250 (PX4's): used, not stored
    assert (sysid, params.get("MAV_SYS_ID")) == (253, 42) and "outside MAV_SYS_ID's range" in note
    d = params.definition("MAV_SYS_ID")
    assert (d.ptype, d.min, d.max, d.reboot_required) == ("INT32", 1, 250, True)
