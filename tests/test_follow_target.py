"""AUTO.FOLLOW_TARGET with nothing running: the target estimate, the follow geometry, target loss, FOLLOW_TARGET
decoding and the commander's mode entry (issue 17, item 9).

The commander tests use :class:`test_commander.Bench` (a real commander and a point that goes where the setpoint
says, 50 Hz) with FOLLOW_TARGET messages handed in through the real link service
(:class:`autopilot.mavlink.follow_target_input.FollowTargetInput`), as a ground station's would arrive.
"""

from __future__ import annotations

import math
import socket

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink

from autopilot.commander.external_inputs import ExternalInputs
from autopilot.mavlink import commands
from autopilot.mavlink.follow_target_input import FollowTargetInput, decode_follow_target
from autopilot.navigation.follow_target import (
    EMERGENCY_ASCENT_M_S,
    FLOOR_M,
    FollowTargetTask,
    approach,
    follow_point,
    orbit_limits,
    step_angle,
)
from autopilot.navigation.follow_target_estimator import (
    TARGET_TIMEOUT_S,
    FollowTargetFix,
    TargetEstimator,
    filter_gains,
)
from autopilot.param_catalogue import default_store
from autopilot.topics import VehicleEstimate
from mavsim_core.geodesy import ned_to_geodetic
from mavsim_core.px4_modes import Mode, lookup_mode
from sitl.sim_settings import UgvSettings
from sitl.ugv_broadcast import UGV_COMPID, UgvRadio, follow_target_message
from sitl.ugv_world import UgvTruth

from test_commander import ACCEPTED, DENIED, ORIGIN, Bench

NAN3 = [math.nan] * 3


def follow_msg(
    north: float, east: float, vel=(math.nan,) * 3, caps: int = 1, q=(1.0, math.nan, math.nan, math.nan), down=0.0
):
    """A FOLLOW_TARGET as MAVSDK's FollowMe sends it (POS bit only, velocity filled), from system 245."""
    lat, lon, alt = ned_to_geodetic(np.array([north, east, down]), *ORIGIN)
    msg = mavlink.MAVLink_follow_target_message(
        0, caps, round(lat * 1e7), round(lon * 1e7), alt, list(vel), NAN3, list(q), NAN3, NAN3, 0
    )
    msg.pack(mavlink.MAVLink(None, 245, 190))  # sets the sender's ids, as a received message has them
    return msg


# --------------------------------------------------------------------------- modes and decoding


def test_follow_target_is_px4s_auto_sub_mode_8():
    assert Mode.from_custom_mode(4 << 16 | 8 << 24) is Mode.AUTO_FOLLOW_TARGET
    assert Mode.AUTO_FOLLOW_TARGET.label == "AUTO.FOLLOW_TARGET"
    for name in ("FOLLOW_TARGET", "auto.follow_target", "FOLLOW_ME", "follow"):
        assert lookup_mode(name).custom_mode == 0x08040000


def test_decode_takes_mavsdks_message_and_refuses_unusable_ones():
    fix = decode_follow_target(follow_msg(10.0, -5.0, vel=(1.0, 2.0, 0.0)), 7_000_000, 3.5)
    assert isinstance(fix, FollowTargetFix)
    assert fix.source == (245, 190) and fix.received_us == 7_000_000 and fix.received_wall_s == 3.5
    assert fix.vel_ned_m_s.tolist() == [1.0, 2.0, 0.0]  # used although MAVSDK sets only the POS bit
    assert math.isnan(fix.yaw_rad)  # MAVSDK's attitude (1, NaN, NaN, NaN): no heading
    yaw = 0.7
    fix = decode_follow_target(follow_msg(0, 0, caps=1 | 8, q=(math.cos(yaw / 2), 0, 0, math.sin(yaw / 2))), 0, 0)
    assert fix.yaw_rad == pytest.approx(yaw) and np.all(np.isnan(fix.vel_ned_m_s))
    assert "bit 0" in decode_follow_target(follow_msg(1, 1, caps=2), 0, 0)
    zero = follow_msg(1, 1)
    zero.lat = zero.lon = 0
    assert "0, 0" in decode_follow_target(zero, 0, 0)


