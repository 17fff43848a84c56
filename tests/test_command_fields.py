"""Every field every command of the table reads, refused when NaN (where required), infinite, out of range or
not in its enumeration (issue 18, finding 4): the answer is MAV_RESULT_DENIED (UNSUPPORTED where a valid value
names something not simulated), a refusal says why in a STATUSTEXT, and nothing changes.

Table-driven: each row of :data:`CASES` is a command with parameters that are ACCEPTED in the bench's state
(checked, so the refusals are the fields' doing) and the bad values of each parameter it reads.  The vehicle
rows run on the commander bench of tests/test_commander.py (a real Commander, COMMAND_LONG through the command
table); the link rows on a recording LinkCommands.  Also: the pure field readers of
:mod:`autopilot.mavlink.command_fields`, COMMAND_INT frames, and the offboard/stick messages with NaN/inf.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink import command_fields as f
from autopilot.mavlink import commands
from autopilot.mavlink.control_messages import manual_input
from autopilot.mavlink.offboard_messages import offboard_setpoint
from mavsim_core import mission_items as mi
from mavsim_core.geodesy import ned_to_geodetic
from mavsim_core.mission_items import MissionItem
from mavsim_core.px4_modes import Mode

from test_commander import ACCEPTED, DENIED, ORIGIN, UNSUPPORTED, Bench

C = mavlink
NAN, INF = math.nan, math.inf
HOME_ALT = ORIGIN[2]
LAT, LON, _ = ned_to_geodetic([10.0, 5.0, 0.0], *ORIGIN)  # 10 m north, 5 m east of home
FAR_LAT, _, _ = ned_to_geodetic([5000.0, 0.0, 0.0], *ORIGIN)


@dataclass
class Case:
    command: int
    state: str  # "ground" (disarmed), "armed" (on the ground), "flying" (holding at MIS_TAKEOFF_ALT), "mission"
    good: tuple[float, ...]  # ACCEPTED in that state
    bad: dict[int, tuple[float, ...]]  # param index (1-based) -> values refused
    unsupported: dict[int, tuple[float, ...]] = field(default_factory=dict)  # valid values of things not simulated


CASES = [
    Case(C.MAV_CMD_COMPONENT_ARM_DISARM, "ground", (1, 0), {1: (NAN, INF, 0.6, -1, 2, 1e38), 2: (1, 21195, -INF)}),
    Case(C.MAV_CMD_COMPONENT_ARM_DISARM, "armed", (0, 0), {1: (NAN, 0.4, -INF), 2: (2, INF)}),
    Case(C.MAV_CMD_NAV_TAKEOFF, "armed", (0, 0, 0, NAN, NAN, NAN, HOME_ALT + 5),
         {7: (INF, -INF, 1e30, 1e38, HOME_ALT + 20000, -5, -1e30), 4: (INF,), 5: (-INF,)}),
    Case(C.MAV_CMD_NAV_LAND, "flying", (0, 0, 0, NAN, NAN, NAN, NAN),
         {2: (3, 0.5, -1, INF), 5: (LAT, INF), 6: (LON, -INF), 1: (INF,)}),
    Case(C.MAV_CMD_NAV_RETURN_TO_LAUNCH, "flying", (0,) * 7, {1: (INF,), 7: (-INF,)}),
    Case(C.MAV_CMD_DO_SET_MODE, "flying", (1, 3, 0),  # POSCTL
         {1: (NAN, 1.5, 256, -1, INF), 2: (NAN, 3.5, 300, -INF), 3: (0.5, -1, 256, INF)}),
    Case(C.MAV_CMD_DO_REPOSITION, "flying", (-1, 1, 0, NAN, LAT, LON, HOME_ALT + 3),
         {1: (INF,), 4: (1e38, INF, -7.0), 5: (INF, 95.0, NAN), 6: (INF, 200.0, NAN),
          7: (INF, -INF, HOME_ALT + 20000), 3: (INF,)}),
    Case(C.MAV_CMD_DO_SET_MISSION_CURRENT, "mission", (1, 0),
         {1: (1.5, -2, 70000, 5, INF), 2: (0.5, 2, -1, INF)}),
    Case(C.MAV_CMD_DO_CHANGE_SPEED, "flying", (1, 5), {1: (1.5, 4, -1, INF), 2: (INF, -3, 0, -INF), 3: (INF,)},
         unsupported={}),
    Case(C.MAV_CMD_DO_SET_HOME, "ground", (0, 0, 0, 0, LAT, LON, HOME_ALT),
         {1: (NAN, 0.5, 2, INF), 5: (INF, 95.0, NAN, FAR_LAT), 6: (INF, NAN), 7: (NAN, INF, HOME_ALT + 5000)}),
    Case(C.MAV_CMD_CONDITION_YAW, "flying", (90, 30, 0, 0),
         {1: (NAN, INF, 400, -361), 2: (INF,), 3: (2, 0.5, -2, INF), 4: (2, 0.5, INF)}),
    Case(C.MAV_CMD_DO_PAUSE_CONTINUE, "flying", (0,), {1: (NAN, 0.6, 2, -1, INF)}),
    Case(C.MAV_CMD_DO_FLIGHTTERMINATION, "flying", (1,), {1: (INF, -INF), 2: (INF,)}),
    Case(C.MAV_CMD_PREFLIGHT_STORAGE, "ground", (2,), {1: (NAN, 1.5, 5, -1, INF), 2: (INF,)}),
    Case(C.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN, "ground", (1,), {1: (1.5, 4, -1, INF), 2: (INF,)},
         unsupported={1: (2, 3)}),
    Case(C.MAV_CMD_DO_MOTOR_TEST, "ground", (1, 0, 15, 2, 0),
         {1: (0, 5, 1.5, NAN, INF), 2: (1.5, 7, NAN, -1, INF), 3: (101, -1, NAN, INF), 4: (-1, NAN, INF),
          5: (2, 1.5, -1, INF)}, unsupported={2: (2, 3)}),
    Case(C.MAV_CMD_DO_ORBIT, "flying", (5, 1, NAN, NAN, NAN, NAN, NAN),
         {1: (INF, 0.1, 1e30), 2: (-1, INF), 3: (6, 1.5, -1), 4: (math.pi, INF), 5: (INF, 95.0, LAT),
          6: (INF, LON), 7: (INF, HOME_ALT + 20000)}),
]  # fmt: skip


def bench(state: str) -> Bench:
    b = Bench()
    b.run(1.0)
    if state == "armed":
        assert b.arm() == ACCEPTED
    elif state in ("flying", "mission"):
        b.fly_up()
    if state == "mission":
        item = MissionItem(0, mi.FRAME_GLOBAL_RELATIVE_ALT, mi.NAV_WAYPOINT, x=int(LAT * 1e7), y=int(LON * 1e7), z=5.0)
        b.cmd.plans.replace(mi.MISSION, [item, dataclasses.replace(item, seq=1)], mission_active=False)
    b.drain()
    return b


def fingerprint(b: Bench) -> tuple:
    """What a command may change: arming, mode, home, task, setpoint, the commander's flags, parameters, mission."""
    c = b.cmd
    return (
        c.armed, c.mode, repr(c.home), id(c.task), repr(c.setpoint), c.terminated, c.motor_test_run,
        c.cruise_override_m_s, c.reboot_pending, c.precland_mode, repr(c.status.mission),
        tuple((n, b.params.get(n)) for n in b.params.names()),
    )  # fmt: skip


