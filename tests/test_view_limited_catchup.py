"""The view-limited catch-up (autopilot/navigation/view_limited_catchup.py, autopilot/control/thrust_cone.py): the
chase's horizontal thrust is shortened just enough that the marker stays inside the camera's view; the gimbal's
reach is the gimbal device's unless PLD_CAM_REACH sets one."""

from __future__ import annotations

import math

import numpy as np
import pytest

from autopilot.control.thrust_cone import AxisCone, horizontal_share
from autopilot.navigation.view_limited_catchup import ViewLimits, view_cone
from autopilot.param_catalogue import default_store
from autopilot.parameters import ParamError

MASS_G_N = 1.4 * 9.81  # the quad_x's weight, N
FIXED = ViewLimits(reach_rad=0.0)  # the seed's body-fixed downward camera, 73.7 deg narrow field, 8 deg margin
GIMBAL = ViewLimits(reach_rad=math.radians(45.0))  # the 3-axis gimbal: 45 deg of reach from the body's down axis
FIXED_HALF_DEG = 73.7 / 2.0 - 8.0  # the cone's half angle without a gimbal: half the narrow field less the margin


def thrust_for(tilt_deg: float, azimuth_deg: float) -> tuple[float, float, float]:
    """The hover thrust (N, NED) tilted by ``tilt_deg`` toward ``azimuth_deg`` (from north): the vehicle accelerates
    that way."""
    t, a = math.radians(tilt_deg), math.radians(azimuth_deg)
    h = MASS_G_N * math.tan(t)
    return (h * math.cos(a), h * math.sin(a), -MASS_G_N)


def down_axis_angle_deg(thrust, rel) -> float:
    """The angle between the vehicle's down axis (minus the thrust direction) and the line of sight (deg)."""
    down = -np.asarray(thrust, float) / np.linalg.norm(thrust)
    los = np.asarray(rel, float) / np.linalg.norm(rel)
    return math.degrees(math.acos(float(np.clip(down @ los, -1.0, 1.0))))


@pytest.mark.parametrize("limits", [FIXED, GIMBAL], ids=["fixed", "gimbal"])
@pytest.mark.parametrize("height_m", [0.5, 1.0, 2.8])
@pytest.mark.parametrize("offset_m", [0.0, 0.4, 1.0, 1.5])
@pytest.mark.parametrize("azimuth_deg", [0.0, 90.0, 180.0, 250.0])
def test_the_marker_stays_in_view_whatever_the_chase_asks(limits, height_m, offset_m, azimuth_deg):
    """The deck `offset_m` north of the point below the vehicle, `height_m` down; the chase asks for 35 deg of tilt
    (MPC_TILTMAX_AIR) toward `azimuth_deg`: after the cone, the line of sight is within the camera's half field (plus
    the gimbal's reach) less the margin, or, if it was already outside that straight down, nothing was cut."""
    rel = (offset_m, 0.0, height_m)
    cone = view_cone(np.array(rel), limits)
    assert cone is not None
    wanted = thrust_for(35.0, azimuth_deg)
    k = horizontal_share(wanted, cone)
    flown = (wanted[0] * k, wanted[1] * k, wanted[2])
    allowed_deg = math.degrees(limits.half_angle_rad)
    if down_axis_angle_deg((0.0, 0.0, -1.0), rel) <= allowed_deg:
        assert down_axis_angle_deg(flown, rel) <= allowed_deg + 0.01
        if down_axis_angle_deg(wanted, rel) <= allowed_deg:
            assert k == 1.0  # no catch-up is given away when the view allows it
        else:
            assert down_axis_angle_deg(flown, rel) == pytest.approx(allowed_deg, abs=0.01)  # as hard as the view allows
    else:
        assert k == 1.0


def test_a_fixed_camera_chasing_a_deck_ahead_tilts_less_than_the_tilt_cap():
    """1 m above, the deck 0.4 m ahead (22 deg off straight down): a fixed 73.7 deg camera with an 8 deg margin
    allows 36.85 - 8 - 21.8 = 7 deg of tilt toward it; the gimbal's 45 deg reach all of MPC_TILTMAX_AIR's 35."""
    rel = np.array([0.4, 0.0, 1.0])
    wanted = thrust_for(35.0, 0.0)
    fixed = horizontal_share(wanted, view_cone(rel, FIXED))
    tilt_deg = math.degrees(math.atan(fixed * math.tan(math.radians(35.0))))
    assert tilt_deg == pytest.approx(36.85 - 8.0 - math.degrees(math.atan(0.4)), abs=0.1)
    assert horizontal_share(wanted, view_cone(rel, GIMBAL)) == 1.0
    # braking (tilting away from the deck swings the camera toward it): never cut
    assert horizontal_share(thrust_for(35.0, 180.0), view_cone(rel, FIXED)) == 1.0