def test_input_service_hands_fixes_on_and_says_each_refusal_once():
    inputs, said = ExternalInputs(), []
    svc = FollowTargetInput(inputs, lambda: 5_000_000, lambda sev, text: said.append((sev, text)), lambda: 1.0)
    handler = svc.handlers()["FOLLOW_TARGET"]
    handler(None, follow_msg(3.0, 4.0))
    assert inputs.follow_target is not None and inputs.follow_target.received_us == 5_000_000
    for _ in range(3):
        handler(None, follow_msg(3.0, 4.0, caps=0))
    assert svc.received == 1 and svc.refused == 3
    assert said == [
        (mavlink.MAV_SEVERITY_WARNING, "FOLLOW_TARGET from 245/190 ignored: no position (est_capabilities bit 0 clear)")
    ]


def test_the_sender_followed_keeps_the_target_until_it_is_silent():
    inputs = ExternalInputs()

    def fix(t_s: float, source: tuple[int, int]) -> FollowTargetFix:
        return FollowTargetFix(round(t_s * 1e6), t_s, source, 47.0, 8.0, 500.0, np.zeros(3))

    assert inputs.on_follow_target(fix(1.0, (245, 190)))
    assert not inputs.on_follow_target(fix(2.0, (1, 52)))  # the ground vehicle, while the station sends
    assert inputs.on_follow_target(fix(3.5, (245, 190)))
    assert not inputs.on_follow_target(fix(3.5 + TARGET_TIMEOUT_S - 0.1, (1, 52)))
    assert inputs.on_follow_target(fix(3.5 + TARGET_TIMEOUT_S + 0.1, (1, 52)))  # the station fell silent
    assert inputs.follow_target.source == (1, 52)
    assert inputs.follow_target_age_s(round(8e6), None) == pytest.approx(8.0 - 6.6)


# --------------------------------------------------------------------------- the target estimate


def test_filter_gains_from_responsiveness():
    assert filter_gains(0.0) == (1.0, 1.0)  # take every measurement as it is
    assert filter_gains(1.0) == (0.0, 0.0)
    g, h = filter_gains(0.1)
    assert g == pytest.approx(0.99) and h == pytest.approx(0.81)


def test_estimate_extrapolates_between_messages_at_the_measured_velocity():
    est = TargetEstimator()
    est.fuse(np.array([10.0, 0.0, 0.0]), np.array([2.0, 1.0, 0.0]), 1_000_000, 0.1, 0.9)
    pos, vel = est.predict(1_500_000)
    assert pos.tolist() == pytest.approx([11.0, 0.5, 0.0]) and vel.tolist() == [2.0, 1.0, 0.0]
    far, _ = est.predict(60_000_000)  # never further than the loss timeout
    assert far[0] == pytest.approx(10.0 + 2.0 * TARGET_TIMEOUT_S)


@pytest.mark.parametrize("rs", [0.0, 0.1, 0.5, 0.8])
def test_responsiveness_sets_how_fast_a_jump_is_taken(rs):
    est = TargetEstimator()
    est.fuse(np.zeros(3), np.zeros(3), 0, rs, 0.9)
    est.fuse(np.array([10.0, 0.0, 0.0]), np.zeros(3), 1_000_000, rs, 0.9)
    assert est.pos_ned_m[0] == pytest.approx(10.0 * (1 - rs * rs))


def test_velocity_from_positions_converges_faster_when_more_responsive():
    def speed_error_after(rs: float, n: int = 6) -> float:
        est = TargetEstimator()
        for k in range(n):  # a target at 2 m/s north, 1 Hz, no velocity in the messages (MAVSDK without one)
            est.fuse(np.array([2.0 * k, 0.0, 0.0]), np.full(3, math.nan), k * 1_000_000, rs, 0.9)
        return abs(est.vel_ned_m_s[0] - 2.0)

    assert speed_error_after(0.0) < 1e-9
    assert speed_error_after(0.1) < 0.05 < speed_error_after(0.6)