def with_param(params: tuple[float, ...], index: int, value: float) -> tuple[float, ...]:
    p = list(params) + [0.0] * (7 - len(params))
    p[index - 1] = value
    return tuple(p)


def case_id(case: Case) -> str:
    return f"{mavlink.enums['MAV_CMD'][case.command].name.removeprefix('MAV_CMD_')}-{case.state}"


@pytest.mark.parametrize("case", CASES, ids=case_id)
def test_each_field_is_checked_and_a_refusal_changes_nothing(case: Case):
    assert bench(case.state).command(case.command, *case.good) == ACCEPTED, "the good parameters are accepted"
    b = bench(case.state)
    name = case_id(case)
    for expected, table in ((DENIED, case.bad), (UNSUPPORTED, case.unsupported)):
        for index, values in table.items():
            for value in values:
                before, texts = fingerprint(b), len(b.texts())
                result = b.command(case.command, *with_param(case.good, index, value))
                assert result == expected, f"{name}: param{index} = {value}: result {result}"
                assert fingerprint(b) == before, f"{name}: param{index} = {value} changed the state"
                assert len(b.texts()) > texts, f"{name}: param{index} = {value} refused without a STATUSTEXT"
                b.run(0.1)


def test_command_int_frames_for_positions():
    b = bench("flying")
    x, y = int(LAT * 1e7), int(LON * 1e7)

    def reposition(frame: int, z: float) -> int:
        msg = mavlink.MAVLink_command_int_message(1, 1, frame, C.MAV_CMD_DO_REPOSITION, 0, 0, -1, 1, 0, NAN, x, y, z)
        result = commands.handle_vehicle_command(
            b.cmd, C.MAV_CMD_DO_REPOSITION, commands.command_int_params(msg), frame
        )
        b.drain()
        return result

    before = fingerprint(b)
    for frame in (C.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT, C.MAV_FRAME_LOCAL_NED, C.MAV_FRAME_BODY_FRD, C.MAV_FRAME_MISSION):
        assert reposition(frame, 3.0) == DENIED, frame
        assert fingerprint(b) == before
    assert "terrain-relative altitudes are not supported" in b.texts()[-4]
    assert reposition(C.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, 4.0) == ACCEPTED  # 4 m above home, not AMSL
    assert b.cmd.task.goal[2] == pytest.approx(-4.0)
    assert reposition(C.MAV_FRAME_GLOBAL_INT, HOME_ALT + 6.0) == ACCEPTED
    assert b.cmd.task.goal[2] == pytest.approx(-6.0)


