"""The stick modes with nothing running: sticks and synthetic estimates in, setpoints out.

Each task is driven through its interface (activate, update, on_ground) at the commander's 50 Hz.
Where a test needs the vehicle to move, a point-mass vehicle flies the position setpoint as the
position loop would (velocity = feed-forward + MPC_XY_P / MPC_Z_P times the position error on
controlled axes).  Frames NED, metres, seconds, radians; sticks as ManualInput (pitch forward +1,
roll right +1, yaw clockwise +1, throttle 0..1 with 0.5 centred).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

from autopilot.navigation.manual_modes import (
    PARAMS,
    AcroTask,
    AltCtlTask,
    PosCtlTask,
    StabilizedTask,
    climb_stick,
    deadzone,
    thrust_curve,
)
from autopilot.navigation.stick_expo import expo
from autopilot.param_catalogue import default_store
from autopilot.topics import AttitudeSetpoint, ManualInput, VehicleEstimate
from mavsim_core import quaternion as quat
from mavsim_core.constants import GRAVITY_M_S2

STEP_US = 20_000
DT_S = STEP_US * 1e-6
YAW = 0.4  # the vehicle's heading in most tests, rad
HOVER = 0.42  # the vehicle's hover thrust fraction


def sticks(pitch=0.0, roll=0.0, throttle=0.5, yaw=0.0) -> ManualInput:
    return ManualInput(0, 0.0, pitch, roll, throttle, yaw)


def estimate(pos, vel=(0.0, 0.0, 0.0), yaw_rad: float = YAW) -> VehicleEstimate:
    return VehicleEstimate(
        timestamp_us=0,
        q_wxyz=quat.from_euler(0.0, 0.0, yaw_rad),
        rate_frd_rad_s=np.zeros(3),
        accel_ned_m_s2=np.zeros(3),
        pos_ned_m=np.array(pos, dtype=float),
        vel_ned_m_s=np.array(vel, dtype=float),
        attitude_valid=True,
        position_valid=True,
        origin_lat_deg=47.4,
        origin_lon_deg=8.5,
        origin_alt_amsl_m=500.0,
        yaw_rad=yaw_rad,
    )


class Pilot:
    """A task, the sticks it reads (``self.input``, None = no sticks) and a vehicle that flies its setpoints."""

    def __init__(self, make, pos=(0.0, 0.0, -5.0), on_ground: bool = False, **kwargs) -> None:
        self.params = default_store()
        self.input: ManualInput | None = sticks()
        self.pos = np.array(pos, dtype=float)
        self.vel = np.zeros(3)
        self.t_us = 5_000_000
        self.task = make(self.params, lambda: self.input, **kwargs)
        self.task.on_ground = on_ground
        self.task.activate(self.est(), self.t_us)
        self.sp = None

    def est(self) -> VehicleEstimate:
        return estimate(self.pos, self.vel, YAW)

    def step(self, seconds: float = DT_S):
        """Update the task for ``seconds`` of simulated time, flying its setpoints; the last setpoint."""
        for _ in range(max(1, round(seconds / DT_S))):
            self.t_us += STEP_US
            self.sp = self.task.update(self.est(), self.t_us)
            if self.sp is not None and not isinstance(self.sp, AttitudeSetpoint):
                self._fly(self.sp)
        return self.sp

    def _fly(self, sp) -> None:
        gains = np.array([self.params.get("MPC_XY_P")] * 2 + [self.params.get("MPC_Z_P")])
        vel = np.where(np.isfinite(sp.vel_ned_m_s), sp.vel_ned_m_s, 0.0)
        held = np.isfinite(sp.pos_ned_m)
        vel[held] += gains[held] * (sp.pos_ned_m[held] - self.pos[held])
        self.vel = vel
        self.pos = self.pos + vel * DT_S


def heading(forward: float, right: float) -> np.ndarray:
    """A heading-frame vector in NED at heading YAW."""
    c, s = math.cos(YAW), math.sin(YAW)
    return np.array([c * forward - s * right, s * forward + c * right])


# -- stick shaping ------------------------------------------------------------------------------


def test_deadzone_zeroes_the_centre_and_keeps_full_travel():
    assert deadzone(0.05, 0.1) == 0.0
    assert deadzone(-0.1, 0.1) == 0.0
    assert deadzone(1.0, 0.1) == 1.0 and deadzone(-1.0, 0.1) == -1.0
    assert deadzone(0.55, 0.1) == pytest.approx(0.5)
    assert deadzone(0.3, 0.0) == pytest.approx(0.3)


def test_throttle_stick_is_zero_centred_and_thrust_curve_passes_through_hover():
    assert climb_stick(0.5) == 0.0 and climb_stick(1.0) == 1.0 and climb_stick(0.0) == -1.0
    assert thrust_curve(0.0, HOVER, 0.08, 1.0) == pytest.approx(0.08)
    assert thrust_curve(0.5, HOVER, 0.08, 1.0) == pytest.approx(HOVER)
    assert thrust_curve(1.0, HOVER, 0.08, 1.0) == pytest.approx(1.0)
    assert thrust_curve(0.25, HOVER, 0.08, 1.0) == pytest.approx((0.08 + HOVER) / 2)
    assert thrust_curve(0.75, HOVER, 0.08, 1.0) == pytest.approx((HOVER + 1.0) / 2)


def test_parameters_are_px4s_with_the_joystick_speeds():
    defs = {d.name: d for d in PARAMS}
    assert defs["MPC_VEL_MANUAL"].default == 1.0 and defs["MPC_VEL_MANUAL"].unit == "m/s"
    assert math.radians(defs["MPC_MAN_Y_MAX"].default) == pytest.approx(0.2, abs=1e-3)
    assert defs["MPC_MAN_Y_MAX"].unit == "deg/s"
    assert defs["MPC_MAN_TILT_MAX"].default == 35.0 and defs["MPC_HOLD_DZ"].default == 0.1
    assert defs["MPC_MANTHR_MIN"].default == 0.08
    assert all(defs[f"MC_ACRO_{a}_MAX"].default == 100.0 for a in "RPY")
    store = default_store()
    for name in ("MPC_Z_VEL_MAX_UP", "MPC_Z_VEL_MAX_DN", "MPC_THR_MAX"):
        assert store.get(name) == defs[name].default  # declared by the position controller, listed here


# -- POSCTL ---------------------------------------------------------------------------------------


def test_posctl_full_stick_flies_mpc_vel_manual_in_the_heading_frame():
    p = Pilot(PosCtlTask)
    p.input = sticks(pitch=1.0)
    sp = p.step(1.0)
    assert np.all(np.isnan(sp.pos_ned_m[:2]))
    assert sp.vel_ned_m_s[:2] == pytest.approx(heading(1.0, 0.0))
    assert sp.pos_ned_m[2] == pytest.approx(-5.0)  # throttle centred: altitude held
    p.input = sticks(roll=-1.0)
    sp = p.step(1.0)
    assert sp.vel_ned_m_s[:2] == pytest.approx(heading(0.0, -1.0))
    p.input = sticks(pitch=1.0, roll=1.0)  # a diagonal is no faster than MPC_VEL_MANUAL
    sp = p.step(1.0)
    assert math.hypot(*sp.vel_ned_m_s[:2]) == pytest.approx(1.0)
    p.params.set("MPC_VEL_MANUAL", 3.0)
    p.input = sticks(pitch=0.55)  # half the travel beyond the deadzone, then PX4's expo (MPC_XY_MAN_EXPO 0.6)
    sp = p.step(1.0)
    assert sp.vel_ned_m_s[:2] == pytest.approx(heading(3.0 * (0.4 * 0.5 + 0.6 * 0.5**3), 0.0))  # 0.825 m/s
    p.params.set("MPC_XY_MAN_EXPO", 0.0)  # linear: half the speed
    sp = p.step(2.0)
    assert sp.vel_ned_m_s[:2] == pytest.approx(heading(1.5, 0.0))


def test_posctl_velocity_changes_at_most_mpc_acc_hor_max():
    p = Pilot(PosCtlTask)
    p.input = sticks(pitch=1.0)
    sp = p.step()
    limit = p.params.get("MPC_ACC_HOR_MAX")
    assert math.hypot(*sp.vel_ned_m_s[:2]) == pytest.approx(limit * DT_S)
    assert math.hypot(*sp.acc_ned_m_s2[:2]) == pytest.approx(limit)


def test_posctl_centred_sticks_brake_then_hold_where_the_vehicle_stopped():
    p = Pilot(PosCtlTask)
    p.input = sticks(pitch=1.0)
    p.step(3.0)
    moved_to = p.pos.copy()
    assert np.linalg.norm(moved_to[:2]) > 2.0
    p.input = sticks(pitch=0.05, roll=-0.08)  # inside the deadzone: centred
    p.step(1.0)
    sp = p.step()
    held = sp.pos_ned_m.copy()
    assert np.all(np.isfinite(held))
    assert np.linalg.norm(held[:2] - moved_to[:2]) < 0.3  # braked within a short distance
    start = p.pos.copy()
    for _ in range(10):
        sp = p.step(1.0)
        assert sp.pos_ned_m == pytest.approx(held)
    assert np.linalg.norm(p.pos - start) <= 0.3


def test_posctl_throttle_commands_climb_and_descent_and_centred_holds_altitude():
    p = Pilot(PosCtlTask)
    p.input = sticks(throttle=1.0)
    sp = p.step(1.0)
    assert math.isnan(sp.pos_ned_m[2]) and sp.vel_ned_m_s[2] == pytest.approx(-p.params.get("MPC_Z_VEL_MAX_UP"))
    assert sp.pos_ned_m[:2] == pytest.approx([0.0, 0.0])  # horizontal sticks centred: position held
    p.input = sticks(throttle=0.0)
    sp = p.step(1.0)
    assert sp.vel_ned_m_s[2] == pytest.approx(p.params.get("MPC_Z_VEL_MAX_DN"))
    p.input = sticks(throttle=0.53)  # within the deadzone
    p.step(1.0)
    down = p.step().pos_ned_m[2]
    assert math.isfinite(down)
    for _ in range(5):
        assert p.step(1.0).pos_ned_m[2] == pytest.approx(down)


def test_posctl_yaw_stick_turns_at_mpc_man_y_max():
    p = Pilot(PosCtlTask)
    p.input = sticks(yaw=1.0)
    sp = p.step(1.0)
    assert sp.yaw_rad == pytest.approx(YAW + math.radians(p.params.get("MPC_MAN_Y_MAX")), abs=1e-6)
    p.input = sticks(yaw=-1.0)
    sp = p.step(2.0)
    assert sp.yaw_rad == pytest.approx(YAW - math.radians(p.params.get("MPC_MAN_Y_MAX")), abs=1e-6)
    p.input = sticks()
    assert p.step(1.0).yaw_rad == pytest.approx(sp.yaw_rad)


def test_posctl_without_sticks_holds_where_activated():
    p = Pilot(PosCtlTask, pos=(3.0, -2.0, -6.0))
    p.input = None
    p.pos = np.array([3.5, -2.0, -6.2])  # pushed away: it goes back
    sp = p.step(1.0)
    assert sp.pos_ned_m == pytest.approx([3.0, -2.0, -6.0]) and sp.yaw_rad == YAW
    p.task.on_ground = True
    assert p.step() is None


def test_posctl_on_the_ground_idles_until_the_throttle_is_raised():
    p = Pilot(PosCtlTask, pos=(1.0, 2.0, 0.0), on_ground=True)
    assert p.step(1.0) is None
    p.input = sticks(pitch=1.0, throttle=0.6)  # a little above centre: still idle, horizontal ignored
    assert p.step(1.0) is None
    p.input = sticks(pitch=1.0, throttle=0.9)
    sp = p.step()
    assert sp.vel_ned_m_s[2] < -0.5  # climbing
    assert sp.pos_ned_m[:2] == pytest.approx([1.0, 2.0])  # straight up
    p.task.on_ground = False
    sp = p.step(1.0)
    assert sp.vel_ned_m_s[0] > 0.5  # in the air the horizontal stick flies


def test_posctl_shift_moves_the_held_point():
    p = Pilot(PosCtlTask)
    p.step()
    p.task.shift(np.array([1.0, -1.0, 0.5]))
    p.pos = p.pos + np.array([1.0, -1.0, 0.5])
    assert p.step().pos_ned_m == pytest.approx([1.0, -1.0, -4.5])


# -- ALTCTL ---------------------------------------------------------------------------------------


def test_altctl_stick_commands_tilt_as_horizontal_acceleration():
    p = Pilot(AltCtlTask)
    p.input = sticks(pitch=1.0)
    sp = p.step()
    tilt = math.radians(p.params.get("MPC_MAN_TILT_MAX"))
    assert np.all(np.isnan(sp.pos_ned_m[:2])) and np.all(np.isnan(sp.vel_ned_m_s[:2]))
    assert sp.acc_ned_m_s2[:2] == pytest.approx(heading(GRAVITY_M_S2 * math.tan(tilt), 0.0))
    assert sp.pos_ned_m[2] == pytest.approx(-5.0)
    p.input = sticks(roll=0.55)  # half the travel beyond the deadzone: half the tilt, to the right
    sp = p.step()
    assert sp.acc_ned_m_s2[:2] == pytest.approx(heading(0.0, GRAVITY_M_S2 * math.tan(tilt / 2)))
    p.input = sticks(pitch=0.08)
    sp = p.step()
    assert sp.acc_ned_m_s2 == pytest.approx(np.zeros(3))
    assert np.all(np.isnan(sp.vel_ned_m_s[:2]))  # centred: level, drifting, no position hold


def test_altctl_throttle_and_yaw_as_posctl():
    p = Pilot(AltCtlTask)
    p.input = sticks(throttle=1.0, yaw=1.0)
    sp = p.step(1.0)
    assert sp.vel_ned_m_s[2] == pytest.approx(-p.params.get("MPC_Z_VEL_MAX_UP"))
    assert sp.yaw_rad == pytest.approx(YAW + math.radians(p.params.get("MPC_MAN_Y_MAX")), abs=1e-6)
    p.input = sticks()
    p.step(2.0)
    down = p.step().pos_ned_m[2]
    assert p.step(3.0).pos_ned_m[2] == pytest.approx(down)
    q = Pilot(AltCtlTask, pos=(0.0, 0.0, 0.0), on_ground=True)
    assert q.step(1.0) is None
    q.input = sticks(throttle=1.0)
    assert q.step().vel_ned_m_s[2] < 0.0


# -- STABILIZED and ACRO ---------------------------------------------------------------------------


def test_stabilized_sticks_set_roll_pitch_and_the_throttle_sets_thrust():
    p = Pilot(StabilizedTask, hover_thrust_frac=HOVER)
    tilt = math.radians(p.params.get("MPC_MAN_TILT_MAX"))
    p.input = sticks(pitch=1.0, throttle=0.5)
    sp = p.step()
    roll, pitch, yaw = quat.to_euler(sp.q_wxyz)
    assert (roll, pitch, yaw) == pytest.approx((0.0, -tilt, YAW), abs=1e-6)  # nose down to go forward
    assert sp.body_rate_frd_rad_s is None and sp.thrust_frac == pytest.approx(HOVER)
    p.input = sticks(roll=0.5, throttle=1.0)
    sp = p.step()
    roll, pitch, _ = quat.to_euler(sp.q_wxyz)
    assert (roll, pitch) == pytest.approx((tilt / 2, 0.0), abs=1e-6)
    assert sp.thrust_frac == pytest.approx(p.params.get("MPC_THR_MAX"))
    p.input = sticks(throttle=0.0)
    assert p.step().thrust_frac == pytest.approx(p.params.get("MPC_MANTHR_MIN"))
    p.input = sticks(pitch=1.0, roll=1.0)  # diagonal: the tilt is still at most MPC_MAN_TILT_MAX
    q = p.step().q_wxyz
    assert math.acos(min(1.0, quat.to_matrix(q)[2, 2])) == pytest.approx(tilt, abs=1e-6)


def test_stabilized_yaw_stick_integrates_the_heading():
    p = Pilot(StabilizedTask, hover_thrust_frac=HOVER)
    p.input = sticks(yaw=0.55)  # half the travel beyond MPC_HOLD_DZ, then MPC_YAW_EXPO 0.6 (PX4's mc_att_control)
    sp = p.step(2.0)
    rate = expo(0.5, 0.6) * math.radians(p.params.get("MPC_MAN_Y_MAX"))
    assert sp.yaw_rate_rad_s == pytest.approx(rate)
    assert quat.to_euler(sp.q_wxyz)[2] == pytest.approx(YAW + 2.0 * rate, abs=1e-6)


def test_stabilized_and_acro_idle_on_the_ground_with_throttle_down():
    for make in (StabilizedTask, AcroTask):
        p = Pilot(make, pos=(0.0, 0.0, 0.0), on_ground=True, hover_thrust_frac=HOVER)
        p.input = sticks(throttle=0.0, pitch=1.0)
        assert p.step() is None
        p.input = None
        assert p.step() is None
        p.input = sticks(throttle=0.7)
        sp = p.step()
        assert sp is not None and sp.thrust_frac > HOVER
        p.task.on_ground = False
        p.input = sticks(throttle=0.0)
        assert p.step().thrust_frac == pytest.approx(p.params.get("MPC_MANTHR_MIN"))  # in the air: never idle


def test_acro_sticks_command_body_rates():
    p = Pilot(AcroTask, hover_thrust_frac=HOVER)
    p.input = sticks(pitch=1.0, roll=-0.5, yaw=0.25, throttle=0.5)
    sp = p.step()
    r = p.params
    assert sp.q_wxyz is None
    assert sp.body_rate_frd_rad_s == pytest.approx(
        [
            -0.5 * math.radians(r.get("MC_ACRO_R_MAX")),
            -1.0 * math.radians(r.get("MC_ACRO_P_MAX")),  # forward stick: nose down
            0.25 * math.radians(r.get("MC_ACRO_Y_MAX")),
        ]
    )
    assert sp.thrust_frac == pytest.approx(HOVER)


# -- gcs fly: keys to sticks (the same code path from a terminal or a key script) ----------------


def test_gcs_fly_keys_deflect_sticks_that_return_to_centre_when_the_key_stops():
    from gcs.fly_cli import DECAY_S, HOLD_S, Sticks

    s = Sticks(deflection=1.0)
    s.press("w", 0.0)
    s.press("l", 0.0)
    s.press("i", 0.0)
    assert s.manual_control() == (1000, 0, 1000, 1000)
    s.relax(HOLD_S - 0.01, 0.04)  # auto-repeat gap: still held
    assert s.manual_control() == (1000, 0, 1000, 1000)
    s.press("w", HOLD_S)  # w keeps coming, the others stopped
    s.relax(HOLD_S + 0.1, DECAY_S / 2)
    assert s.manual_control() == (1000, 0, 750, 500)
    s.relax(HOLD_S + 0.2, DECAY_S)
    assert s.manual_control() == (1000, 0, 500, 0)
    s.press(" ", 1.0)  # space centres all at once
    assert s.manual_control() == (0, 0, 500, 0)
    half = Sticks(deflection=0.5)
    half.press("a", 0.0)
    half.press("k", 0.0)
    assert half.manual_control() == (0, -500, 250, 0)


def test_gcs_fly_key_script_holds_keys_for_their_seconds():
    from gcs.fly_cli import REPEAT_S, ScriptKeys, parse_script

    steps = parse_script("# comment\n0.5 -\nm\n0.2 w  # forward\n0.1 space\n")
    assert steps == [(0.5, ""), (0.0, "m"), (0.2, "w"), (0.1, " ")]
    with pytest.raises(ValueError, match="line 1"):
        parse_script("x w")
    with pytest.raises(ValueError, match="unknown key"):
        parse_script("1 z")
    now = [0.0]
    keys = ScriptKeys(steps, clock=lambda: now[0])
    seen = []
    while (k := keys.read(0.0)) is not None:
        if k:
            seen.append((round(now[0], 3), k))
        now[0] += 0.01
    assert seen[0] == (0.5, "m")
    presses = [t for t, k in seen if k == "w"]
    assert presses[0] == pytest.approx(0.51) and len(presses) == pytest.approx(0.2 / REPEAT_S, abs=1)
    assert seen[-1][1] == " " and now[0] == pytest.approx(0.81, abs=0.02)
