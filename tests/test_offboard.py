"""OFFBOARD with nothing running: offboard messages decoded, the task's setpoints, the entry and loss rules.

Messages are built with pymavlink as a client sends them and decoded with a synthetic estimate (origin
47.4 N 8.5 E 500 m, the vehicle at ``POS`` heading ``YAW``).  The task is driven through its interface
(activate, on_ground, update) at 50 Hz.  Frames NED, metres, seconds, radians.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink

from autopilot.commander import failsafes
from autopilot.commander.external_inputs import ExternalInputs
from autopilot.control.position_control import PositionSetpoint
from autopilot.mavlink import telemetry
from autopilot.mavlink.offboard_messages import offboard_setpoint
from autopilot.navigation import offboard
from autopilot.navigation.offboard import OffboardTask, loss_fallback_mode, offboard_lost, offboard_refusal
from autopilot.param_catalogue import default_store
from autopilot.topics import (
    AttitudeSetpoint,
    BatteryState,
    ControlSetpoints,
    HomePosition,
    LandedState,
    OffboardKind,
    TelemetrySnapshot,
    VehicleEstimate,
)
from mavsim_core import quaternion as quat
from mavsim_core.geodesy import ned_to_geodetic
from mavsim_core.px4_modes import Mode

M = mavlink
ORIGIN = (47.4, 8.5, 500.0)
POS = (10.0, -4.0, -6.0)
YAW = math.radians(90.0)  # facing east: forward = east, right = south
NOW_US, WALL_S = 7_000_000, 100.0
HOVER = 0.42
nan = math.nan

# type_masks as MAVSDK's Offboard plugin sends them
ONLY_POS = 0b1001_1111_1000  # x y z, yaw (ignores velocity, acceleration, yaw rate)
ONLY_VEL = 0b1001_1100_0111  # vx vy vz, yaw
ONLY_ACC = 0b1000_0011_1111  # afx afy afz, yaw
VEL_YAW_RATE = 0b0101_1100_0111  # vx vy vz, yaw rate
ATT_ONLY = M.ATTITUDE_TARGET_TYPEMASK_BODY_ROLL_RATE_IGNORE | M.ATTITUDE_TARGET_TYPEMASK_BODY_PITCH_RATE_IGNORE
ATT_ONLY |= M.ATTITUDE_TARGET_TYPEMASK_BODY_YAW_RATE_IGNORE
RATES_ONLY = M.ATTITUDE_TARGET_TYPEMASK_ATTITUDE_IGNORE


def estimate(pos=POS, yaw: float = YAW, valid: bool = True) -> VehicleEstimate:
    return VehicleEstimate(
        timestamp_us=NOW_US, q_wxyz=quat.from_euler(0.0, 0.0, yaw), rate_frd_rad_s=np.zeros(3),
        accel_ned_m_s2=np.zeros(3), pos_ned_m=np.array(pos, dtype=float), vel_ned_m_s=np.zeros(3),
        attitude_valid=True, position_valid=valid, origin_lat_deg=ORIGIN[0], origin_lon_deg=ORIGIN[1],
        origin_alt_amsl_m=ORIGIN[2], yaw_rad=yaw,
    )  # fmt: skip


HOME = HomePosition(ORIGIN[0], ORIGIN[1], 510.0, np.array([0.0, 0.0, -10.0]), 0.0)


def local(frame, mask, pos=(0, 0, 0), vel=(0, 0, 0), acc=(0, 0, 0), yaw=0.0, yaw_rate=0.0):
    return M.MAVLink_set_position_target_local_ned_message(0, 1, 1, frame, mask, *pos, *vel, *acc, yaw, yaw_rate)


def global_int(frame, mask, lat, lon, alt, vel=(0, 0, 0), yaw=0.0):
    return M.MAVLink_set_position_target_global_int_message(
        0, 1, 1, frame, mask, round(lat * 1e7), round(lon * 1e7), alt, *vel, 0, 0, 0, yaw, 0.0
    )


def attitude(mask, q=(1, 0, 0, 0), rates=(0, 0, 0), thrust=0.5):
    return M.MAVLink_set_attitude_target_message(0, 1, 1, mask, list(q), *rates, thrust)


def decode(msg, est=None, home=HOME):
    return offboard_setpoint(msg, NOW_US, WALL_S, estimate() if est is None else est, home)


# --------------------------------------------------------------------------- SET_POSITION_TARGET_LOCAL_NED


def test_local_ned_position_with_yaw_is_taken_as_given():
    sp = decode(local(M.MAV_FRAME_LOCAL_NED, ONLY_POS, pos=(5, 5, -5), yaw=0.3))
    assert sp.kind is OffboardKind.POSITION and sp.frame == M.MAV_FRAME_LOCAL_NED
    assert sp.received_us == NOW_US and sp.received_wall_s == WALL_S
    np.testing.assert_allclose(sp.pos_ned_m, [5, 5, -5])
    assert np.isnan(sp.vel_ned_m_s).all() and np.isnan(sp.acc_ned_m_s2).all()
    assert sp.yaw_rad == pytest.approx(0.3) and math.isnan(sp.yaw_rate_rad_s)


def test_local_offset_ned_adds_the_vehicle_position():
    sp = decode(local(M.MAV_FRAME_LOCAL_OFFSET_NED, ONLY_POS, pos=(1, 2, -3)))
    np.testing.assert_allclose(sp.pos_ned_m, [11, -2, -9])
    assert sp.frame == M.MAV_FRAME_LOCAL_OFFSET_NED


def test_body_ned_rotates_velocity_by_the_heading_and_keeps_position_local():
    sp = decode(local(M.MAV_FRAME_BODY_NED, VEL_YAW_RATE, vel=(2, 1, -0.5), yaw_rate=0.2))
    assert sp.kind is OffboardKind.VELOCITY and sp.frame == M.MAV_FRAME_BODY_NED
    np.testing.assert_allclose(sp.vel_ned_m_s, [-1, 2, -0.5], atol=1e-9)  # forward = east, right = south
    assert sp.yaw_rate_rad_s == pytest.approx(0.2) and math.isnan(sp.yaw_rad)
    sp = decode(local(M.MAV_FRAME_BODY_NED, ONLY_POS, pos=(5, 5, -5)))
    np.testing.assert_allclose(sp.pos_ned_m, [5, 5, -5])


def test_body_offset_ned_rotates_the_offset_and_adds_the_position():
    sp = decode(local(M.MAV_FRAME_BODY_OFFSET_NED, ONLY_POS, pos=(2, 0, -1)))
    np.testing.assert_allclose(sp.pos_ned_m, [10, -2, -7], atol=1e-9)  # 2 m forward = 2 m east


def test_lowest_level_given_sets_the_kind_and_masked_parts_are_nan():
    assert decode(local(M.MAV_FRAME_LOCAL_NED, ONLY_ACC, acc=(0, 0, -1))).kind is OffboardKind.ACCELERATION
    mixed = ONLY_POS & ~M.POSITION_TARGET_TYPEMASK_VZ_IGNORE | M.POSITION_TARGET_TYPEMASK_Z_IGNORE
    sp = decode(local(M.MAV_FRAME_LOCAL_NED, mixed, pos=(1, 2, 3), vel=(9, 9, -1)))
    assert sp.kind is OffboardKind.POSITION
    np.testing.assert_allclose(sp.pos_ned_m[:2], [1, 2])
    assert math.isnan(sp.pos_ned_m[2]) and sp.vel_ned_m_s[2] == -1 and np.isnan(sp.vel_ned_m_s[:2]).all()


@pytest.mark.parametrize(
    "msg, est, why",
    [
        (local(M.MAV_FRAME_LOCAL_NED, ONLY_POS, pos=(nan, 0, 0)), None, "NaN in a used field"),
        (local(M.MAV_FRAME_LOCAL_NED, ONLY_VEL, vel=(math.inf, 0, 0)), None, "infinity in a used field"),
        (local(M.MAV_FRAME_LOCAL_NED, ONLY_ACC | M.POSITION_TARGET_TYPEMASK_FORCE_SET), None, "force setpoint"),
        (local(M.MAV_FRAME_LOCAL_NED, 0b1111_1111_1111), None, "nothing given"),
        (local(M.MAV_FRAME_GLOBAL_INT, ONLY_POS), None, "a global frame in the local message"),
        (local(M.MAV_FRAME_BODY_FRD, ONLY_POS), None, "unsupported frame"),
        (local(M.MAV_FRAME_LOCAL_OFFSET_NED, ONLY_POS), estimate(valid=False), "offset without a position"),
        (local(M.MAV_FRAME_BODY_NED, ONLY_VEL | M.POSITION_TARGET_TYPEMASK_VY_IGNORE), None, "half a body vector"),
    ],
)
def test_unusable_local_messages_give_none(msg, est, why):
    assert decode(msg, est) is None, why


def test_no_estimate_only_matters_where_a_conversion_needs_it():
    assert offboard_setpoint(local(M.MAV_FRAME_LOCAL_NED, ONLY_POS), NOW_US, WALL_S, None) is not None
    assert offboard_setpoint(local(M.MAV_FRAME_BODY_NED, ONLY_VEL), NOW_US, WALL_S, None) is None
    assert offboard_setpoint(M.MAVLink_heartbeat_message(6, 8, 0, 0, 0, 3), NOW_US, WALL_S, estimate()) is None


# --------------------------------------------------------------------------- SET_POSITION_TARGET_GLOBAL_INT


def test_global_int_amsl_and_relative_altitude():
    lat, lon, _ = ned_to_geodetic(np.array([30.0, -20.0, 0.0]), *ORIGIN)
    sp = decode(global_int(M.MAV_FRAME_GLOBAL_INT, ONLY_POS, lat, lon, 512.0))
    assert sp.kind is OffboardKind.POSITION and sp.frame == M.MAV_FRAME_GLOBAL_INT
    np.testing.assert_allclose(sp.pos_ned_m, [30, -20, -12], atol=0.02)  # degE7 is ~1 cm
    sp = decode(global_int(M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, ONLY_POS, lat, lon, 5.0))
    np.testing.assert_allclose(sp.pos_ned_m, [30, -20, -15], atol=0.02)  # home at 510 m AMSL
    assert decode(global_int(M.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, ONLY_POS, lat, lon, 5.0), home=None) is None


def test_global_int_velocity_needs_no_position():
    sp = decode(global_int(M.MAV_FRAME_GLOBAL_INT, ONLY_VEL, 0, 0, 0, vel=(1, 2, 3)), estimate(valid=False))
    assert sp.kind is OffboardKind.VELOCITY and np.isnan(sp.pos_ned_m).all()
    np.testing.assert_allclose(sp.vel_ned_m_s, [1, 2, 3])


@pytest.mark.parametrize("frame", [M.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT, M.MAV_FRAME_LOCAL_NED, M.MAV_FRAME_BODY_NED])
def test_global_int_unsupported_frames(frame):
    assert decode(global_int(frame, ONLY_POS, 47.4, 8.5, 5.0)) is None


def test_global_int_without_an_estimate_or_with_a_bad_altitude():
    assert offboard_setpoint(global_int(M.MAV_FRAME_GLOBAL_INT, ONLY_POS, 47.4, 8.5, 5.0), 0, 0.0, None) is None
    assert decode(global_int(M.MAV_FRAME_GLOBAL_INT, ONLY_POS, 47.4, 8.5, nan)) is None


# --------------------------------------------------------------------------- SET_ATTITUDE_TARGET


def test_attitude_quaternion_is_normalised_with_thrust_and_yaw_rate():
    q = quat.from_euler(0.1, -0.2, 0.3) * 2.0
    mask = ATT_ONLY & ~M.ATTITUDE_TARGET_TYPEMASK_BODY_YAW_RATE_IGNORE
    sp = decode(attitude(mask, q=q, rates=(9, 9, 0.25), thrust=0.6))
    assert sp.kind is OffboardKind.ATTITUDE
    np.testing.assert_allclose(sp.q_wxyz, q / 2.0, atol=1e-6)
    assert sp.thrust_frac == pytest.approx(0.6) and sp.yaw_rate_rad_s == pytest.approx(0.25)
    assert decode(attitude(ATT_ONLY | M.ATTITUDE_TARGET_TYPEMASK_THROTTLE_IGNORE)).thrust_frac != 0.5  # NaN
    assert decode(attitude(ATT_ONLY, thrust=1.7)).thrust_frac == 1.0  # clipped to 0..1


def test_body_rates_with_ignored_rates_zero():
    mask = RATES_ONLY | M.ATTITUDE_TARGET_TYPEMASK_BODY_YAW_RATE_IGNORE
    sp = decode(attitude(mask, q=(0, 0, 0, 0), rates=(0.5, -0.25, 7), thrust=0.4))
    assert sp.kind is OffboardKind.BODY_RATES and sp.q_wxyz is None
    np.testing.assert_allclose(sp.body_rate_frd_rad_s, [0.5, -0.25, 0.0])


@pytest.mark.parametrize(
    "msg, why",
    [
        (attitude(ATT_ONLY, q=(0, 0, 0, 0)), "zero quaternion"),
        (attitude(ATT_ONLY, q=(nan, 0, 0, 0)), "NaN quaternion"),
        (attitude(ATT_ONLY, thrust=nan), "NaN thrust"),
        (attitude(RATES_ONLY, rates=(nan, 0, 0)), "NaN rate"),
        (attitude(RATES_ONLY | 0b111), "neither attitude nor rates"),
        (attitude(ATT_ONLY | 32), "thrust vector (THRUST_BODY_SET)"),
    ],
)
def test_unusable_attitude_messages_give_none(msg, why):
    assert decode(msg) is None, why


# --------------------------------------------------------------------------- the task


class Flight:
    """An OffboardTask fed the decoded setpoint ``self.sp`` (None: none yet) with the vehicle at ``pos``."""

    def __init__(self, pos=POS, on_ground: bool = False) -> None:
        self.sp = None
        self.pos = np.array(pos, dtype=float)
        self.t_us = NOW_US
        self.task = OffboardTask(default_store(), lambda: self.sp, HOVER)
        self.task.on_ground = on_ground
        self.task.activate(estimate(self.pos), self.t_us)

    def send(self, msg) -> None:
        self.sp = decode(msg, estimate(self.pos))
        assert self.sp is not None

    def step(self, n: int = 1):
        out = None
        for _ in range(n):
            self.t_us += 20_000
            out = self.task.update(estimate(self.pos), self.t_us)
        return out


def test_task_holds_where_activated_before_the_first_setpoint():
    f = Flight()
    out = f.step()
    assert isinstance(out, PositionSetpoint)
    np.testing.assert_allclose(out.pos_ned_m, POS)
    assert out.yaw_rad == pytest.approx(YAW)


def test_task_flies_position_velocity_and_acceleration_setpoints():
    f = Flight()
    f.send(local(M.MAV_FRAME_LOCAL_NED, ONLY_POS, pos=(1, 2, -3), yaw=0.5))
    out = f.step()
    np.testing.assert_allclose(out.pos_ned_m, [1, 2, -3])
    assert out.yaw_rad == pytest.approx(0.5) and np.isnan(out.vel_ned_m_s).all()
    f.send(local(M.MAV_FRAME_LOCAL_NED, ONLY_VEL, vel=(1, 0, 0), yaw=0.5))
    out = f.step()
    assert np.isnan(out.pos_ned_m).all() and out.vel_ned_m_s[0] == 1.0
    f.send(local(M.MAV_FRAME_LOCAL_NED, ONLY_ACC, acc=(0.5, 0, 0), yaw=0.5))
    out = f.step()
    assert np.isnan(out.vel_ned_m_s).all() and out.acc_ned_m_s2[0] == 0.5


def test_task_integrates_a_yaw_rate_and_holds_the_yaw_without_one():
    f = Flight()
    f.send(local(M.MAV_FRAME_LOCAL_NED, VEL_YAW_RATE, vel=(0, 0, 0), yaw_rate=0.2))
    out = f.step(50)  # 1 s
    assert out.yaw_rad == pytest.approx(YAW + 0.2, abs=1e-6)
    f.send(local(M.MAV_FRAME_LOCAL_NED, ONLY_VEL | M.POSITION_TARGET_TYPEMASK_YAW_IGNORE))
    assert f.step(50).yaw_rad == pytest.approx(YAW + 0.2, abs=1e-6)


def test_task_attitude_and_rates_with_the_hover_thrust_when_none_given():
    f = Flight()
    q = quat.from_euler(0.1, 0.0, 1.0)
    f.send(attitude(ATT_ONLY, q=q, thrust=0.55))
    out = f.step()
    assert isinstance(out, AttitudeSetpoint) and out.body_rate_frd_rad_s is None
    np.testing.assert_allclose(out.q_wxyz, q, atol=1e-6)
    assert out.thrust_frac == pytest.approx(0.55)
    f.send(attitude(RATES_ONLY | M.ATTITUDE_TARGET_TYPEMASK_THROTTLE_IGNORE, rates=(0.1, 0.2, 0.3)))
    out = f.step()
    assert out.q_wxyz is None and out.thrust_frac == HOVER
    np.testing.assert_allclose(out.body_rate_frd_rad_s, [0.1, 0.2, 0.3])


@pytest.mark.parametrize(
    "msg, lifts",
    [
        (None, False),
        (local(M.MAV_FRAME_LOCAL_NED, ONLY_POS, pos=(0, 0, 0)), False),  # the ground itself
        (local(M.MAV_FRAME_LOCAL_NED, ONLY_POS, pos=(0, 0, -5)), True),
        (local(M.MAV_FRAME_LOCAL_NED, ONLY_POS | M.POSITION_TARGET_TYPEMASK_Z_IGNORE, pos=(3, 0, 0)), False),
        (local(M.MAV_FRAME_LOCAL_NED, ONLY_VEL, vel=(1, 0, 0)), False),
        (local(M.MAV_FRAME_LOCAL_NED, ONLY_VEL, vel=(0, 0, -1)), True),
        (local(M.MAV_FRAME_LOCAL_NED, ONLY_ACC, acc=(0, 0, -1)), True),
        (attitude(ATT_ONLY, thrust=0.05), False),
        (attitude(ATT_ONLY, thrust=0.6), True),
        (attitude(RATES_ONLY, thrust=0.6), True),
    ],
)
def test_task_on_the_ground_idles_until_the_setpoint_climbs(msg, lifts):
    f = Flight(pos=(0, 0, 0), on_ground=True)
    if msg is not None:
        f.send(msg)
    out = f.step()
    assert (out is not None) == lifts
    f.task.on_ground = False
    assert f.step() is not None  # in the air it always flies something


def test_task_shift_moves_the_held_point_only():
    f = Flight()
    f.task.shift(np.array([1.0, 0.0, 0.0]))
    np.testing.assert_allclose(f.step().pos_ned_m, [11, -4, -6])


# --------------------------------------------------------------------------- entry, loss, fallback


def stream(inputs: ExternalInputs, t_us: int, wall_s: float, n: int = 5, every_us: int = 50_000, wall_every=0.05):
    msg = local(M.MAV_FRAME_LOCAL_NED, ONLY_POS)
    for i in range(n):
        inputs.on_offboard(offboard_setpoint(msg, t_us + i * every_us, wall_s + i * wall_every, None))


def test_entry_needs_a_stream():
    p = default_store()
    inputs = ExternalInputs()
    assert offboard_refusal(inputs, NOW_US, WALL_S, p) == "no offboard setpoints streaming"
    stream(inputs, NOW_US, WALL_S, n=1)
    # One recent setpoint is enough, as PX4's offboard check: MAVSDK's examples set one, then start at once.
    assert offboard_refusal(inputs, NOW_US, WALL_S, p) is None
    stream(inputs, NOW_US, WALL_S, n=3)
    assert offboard_refusal(inputs, NOW_US + 150_000, WALL_S + 0.15, p) is None
    assert offboard_refusal(inputs, NOW_US + 3_000_000, WALL_S + 3.0, p) is not None  # stopped


def test_loss_needs_silence_on_both_clocks():
    p = default_store()
    assert p.get("COM_OF_LOSS_T") == 1.0 and p.get("COM_OBL_RC_ACT") == 0  # PX4's defaults
    inputs = ExternalInputs()
    assert offboard_lost(inputs, NOW_US, WALL_S, p)  # never came
    stream(inputs, NOW_US, WALL_S, n=2)
    last_us, last_wall = NOW_US + 50_000, WALL_S + 0.05
    # The simulation ran 20x faster than the client's 20 Hz: 2 s simulated, 0.1 s of wall clock.
    assert not offboard_lost(inputs, last_us + 2_000_000, last_wall + 0.1, p)
    assert offboard_refusal(inputs, last_us + 2_000_000, last_wall + 0.1, p) is None
    # Silent on both clocks for longer than COM_OF_LOSS_T: lost.
    assert offboard_lost(inputs, last_us + 2_000_000, last_wall + 1.5, p)
    # Simulated time only (no wall clock): the simulated age decides.
    assert not offboard_lost(inputs, last_us + 900_000, None, p)
    assert offboard_lost(inputs, last_us + 1_100_000, None, p)
    p.set("COM_OF_LOSS_T", 5.0)
    assert not offboard_lost(inputs, last_us + 2_000_000, last_wall + 4.0, p)


@pytest.mark.parametrize(
    "action, mode",
    [
        (0, Mode.POSCTL), (1, Mode.POSCTL), (2, Mode.POSCTL), (3, Mode.AUTO_RTL), (4, Mode.AUTO_LAND),
        (5, Mode.AUTO_LOITER), (6, offboard.TERMINATE), (7, offboard.TERMINATE),
    ],
)  # fmt: skip
def test_loss_fallback_mode(action, mode):
    p = default_store()
    p.set("COM_OBL_RC_ACT", action)
    assert loss_fallback_mode(p) == mode
    assert offboard.TERMINATE == failsafes.TERMINATE  # what the failsafes take for "stop the motors"


def test_params_are_pxs():
    names = {d.name: d for d in offboard.PARAMS}
    assert (names["COM_OF_LOSS_T"].default, names["COM_OF_LOSS_T"].min, names["COM_OF_LOSS_T"].max) == (1.0, 0, 60)
    assert (names["COM_OBL_RC_ACT"].default, names["COM_OBL_RC_ACT"].max) == (0, 7)


# --------------------------------------------------------------------------- echo (as PX4 does)


def test_position_target_global_int_echoes_the_setpoint_with_uncontrolled_parts_flagged():
    control = ControlSetpoints(
        NOW_US, np.array([30.0, -20.0, nan]), np.array([0.5, 0.0, -1.0]), np.zeros(3), 0.3,
        quat.from_euler(0, 0, 0.3), np.zeros(3), 0.5,
    )  # fmt: skip
    snap = TelemetrySnapshot(
        NOW_US, M.MAV_TYPE_QUADROTOR, True, 0, 0, M.MAV_STATE_ACTIVE, LandedState.IN_AIR, estimate(), None, HOME,
        BatteryState(15.0, 1.0, 0.9), 0.5, 0, 0, 0, True, control=control,
    )  # fmt: skip
    msg = telemetry.BUILDERS[M.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT](snap, NOW_US)
    assert M.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT in telemetry.DEFAULT_STREAM_RATES_HZ
    lat, lon, _ = ned_to_geodetic(np.array([30.0, -20.0, 0.0]), *ORIGIN)
    assert msg.coordinate_frame == M.MAV_FRAME_GLOBAL_INT
    assert (msg.lat_int, msg.lon_int) == (round(lat * 1e7), round(lon * 1e7))
    assert (
        msg.type_mask & M.POSITION_TARGET_TYPEMASK_Z_IGNORE and not msg.type_mask & M.POSITION_TARGET_TYPEMASK_X_IGNORE
    )
    assert (msg.vx, msg.vz, msg.yaw) == pytest.approx((0.5, -1.0, 0.3))
    caps = telemetry.CAPABILITIES
    for bit in ("SET_ATTITUDE_TARGET", "SET_POSITION_TARGET_LOCAL_NED", "SET_POSITION_TARGET_GLOBAL_INT"):
        assert caps & getattr(M, "MAV_PROTOCOL_CAPABILITY_" + bit)