def test_no_cone_when_off_or_without_a_target_below():
    assert view_cone(np.array([0.3, 0.0, 1.0]), ViewLimits(enabled=False)) is None
    assert view_cone(None, GIMBAL) is None
    assert view_cone(np.array([0.3, 0.0, -1.0]), GIMBAL) is None  # above the vehicle
    assert view_cone(np.array([math.nan, 0.0, 1.0]), GIMBAL) is None
    assert horizontal_share((1.0, 0.0, 5.0), AxisCone((0.0, 0.0, 1.0), 0.1)) == 1.0  # thrust downward: nothing


def half_angle_deg(limits: ViewLimits) -> float:
    """The cone's half angle (deg) for a deck 0.4 m ahead, 1 m below."""
    cone = view_cone(np.array([0.4, 0.0, 1.0]), limits)
    assert cone is not None
    return math.degrees(cone.half_angle_rad)


def test_by_default_the_reach_is_the_gimbal_devices_and_zero_without_one():
    """PLD_CAM_REACH -1 (the default): the reach the gimbal manager publishes (rad from the body's down axis), held
    to 0..90 deg; without a device (None: a fixed camera, a lost device, the manager off) the fixed camera's cone."""
    store = default_store()
    auto = ViewLimits.from_store(store)
    assert store.get("PLD_CAM_REACH") == -1.0 and auto.reach_rad is None
    assert half_angle_deg(auto) == pytest.approx(FIXED_HALF_DEG)  # no device has reported
    gimbal = auto.with_device(math.radians(45.0))
    assert half_angle_deg(gimbal) == pytest.approx(FIXED_HALF_DEG + 45.0)
    assert half_angle_deg(gimbal.with_device(math.radians(30.0))) == pytest.approx(FIXED_HALF_DEG + 30.0)
    assert half_angle_deg(gimbal.with_device(None)) == pytest.approx(FIXED_HALF_DEG)  # the device lost
    assert auto.with_device(math.radians(120.0)).reach_in_use_rad == pytest.approx(math.pi / 2)
    assert auto.with_device(-0.1).reach_in_use_rad == 0.0 and auto.with_device(math.nan).reach_in_use_rad == 0.0
    assert gimbal.with_device(gimbal.device_reach_rad) is gimbal  # unchanged: the same limits


@pytest.mark.parametrize("reach_deg", [0.0, 20.0, 90.0])
def test_a_reach_the_user_sets_overrides_the_devices(reach_deg):
    store = default_store()
    store.set("PLD_CAM_REACH", reach_deg)
    user = ViewLimits.from_store(store)
    for device in (None, math.radians(45.0)):
        assert half_angle_deg(user.with_device(device)) == pytest.approx(FIXED_HALF_DEG + reach_deg)


@pytest.mark.parametrize("value", [-1.5, 90.5])
def test_the_reach_keeps_its_range_check(value):
    store = default_store()
    with pytest.raises(ParamError, match="PLD_CAM_REACH"):
        store.set("PLD_CAM_REACH", value)


@pytest.mark.parametrize("slew, want", [(None, 20.0), (35.0, 35.0), (0.0, math.inf)])
def test_the_landings_setpoints_carry_pld_acc_slew_from_tracking_on(slew, want):
    """PLD_ACC_SLEW (default 20 m/s^3, 0: no limit) goes with every setpoint of the chase and the docking, and not
    with the preparation's hover (a deck seen later: the vehicle there is still)."""
    from autopilot.navigation.precland import LandingTargetInput, PrecLandPhase, PrecLandTask
    from autopilot.topics import VehicleEstimate

    store = default_store()
    if slew is not None:
        store.set("PLD_ACC_SLEW", slew)
    pos, t = np.array([0.0, 0.0, -2.8]), 1_000_000

    def est(t_us: int) -> VehicleEstimate:
        return VehicleEstimate(
            t_us, np.array([1.0, 0.0, 0.0, 0.0]), np.zeros(3), np.zeros(3), pos.copy(), np.zeros(3), True, True,
            47.0, 8.0, 400.0,
        )  # fmt: skip

    task = PrecLandTask(0.0, store)
    task.activate(est(t), t)
    assert task.update(est(t + 20_000), t + 20_000).acc_slew_m_s3 == math.inf  # preparation: no target yet
    seen = {}
    for k in range(2, 600):
        t_us = t + 20_000 * k
        sp = task.update(est(t_us), t_us, LandingTargetInput(t_us, np.array([0.5, 0.0, 2.8]), np.zeros(3)))
        seen.setdefault(task.phase, sp.acc_slew_m_s3)
    assert {PrecLandPhase.TRACKING, PrecLandPhase.APPROACHING} <= seen.keys()
    assert all(v == want for p, v in seen.items() if p is not PrecLandPhase.DONE)