def test_takeoff_ceiling_is_gf_max_ver_dist_when_set():
    b = bench("armed")
    b.params.set("GF_MAX_VER_DIST", 30.0)
    assert b.command(C.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, NAN, NAN, NAN, HOME_ALT + 31) == DENIED
    assert b.texts()[-1] == "Takeoff denied: 31 m above home is over the GF_MAX_VER_DIST ceiling of 30 m"
    assert b.command(C.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, NAN, NAN, NAN, 1e30) == DENIED
    assert b.command(C.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, NAN, NAN, NAN, INF) == DENIED
    assert b.texts()[-1] == "Takeoff denied: param7 is inf"
    b.params.set("GF_MAX_VER_DIST", 0.0)
    assert b.command(C.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, NAN, NAN, NAN, HOME_ALT + 10001) == DENIED
    assert b.texts()[-1] == "Takeoff denied: 10001 m above home is over the ceiling of 10000 m (GF_MAX_VER_DIST 0)"
    assert b.command(C.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, NAN, NAN, NAN, NAN) == ACCEPTED  # NaN: MIS_TAKEOFF_ALT
    assert b.texts()[-2] == f"Taking off to {b.params.get('MIS_TAKEOFF_ALT'):.1f} m above home"


def test_land_on_the_ground_is_a_landing_done_disarming_after_com_disarm_land():
    b = bench("armed")
    b.params.set("COM_DISARM_LAND", 1.0)
    b.run(3.0)  # armed on the ground for a while (COM_DISARM_PRFLT is 10 s)
    assert b.command(C.MAV_CMD_NAV_LAND, 0, 0, 0, NAN, 0, 0, 0) == ACCEPTED  # MAVProxy's "land": zeros
    assert b.cmd.status.mode is Mode.AUTO_LAND and b.texts()[-2:] == ["Land: already on the ground", "Mode AUTO.LAND"]
    b.run(0.9)
    assert b.cmd.armed
    b.run(0.2)
    assert not b.cmd.armed and b.texts()[-1] == "Disarmed (landed)"


def test_reposition_speed_is_limited_to_mpc_xy_vel_max():
    b = bench("flying")
    assert b.command(C.MAV_CMD_DO_REPOSITION, 1e30, 1, 0, NAN, LAT, LON, NAN) == ACCEPTED
    assert b.cmd.task.cruise_m_s == b.params.get("MPC_XY_VEL_MAX")
    assert b.texts()[-1] == "Speed 1e+30 m/s limited to MPC_XY_VEL_MAX"


class RecordingLink:
    """A LinkCommands that records what it was asked."""

    def __init__(self) -> None:
        self.calls: list[tuple] = []

    def set_message_interval(self, msg_id: int, interval_us: int) -> int:
        self.calls.append(("interval", msg_id, interval_us))
        return ACCEPTED

    def request_message(self, msg_id: int, param2: float) -> int:
        self.calls.append(("request", msg_id, param2))
        return ACCEPTED

    def send_autopilot_version(self) -> int:
        self.calls.append(("version",))
        return ACCEPTED


@pytest.mark.parametrize(
    "command, good, bad",
    [
        (C.MAV_CMD_SET_MESSAGE_INTERVAL, (33, 100000),
         {1: (NAN, INF, -1, 1.5, 2**24), 2: (NAN, INF, -2, 3e9, -INF), 7: (INF,)}),
        (C.MAV_CMD_REQUEST_MESSAGE, (33, 0), {1: (NAN, INF, -1, 1.5, 2**24), 2: (INF,)}),
        (C.MAV_CMD_REQUEST_AUTOPILOT_CAPABILITIES, (1,), {1: (INF,)}),
    ],
)  # fmt: skip
def test_link_rows_refuse_bad_fields_without_acting(command, good, bad):
    link = RecordingLink()
    assert commands.run(command, with_param(good, 1, good[0]), C.MAV_FRAME_GLOBAL, link, None) == ACCEPTED
    assert len(link.calls) == 1
    for index, values in bad.items():
        for value in values:
            result = commands.run(command, with_param(good, index, value), C.MAV_FRAME_GLOBAL, link, None)
            assert result == DENIED, (index, value)
    assert len(link.calls) == 1, link.calls


