"""AUTO.PRECLAND in the commander: how it is entered and refused, its reports, the motor cut on the
deck, and what a required and an opportunistic landing do without a target (issue 13, item 6).

The commander of ``test_commander.Bench`` (a point that goes where the setpoint says, the ground at
down = 0); commands go through the MAVLink command table as a ground station's would.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from pymavlink.dialects.v20 import common as mavlink

from autopilot.navigation.precland import LandingTargetInput, PrecLandMode
from mavsim_core.px4_modes import Mode

from test_commander import ACCEPTED, DENIED, Bench

PRECLAND = (mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 4, 9)  # DO_SET_MODE: AUTO, sub-mode 9


def test_precland_is_refused_on_the_ground_and_for_an_unknown_land_mode():
    b = Bench()
    b.run(0.5)
    assert b.command(mavlink.MAV_CMD_NAV_LAND, 0, 2) == DENIED
    assert b.texts()[-1] == "Land denied: vehicle not armed"
    assert b.command(mavlink.MAV_CMD_DO_SET_MODE, *PRECLAND) == DENIED
    assert b.texts()[-1] == "Precision landing denied: vehicle not flying"
    b.fly_up()
    assert b.command(mavlink.MAV_CMD_NAV_LAND, 0, 3) == DENIED
    assert b.texts()[-1] == "Land denied: param2 (precision land mode) 3 is not one of 0, 1, 2"
    assert b.cmd.status.mode is Mode.AUTO_LOITER


def test_nav_land_param2_and_do_set_mode_enter_precland_as_px4():
    b = Bench()
    b.fly_up()
    assert b.command(mavlink.MAV_CMD_NAV_LAND, 0, 1) == ACCEPTED
    assert b.cmd.status.mode is Mode.AUTO_PRECLAND and b.cmd.precland_mode is PrecLandMode.OPPORTUNISTIC
    assert b.cmd.status.mode.value == (4, 9)  # HEARTBEAT custom_mode: AUTO, sub-mode 9
    b.run(0.02)  # the phase is reported at the next update
    assert any(t.startswith("Precland: preparation") for t in b.texts())
    assert b.set_mode(Mode.AUTO_LOITER) == ACCEPTED
    assert b.command(mavlink.MAV_CMD_DO_SET_MODE, *PRECLAND) == ACCEPTED
    assert b.cmd.status.mode is Mode.AUTO_PRECLAND and b.cmd.precland_mode is PrecLandMode.REQUIRED


def _fly_with_target(b: Bench, target_ned: np.ndarray | None, seconds: float) -> None:
    for _ in range(round(seconds / 0.02)):
        if target_ned is not None:
            b.cmd.landing_target = LandingTargetInput(b.t_us, target_ned - b.pos, np.zeros(3), True)
        b.run(0.02)


def test_a_seen_target_is_landed_on_and_the_motors_cut_there():
    b = Bench()
    b.fly_up()
    pad = np.array([0.6, -0.4, -0.3])  # a deck 0.3 m up, 0.7 m away
    assert b.command(mavlink.MAV_CMD_NAV_LAND, 0, 2) == ACCEPTED
    _fly_with_target(b, pad, 20.0)
    phases = [t.split(" (")[0] for t in b.texts() if t.startswith("Precland:")]
    assert phases == [
        "Precland: preparation",
        "Precland: tracking",
        "Precland: approaching",
        "Precland: docking",
        "Precland: done",
    ]
    assert "Disarmed (docked on the landing target)" in b.texts()
    assert not b.cmd.status.armed
    assert np.linalg.norm(b.pos[:2] - pad[:2]) < 0.05  # over the marker
    assert pad[2] - b.pos[2] < 0.06  # the feet (the point itself here) at the deck's docking point


def test_without_a_target_required_holds_and_reports_opportunistic_lands():
    for mode, lands in ((2, False), (1, True)):
        b = Bench()
        for name, value in (("PLD_SRCH_TOUT", 1.0), ("PLD_MAX_SRCH", 1), ("PLD_SRCH_ALT", 3.0)):
            b.params.set(name, value)
        b.fly_up()
        assert b.command(mavlink.MAV_CMD_NAV_LAND, 0, mode) == ACCEPTED
        _fly_with_target(b, None, 30.0)
        texts = b.texts()
        assert any(t.startswith("Precland: search (target lost, search 1 of 1)") for t in texts)
        assert any(t.startswith("Precland: fallback") for t in texts)
        failed = "Precision landing failed: no landing target, holding position" in texts
        assert failed is not lands
        assert (not b.cmd.status.armed) is lands  # opportunistic: landed and disarmed; required: holding


def test_the_chase_cone_follows_the_gimbal_reach_the_gimbal_manager_publishes():
    """PLD_CAM_REACH -1: the commander hands the reach in its inputs (ExternalInputs.on_gimbal_reach, the gimbal
    manager's) to the landing at every update; without a device the cone is the body-fixed camera's."""
    b = Bench()
    b.fly_up()
    pad = np.array([3.0, 0.0, 0.0])
    assert b.command(mavlink.MAV_CMD_NAV_LAND, 0, 2) == ACCEPTED
    fixed_rad = math.radians(73.7 / 2.0 - 8.0)  # half the narrow field less the margin

    def half_angle_rad() -> float:
        _fly_with_target(b, pad, 0.04)
        assert b.cmd.setpoint.axis_cone is not None
        return b.cmd.setpoint.axis_cone.half_angle_rad

    _fly_with_target(b, pad, 0.5)
    assert b.cmd.task.phase.value == "tracking"
    assert half_angle_rad() == pytest.approx(fixed_rad)  # no gimbal device reports
    b.cmd.inputs.on_gimbal_reach(math.radians(45.0))
    assert half_angle_rad() == pytest.approx(fixed_rad + math.radians(45.0))
    b.cmd.inputs.on_gimbal_reach(None)  # the device lost
    assert half_angle_rad() == pytest.approx(fixed_rad)
    b.params.set("PLD_CAM_REACH", 10.0)  # read when the landing starts: a new landing takes it
    assert b.set_mode(Mode.AUTO_LOITER) == ACCEPTED
    assert b.command(mavlink.MAV_CMD_NAV_LAND, 0, 2) == ACCEPTED
    b.cmd.inputs.on_gimbal_reach(math.radians(45.0))
    _fly_with_target(b, pad, 0.5)
    assert half_angle_rad() == pytest.approx(fixed_rad + math.radians(10.0))  # the user's reach wins