def test_a_repeated_message_is_fused_only_after_half_a_second():
    est = TargetEstimator()
    p, v = np.array([5.0, 0.0, 0.0]), np.array([2.0, 0.0, 0.0])
    est.fuse(p, v, 0, 0.1, 0.9)
    assert not est.fuse(p, v, 200_000, 0.1, 0.9)  # MAVSDK's keep-alive, soon after
    assert est.fuse(p, v, 1_000_000, 0.1, 0.9)  # the target stopped sending news: it is pulled back
    assert est.predict(1_000_000)[0][0] < 5.0 + 2.0 * 0.1


# --------------------------------------------------------------------------- geometry helpers


def test_follow_point_angle_step_and_approach():
    assert follow_point(np.array([10.0, 5.0, 0.0]), math.pi, 6.0).tolist() == pytest.approx([4.0, 5.0])
    assert follow_point(np.zeros(3), math.pi / 2, 6.0).tolist() == pytest.approx([0.0, 6.0])
    alpha, rate = step_angle(3.0, 1.0, -3.0, (1.0, 2.0), 0.1)  # the short way, across +-pi, at the rate limit
    assert (alpha, rate) == pytest.approx((3.1, 1.0))
    alpha, rate, t = 0.0, 0.0, 0.0
    while alpha != 1.0 and t < 20:  # from rest to rest: speeds up, cruises, brakes
        alpha, rate = step_angle(alpha, rate, 1.0, (0.5, 0.25), 0.02)
        assert abs(rate) <= 0.5 + 1e-9
        t += 0.02
    assert alpha == pytest.approx(1.0) and rate == 0.0 and t == pytest.approx(1.0 / 0.5 + 0.5 / 0.25, abs=0.4)
    assert orbit_limits(6.0, 5.0, 4.0) == pytest.approx((math.sqrt(2.0 / 6.0), 2.0 / 6.0))  # centripetal 2 m/s^2
    assert orbit_limits(6.0, 1.0, 4.0)[0] == pytest.approx(1.0 / 6.0)  # FLW_TGT_MAX_VEL
    pos, vel, t = 0.0, 0.0, 0.0
    while pos != -5.0 and t < 20:
        pos, vel = approach(pos, vel, -5.0, 2.0, 1.0, 0.02)
        assert abs(vel) <= 2.0 + 1e-9
        t += 0.02
    assert pos == -5.0 and vel == 0.0


# --------------------------------------------------------------------------- the commander flying it


class FollowBench(Bench):
    """The commander's bench with a target driving at ``speed`` m/s along ``course`` (rad), FOLLOW_TARGET at 5 Hz."""

    def __init__(self) -> None:
        super().__init__()
        self.svc = FollowTargetInput(self.cmd.inputs, lambda: self.t_us, lambda sev, text: None, lambda: 0.0)
        self.target = np.array([20.0, 0.0])
        self.speed, self.course, self.sending = 0.0, 0.0, True
        self.target_down = 0.0  # the target's GPS altitude, m below home

    def fly(self, seconds: float) -> list[np.ndarray]:
        """Fly; the vehicle's horizontal offsets from the true target, one per 50 Hz step."""
        offsets = []
        for _ in range(round(seconds * 50)):
            vel = self.speed * np.array([math.cos(self.course), math.sin(self.course)])
            if self.sending and self.t_us % 200_000 == 0:  # where the target is now, stamped now
                msg = follow_msg(*self.target, vel=(*vel, 0.0), down=self.target_down)
                self.svc.handlers()["FOLLOW_TARGET"](None, msg)
            self.target = self.target + vel * 0.02
            self.run(0.02)
            offsets.append(self.pos[:2] - self.target)
        return offsets


def follow_bench(dst: float = 6.0, ht: float = 10.0, fa: float = 180.0) -> FollowBench:
    b = FollowBench()
    for name, value in (("FLW_TGT_DST", dst), ("FLW_TGT_HT", ht), ("FLW_TGT_FA", fa)):
        b.params.set(name, value)
    b.fly_up()
    return b