def test_field_readers():
    assert f.optional(NAN, "x") is None and f.optional(2.5, "x") == 2.5
    with pytest.raises(f.FieldError, match="x inf is not a number"):
        f.optional(INF, "x")
    assert f.whole(NAN, "n", 0, 3, nan=2) == 2 and f.whole(3.0, "n", 0, 3) == 3
    for bad in (NAN, 3.5, 4, -1, INF):
        with pytest.raises(f.FieldError):
            f.whole(bad, "n", 0, 3)
    assert f.flag(1.0, "b") is True and f.flag(0.0, "b") is False and f.flag(NAN, "b", nan=True) is True
    for bad in (0.6, 2, NAN, -INF):
        with pytest.raises(f.FieldError, match="is not one of 0, 1|not given|not a number"):
            f.flag(bad, "b")
    assert f.lat_lon(NAN, NAN) is None and f.lat_lon(0, 0, zero_is_here=True) is None
    assert f.lat_lon(0, 0) == (0.0, 0.0)
    for lat, lon in ((NAN, 8.0), (47.0, NAN), (91.0, 8.0), (47.0, -181.0), (INF, 8.0)):
        with pytest.raises(f.FieldError):
            f.lat_lon(lat, lon)
    assert f.yaw_rad(NAN) is None and f.yaw_rad(-math.pi) == -math.pi
    with pytest.raises(f.FieldError, match="radians expected"):
        f.yaw_rad(90.0)
    assert f.to_amsl((0,) * 6 + (5.0,), C.MAV_FRAME_GLOBAL_RELATIVE_ALT, 488.0)[6] == 493.0
    assert math.isnan(f.to_amsl((0,) * 4 + (NAN,) * 3, C.MAV_FRAME_LOCAL_NED, None)[6])  # nothing given: any frame
    with pytest.raises(f.FieldError, match="before a home position"):
        f.to_amsl((0,) * 6 + (5.0,), C.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, None)


def test_offboard_and_stick_messages_with_nan_or_inf_are_ignored():
    """SET_POSITION_TARGET_* / SET_ATTITUDE_TARGET with NaN or inf in a used field give no setpoint (the vehicle
    keeps the last good one, and loses offboard after COM_OF_LOSS_T); MANUAL_CONTROL's fields are int16 (no NaN)
    and out-of-range values are clipped."""
    b = bench("flying")
    est, home = b.cmd.est, b.cmd.home
    pos_only = 0b1101_1111_1000  # velocity, acceleration, yaw and yaw rate ignored
    good_local = mavlink.MAVLink_set_position_target_local_ned_message(
        0, 1, 1, C.MAV_FRAME_LOCAL_NED, pos_only, 1.0, 0, -5, 0, 0, 0, 0, 0, 0, 0, 0
    )
    assert offboard_setpoint(good_local, 1, 1.0, est, home) is not None
    good_att = mavlink.MAVLink_set_attitude_target_message(0, 1, 1, 0b0000_0111, [1.0, 0.0, 0.0, 0.0], 0, 0, 0, 0.5)
    assert offboard_setpoint(good_att, 1, 1.0, est, home) is not None
    for bad in (NAN, INF, -INF):
        local = mavlink.MAVLink_set_position_target_local_ned_message(
            0, 1, 1, C.MAV_FRAME_LOCAL_NED, pos_only, bad, 0, -5, 0, 0, 0, 0, 0, 0, 0, 0
        )
        assert offboard_setpoint(local, 1, 1.0, est, home) is None
        glob = mavlink.MAVLink_set_position_target_global_int_message(
            0, 1, 1, C.MAV_FRAME_GLOBAL_INT, pos_only, int(LAT * 1e7), int(LON * 1e7), bad, 0, 0, 0, 0, 0, 0, 0, 0
        )
        assert offboard_setpoint(glob, 1, 1.0, est, home) is None
        att = mavlink.MAVLink_set_attitude_target_message(0, 1, 1, 0b0000_0111, [1.0, 0.0, bad, 0.0], 0, 0, 0, 0.5)
        assert offboard_setpoint(att, 1, 1.0, est, home) is None
        rates = mavlink.MAVLink_set_attitude_target_message(0, 1, 1, 0b1000_0000, [1, 0, 0, 0], bad, 0, 0, 0.5)
        assert offboard_setpoint(rates, 1, 1.0, est, home) is None
    sticks = manual_input(mavlink.MAVLink_manual_control_message(1, -32768, 32767, 32000, -5000, 0), 1, 1.0)
    assert (sticks.pitch, sticks.roll, sticks.throttle, sticks.yaw) == (-1.0, 0.0, 1.0, -1.0)
    assert np.isfinite([sticks.pitch, sticks.roll, sticks.throttle, sticks.yaw]).all()
