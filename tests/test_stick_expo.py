"""Stick expo as PX4 shapes its sticks (autopilot/navigation/stick_expo.py), on the stick modes with nothing
running: PX4's ``math::expo`` and ``math::superexpo``, their parameters, and where each applies (POSCTL's
horizontal sticks, the climb rate and the yaw rate of POSCTL and ALTCTL, ACRO's rates).  The pilot and its
point-mass vehicle are tests/test_manual_modes.py's."""

from __future__ import annotations

import math

import pytest
from test_manual_modes import HOVER, YAW, Pilot, sticks

from autopilot.navigation.manual_modes import PARAMS, AcroTask, AltCtlTask, PosCtlTask
from autopilot.navigation.stick_expo import expo, superexpo
from autopilot.param_catalogue import default_store


def test_expo_and_superexpo_are_px4s_curves():
    assert expo(0.5, 0.6) == pytest.approx(0.4 * 0.5 + 0.6 * 0.125)  # (1 - e) x + e x^3
    assert expo(0.5, 0.0) == 0.5 and expo(0.5, 1.0) == 0.125  # linear, cubic
    assert expo(1.0, 0.6) == 1.0 and expo(-1.0, 0.6) == -1.0 and expo(-0.3, 0.6) == -expo(0.3, 0.6)
    assert expo(2.0, 0.6) == 1.0 and expo(0.5, 1.7) == expo(0.5, 1.0)  # stick and factor clipped as PX4 clips
    # superexpo: expo * (1 - g) / (1 - |x| g); full stick stays full, g clipped to 0.99
    assert superexpo(0.5, 0.69, 0.7) == pytest.approx(expo(0.5, 0.69) * 0.3 / (1 - 0.5 * 0.7))
    assert superexpo(1.0, 0.69, 0.7) == pytest.approx(1.0) and superexpo(0.5, 0.3, 0.0) == expo(0.5, 0.3)
    assert superexpo(-0.5, 0.2, 0.5) == -superexpo(0.5, 0.2, 0.5) and superexpo(1.0, 0.0, 1.0) == pytest.approx(1.0)


def test_expo_parameters_are_px4s():
    defs = {d.name: d for d in PARAMS}
    for name in ("MPC_XY_MAN_EXPO", "MPC_Z_MAN_EXPO", "MPC_YAW_EXPO"):
        assert (defs[name].default, defs[name].min, defs[name].max) == (0.6, 0.0, 1.0)
    for name in ("MC_ACRO_EXPO", "MC_ACRO_EXPO_Y"):
        assert (defs[name].default, defs[name].min, defs[name].max) == (0.0, 0.0, 1.0)
    for name in ("MC_ACRO_SUPEXPO", "MC_ACRO_SUPEXPOY"):
        assert (defs[name].default, defs[name].min, defs[name].max) == (0.0, 0.0, 0.95)
    assert set(defs) <= set(default_store().names())


def test_posctl_and_altctl_climb_rate_and_yaw_rate_follow_the_expo():
    for make in (PosCtlTask, AltCtlTask):
        p = Pilot(make)
        p.input = sticks(throttle=0.775, yaw=-0.55)  # both half the travel beyond the deadzone
        sp = p.step(1.0)
        up, turn = expo(0.5, 0.6), expo(-0.5, 0.6)  # MPC_Z_MAN_EXPO, MPC_YAW_EXPO: 0.275 of full
        assert sp.vel_ned_m_s[2] == pytest.approx(-up * p.params.get("MPC_Z_VEL_MAX_UP"))
        assert sp.yaw_rad == pytest.approx(YAW + turn * math.radians(p.params.get("MPC_MAN_Y_MAX")), abs=1e-6)
        p.params.set("MPC_Z_MAN_EXPO", 1.0)  # cubic
        assert p.step(0.1).vel_ned_m_s[2] == pytest.approx(-0.125 * p.params.get("MPC_Z_VEL_MAX_UP"))


def test_takeoff_stick_is_read_before_the_expo():
    p = Pilot(PosCtlTask, pos=(0.0, 0.0, 0.0), on_ground=True)
    p.input = sticks(throttle=0.8)  # (0.6 - 0.1) / 0.9 = 0.56 up: past TAKEOFF_STICK, 0.33 after the expo
    sp = p.step()
    assert sp is not None and sp.vel_ned_m_s[2] == pytest.approx(
        -expo(0.5 / 0.9, 0.6) * p.params.get("MPC_Z_VEL_MAX_UP")
    )


def test_acro_expo_and_superexpo_shape_the_rates():
    p = Pilot(AcroTask, hover_thrust_frac=HOVER)
    for name, value in (("MC_ACRO_EXPO", 0.69), ("MC_ACRO_SUPEXPO", 0.7), ("MC_ACRO_EXPO_Y", 0.5)):
        p.params.set(name, value)
    p.input = sticks(pitch=1.0, roll=-0.5, yaw=0.25, throttle=0.5)
    rates = p.step().body_rate_frd_rad_s
    r = p.params
    assert rates == pytest.approx([
        superexpo(-0.5, 0.69, 0.7) * math.radians(r.get("MC_ACRO_R_MAX")),
        -math.radians(r.get("MC_ACRO_P_MAX")),  # full stick: full rate whatever the curve
        expo(0.25, 0.5) * math.radians(r.get("MC_ACRO_Y_MAX")),  # MC_ACRO_SUPEXPOY 0: plain expo
    ])  # fmt: skip
    assert abs(rates[0]) < 0.5 * 0.5 * math.radians(r.get("MC_ACRO_R_MAX"))  # half stick: well under half rate