def test_follow_target_refused_on_the_ground_and_flies_the_geometry():
    b = FollowBench()
    b.run(1.0)
    assert b.arm() == ACCEPTED
    assert b.set_mode(Mode.AUTO_FOLLOW_TARGET) == DENIED and "Follow target denied: vehicle not flying" in b.texts()
    b = follow_bench()
    main, sub = Mode.AUTO_FOLLOW_TARGET.value
    assert b.command(mavlink.MAV_CMD_DO_SET_MODE, 129, main, sub) == ACCEPTED  # what MAVSDK's start() sends
    assert b.cmd.status.mode is Mode.AUTO_FOLLOW_TARGET
    b.speed = 2.0
    offsets = b.fly(25.0)[-250:]  # settled: the last 5 s
    for off in offsets:  # 6 m behind a target driving north, 10 m above home
        assert off.tolist() == pytest.approx([-6.0, 0.0], abs=0.05)
    assert -b.pos[2] == pytest.approx(10.0, abs=0.01)
    assert b.cmd.setpoint.vel_ned_m_s[:2].tolist() == pytest.approx([2.0, 0.0], abs=0.02)  # fed forward
    assert b.cmd.setpoint.yaw_rad == pytest.approx(0.0, abs=0.02)  # facing the target
    assert "Following target 245/190" in b.texts()


def test_a_turn_of_the_target_swings_the_vehicle_round_within_the_orbit_limits():
    b = follow_bench(fa=90.0)  # on the target's right
    main, sub = Mode.AUTO_FOLLOW_TARGET.value
    b.command(mavlink.MAV_CMD_DO_SET_MODE, 129, main, sub)
    b.speed = 2.0
    assert b.fly(20.0)[-1].tolist() == pytest.approx([0.0, 6.0], abs=0.1)  # right of a northbound course: east
    b.course = math.pi / 2  # it turns east: its right is now south
    offsets = b.fly(12.0)
    distances = [float(np.hypot(*o)) for o in offsets]
    assert min(distances) > 5.0 and max(distances) < 7.0  # round the target, never over it
    rate, acc = orbit_limits(6.0, b.params.get("FLW_TGT_MAX_VEL"), b.params.get("MPC_ACC_HOR"))
    quarter_s = (math.pi / 2) / rate + rate / acc  # speeds up, orbits at the limit, brakes
    swung = next(i for i, o in enumerate(offsets) if o[0] < -5.9) * 0.02
    assert swung == pytest.approx(quarter_s, abs=0.6)
    assert offsets[-1].tolist() == pytest.approx([-6.0, 0.0], abs=0.1)


def test_target_loss_holds_position_and_following_resumes():
    b = follow_bench()
    main, sub = Mode.AUTO_FOLLOW_TARGET.value
    b.command(mavlink.MAV_CMD_DO_SET_MODE, 129, main, sub)
    b.speed = 2.0
    b.fly(20.0)
    b.sending = False
    n = len(b.events)
    b.fly(TARGET_TIMEOUT_S - 0.2)  # extrapolated meanwhile: still following
    assert not any("lost" in t for _, t in b.events[n:])
    b.fly(0.4)
    lost = [(t, text) for t, text in b.events[n:] if text.startswith("Follow target lost")]
    assert len(lost) == 1 and b.cmd.status.mode is Mode.AUTO_FOLLOW_TARGET  # still in the mode, as PX4
    held = b.pos.copy()
    b.fly(5.0)
    assert np.allclose(b.pos, held) and np.allclose(b.cmd.setpoint.vel_ned_m_s, 0.0)
    b.sending = True
    b.fly(15.0)
    assert float(np.hypot(*(b.pos[:2] - b.target))) == pytest.approx(6.0, abs=0.1)  # caught up again


def test_climbs_to_the_follow_height_before_moving_horizontally():
    b = follow_bench(ht=12.0)
    start = b.pos.copy()
    b.command(mavlink.MAV_CMD_DO_SET_MODE, 129, *Mode.AUTO_FOLLOW_TARGET.value)
    track = []
    for _ in range(100):
        b.fly(0.1)
        track.append(b.pos.copy())
    for p in track:
        if -p[2] < 12.0 - 3.0 - 0.2:  # more than ALT_ACCEPTANCE_M below: no horizontal move yet
            assert np.allclose(p[:2], start[:2])
    assert track[-1][0] > 10.0  # then it went to the target (20 m north, standing): 6 m short of it


def test_stop_hold_leaves_follow_mode():
    b = follow_bench()
    b.command(mavlink.MAV_CMD_DO_SET_MODE, 129, *Mode.AUTO_FOLLOW_TARGET.value)
    b.fly(5.0)
    main, sub = Mode.AUTO_LOITER.value
    assert commands.handle_set_mode(b.cmd, 129, main << 16 | sub << 24) == ACCEPTED  # MAVSDK's stop()
    assert b.cmd.status.mode is Mode.AUTO_LOITER


def test_a_target_below_home_is_followed_at_the_minimum_height_and_said_once():
    """Issue 36: FLW_TGT_ALT_M 2 (MAVSDK's TARGET_GPS) and a target reported 8 m below home took the vehicle to
    the ground.  It follows at FLOOR_M above home instead, horizontally too, and says so once."""
    b = follow_bench(ht=8.0)
    b.params.set("FLW_TGT_ALT_M", 2)
    b.target_down, b.speed = 8.0, 1.0
    b.command(mavlink.MAV_CMD_DO_SET_MODE, 129, *Mode.AUTO_FOLLOW_TARGET.value)
    heights = []
    for _ in range(300):
        b.fly(0.1)
        heights.append(-b.pos[2])
    assert min(heights) > FLOOR_M - 0.02 and heights[-1] == pytest.approx(FLOOR_M)  # (approach's last step)
    assert float(np.hypot(*(b.pos[:2] - b.target))) == pytest.approx(6.0, abs=0.1)  # still following
    floor = [t for t in b.texts() if "following at the minimum" in t]
    assert floor == ["Follow target: 0.0 m above home asked: following at the minimum, 1.5 m"]
    assert b.cmd.status.armed and b.cmd.status.mode is Mode.AUTO_FOLLOW_TARGET
    b.target_down = -4.0  # the target's altitude back above home: FLW_TGT_HT above it
    b.fly(20.0)
    assert -b.pos[2] == pytest.approx(12.0)


def test_under_the_minimum_safety_altitude_it_stops_and_climbs_at_half_a_metre_a_second():
    """PX4's emergency ascent: under MIN_SAFETY_ALT_M above home (the vehicle entered the mode that low), no
    horizontal position control, the height setpoint rising at EMERGENCY_ASCENT_M_S; said once."""
    said: list[str] = []
    fix = FollowTargetFix(0, 0.0, (245, 190), *ned_to_geodetic(np.array([20.0, 0.0, 0.0]), *ORIGIN), np.zeros(3))
    task = FollowTargetTask(default_store(), lambda: fix, 0.0, lambda sev, text: said.append(text))

    def at(down: float, k: int):  # the vehicle moving north at 2 m/s, ``down`` m NED, at step k (50 Hz)
        e = VehicleEstimate(k * 20_000, np.array([1.0, 0, 0, 0]), np.zeros(3), np.zeros(3), np.array([0, 0, down]),
                            np.array([2.0, 0, 0]), True, True, *ORIGIN)  # fmt: skip
        return task.update(e, k * 20_000) if k else task.activate(e, 0)

    at(-0.6, 0)
    downs = []
    for k in range(1, 51):
        sp = at(-0.6, k)
        assert np.all(np.isnan(sp.pos_ned_m[:2])) and sp.vel_ned_m_s.tolist() == [0.0, 0.0, -EMERGENCY_ASCENT_M_S]
        downs.append(sp.pos_ned_m[2])
    assert downs[-1] - downs[0] == pytest.approx(-EMERGENCY_ASCENT_M_S * 49 * 0.02)  # 0.5 m/s up
    assert said.count("Follow target: under 1 m above home: climbing at 0.5 m/s") == 1
    sp = at(-1.1, 51)  # above the minimum: on to FLW_TGT_HT (8 m) from where it is, still climbing
    assert sp.pos_ned_m[:2].tolist() == [0.0, 0.0] and sp.pos_ned_m[2] < downs[-1]
    assert at(-0.6, 52).vel_ned_m_s[2] == -EMERGENCY_ASCENT_M_S
    assert sum("climbing" in t for t in said) == 1  # once per activation


# --------------------------------------------------------------------------- the ground vehicle's radio


def test_ugv_radio_sends_follow_target_at_its_rate_only_when_enabled():
    rx = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    rx.bind(("127.0.0.1", 0))
    rx.settimeout(1.0)
    settings = UgvSettings()
    radio = UgvRadio(settings, rx.getsockname(), 5, ORIGIN)
    truth = UgvTruth(0, np.array([3.0, 4.0, -0.3]), np.array([1.5, -0.5, 0.0]), 0.5)
    try:
        for t in range(0, 2_000_000, 20_000):
            radio.step(t, lambda: truth)
        assert radio.sent == 0  # SIM_UGV_FLW = 0
        settings.follow_target = 1
        for t in range(0, 2_000_000, 20_000):
            radio.step(t, lambda: UgvTruth(t, truth.deck_pos_ned_m, truth.vel_ned_m_s, truth.yaw_rad))
        assert radio.sent == 10  # 5 Hz for 2 s
        parser = mavlink.MAVLink(None)
        msg = parser.parse_buffer(rx.recv(1000))[0]
        assert msg.get_type() == "FOLLOW_TARGET" and (msg.get_srcSystem(), msg.get_srcComponent()) == (5, UGV_COMPID)
        fix = decode_follow_target(msg, 0, 0.0)
        assert msg.est_capabilities == 1 | 2 | 8 and msg.timestamp == 0
        lat, lon, alt = ned_to_geodetic(truth.deck_pos_ned_m, *ORIGIN)
        assert (fix.lat_deg, fix.lon_deg) == pytest.approx((lat, lon), abs=1e-7)  # degE7: 1 cm
        assert fix.alt_amsl_m == pytest.approx(alt, abs=1e-3)  # a float32
        assert fix.vel_ned_m_s.tolist() == pytest.approx([1.5, -0.5, 0.0]) and fix.yaw_rad == pytest.approx(0.5)
    finally:
        radio.close()
        rx.close()


def test_ugv_message_fields():
    msg = follow_target_message(UgvTruth(1_234_000, np.zeros(3), np.zeros(3), math.pi), ORIGIN)
    assert msg.timestamp == 1234 and msg.alt == pytest.approx(ORIGIN[2])
    assert msg.attitude_q[0] == pytest.approx(0.0, abs=1e-9) and msg.attitude_q[3] == pytest.approx(1.0)


def test_a_sender_silent_in_simulated_time_is_replaced_at_once_when_inputs_age_on_the_simulated_clock():
    """The stale ground station that a stepped flight left behind (issue 33): 30 simulated seconds silent but
    only 1 wall second.  On both clocks (the default) it still holds the target; with ``--input-clock sim``
    (``on_wall_clock`` False) the ground vehicle takes it over at once."""

    def fix(t_s: float, wall_s: float, source: tuple[int, int]) -> FollowTargetFix:
        return FollowTargetFix(round(t_s * 1e6), wall_s, source, 47.0, 8.0, 500.0, np.zeros(3))

    both, sim_only = ExternalInputs(), ExternalInputs()
    sim_only.on_wall_clock = False
    for inputs in (both, sim_only):
        assert inputs.on_follow_target(fix(10.0, 100.0, (245, 190)))
    assert not both.on_follow_target(fix(40.0, 101.0, (1, 52)))
    assert sim_only.on_follow_target(fix(40.0, 101.0, (1, 52)))
    assert sim_only.follow_target.source == (1, 52)
