"""Parameters -> controller gains: the one place that knows parameter names, units and conversions.

The controllers in :mod:`autopilot.control` take frozen gain records
(:class:`RateGains`, :class:`AttitudeGains`, :class:`PositionGains`,
:class:`GyroFilterSettings`) and never read parameters.  This module declares the
parameters (PX4's names), builds those records from a :class:`ParameterStore`
(degrees -> radians, fractions of maximum thrust, ...), and with
:class:`GainsFromParams` subscribes to parameter changes: an accepted change of one
of a controller's parameters calls that controller's ``set_gains`` with a new record
at once, so the controller flies with it from its next update (live tuning).
This is the only path by which a parameter reaches a controller.
"""

from __future__ import annotations

import math
from collections.abc import Callable

from autopilot.control.attitude_control import AttitudeControl, AttitudeGains
from autopilot.control.disturbance_observer import DisturbanceFeedForward
from autopilot.control.gyro_filter import GyroFilter, GyroFilterSettings
from autopilot.control.position_control import PositionControl, PositionGains
from autopilot.control.rate_control import RateControl, RateGains
from autopilot.parameters import ParamDef, ParameterStore, ParamType, param

Getter = Callable[[str], float]  # a parameter's current value by name

RATE_PARAMS: tuple[ParamDef, ...] = (
    param("MC_ROLLRATE_P", 12.0, 0.0, 150.0, "1/s", "Roll rate P: angular acceleration (rad/s^2) per rad/s of error"),
    param("MC_ROLLRATE_I", 6.0, 0.0, 1000.0, "1/s^2", "Roll rate integral gain"),
    param("MC_ROLLRATE_D", 0.15, 0.0, 2.0, "-", "Roll rate derivative gain"),
    param("MC_PITCHRATE_P", 12.0, 0.0, 150.0, "1/s", "Pitch rate P: angular acceleration (rad/s^2) per rad/s of error"),
    param("MC_PITCHRATE_I", 6.0, 0.0, 1000.0, "1/s^2", "Pitch rate integral gain"),
    param("MC_PITCHRATE_D", 0.15, 0.0, 2.0, "-", "Pitch rate derivative gain"),
    param("MC_YAWRATE_P", 6.0, 0.0, 60.0, "1/s", "Yaw rate P: angular acceleration (rad/s^2) per rad/s of error"),
    param("MC_YAWRATE_I", 2.0, 0.0, 1000.0, "1/s^2", "Yaw rate integral gain"),
    param("MC_YAWRATE_D", 0.0, 0.0, 2.0, "-", "Yaw rate derivative gain"),
    param("MC_RR_INT_LIM", 5.0, 0.0, 50.0, "rad/s^2", "Roll rate integrator clamp"),
    param("MC_PR_INT_LIM", 5.0, 0.0, 50.0, "rad/s^2", "Pitch rate integrator clamp"),
    param("MC_YR_INT_LIM", 3.0, 0.0, 50.0, "rad/s^2", "Yaw rate integrator clamp"),
    param("MC_RATE_D_LIM", 100.0, 0.0, 1000.0, "rad/s^2", "Clamp of the rate derivative term ([Q 3.4])"),
)

ATTITUDE_PARAMS: tuple[ParamDef, ...] = (
    param("MC_ROLL_P", 6.5, 0.0, 12.0, "1/s", "Roll angle proportional gain"),
    param("MC_PITCH_P", 6.5, 0.0, 12.0, "1/s", "Pitch angle proportional gain"),
    param("MC_YAW_P", 2.8, 0.0, 12.0, "1/s", "Yaw angle proportional gain"),
    param(
        "MC_YAW_WEIGHT",
        0.4,
        0.0,
        1.0,
        "norm",
        "Yaw weight: the fraction of a heading error corrected beside the tilt (yaw after roll and pitch)",
    ),
    param("MC_ROLLRATE_MAX", 220.0, 0.0, 1800.0, "deg/s", "Maximum roll rate"),
    param("MC_PITCHRATE_MAX", 220.0, 0.0, 1800.0, "deg/s", "Maximum pitch rate"),
    param("MC_YAWRATE_MAX", 200.0, 0.0, 1800.0, "deg/s", "Maximum yaw rate"),
)

GYRO_FILTER_PARAMS: tuple[ParamDef, ...] = (
    param(
        "IMU_GYRO_CUTOFF",
        30.0,
        0.0,
        1000.0,
        "Hz",
        "Low-pass cutoff of the body rates the rate controller uses (0: no filter)",
    ),
)

POSITION_PARAMS: tuple[ParamDef, ...] = (
    param("MPC_XY_P", 0.95, 0.0, 2.0, "1/s", "Horizontal position proportional gain"),
    param("MPC_Z_P", 1.0, 0.0, 2.0, "1/s", "Vertical position proportional gain"),
    param(
        "MPC_XY_VEL_P_ACC",
        2.2,
        0.0,
        10.0,
        "1/s",
        "Horizontal velocity proportional gain (acceleration per velocity error)",
    ),
    param("MPC_XY_VEL_I_ACC", 0.8, 0.0, 10.0, "1/s^2", "Horizontal velocity integral gain"),
    param("MPC_XY_VEL_D_ACC", 0.2, 0.0, 2.0, "-", "Horizontal velocity derivative gain"),
    param("MPC_Z_VEL_P_ACC", 4.0, 0.0, 15.0, "1/s", "Vertical velocity proportional gain"),
    param("MPC_Z_VEL_I_ACC", 2.0, 0.0, 10.0, "1/s^2", "Vertical velocity integral gain"),
    param("MPC_Z_VEL_D_ACC", 0.0, 0.0, 2.0, "-", "Vertical velocity derivative gain"),
    param("MPC_XY_VEL_MAX", 5.0, 0.0, 20.0, "m/s", "Maximum horizontal velocity"),
    param("MPC_Z_VEL_MAX_UP", 3.0, 0.5, 8.0, "m/s", "Maximum ascent velocity"),
    param("MPC_Z_VEL_MAX_DN", 1.5, 0.5, 4.0, "m/s", "Maximum descent velocity"),
    param("MPC_TILTMAX_AIR", 35.0, 20.0, 89.0, "deg", "Maximum tilt in air"),
    param("MPC_THR_MIN", 0.12, 0.05, 0.5, "norm", "Minimum collective thrust in flight (fraction of maximum)"),
    param("MPC_THR_MAX", 1.0, 0.5, 1.0, "norm", "Maximum collective thrust (fraction of maximum)"),
    param("MPC_XY_INT_LIM", 3.0, 0.0, 10.0, "m/s^2", "Horizontal velocity integrator clamp ([Q 3.4])"),
    param("MPC_Z_INT_LIM", 4.0, 0.0, 10.0, "m/s^2", "Vertical velocity integrator clamp ([Q 3.4])"),
    param(
        "MPC_JERK_AUTO",
        10.0,
        1.0,
        80.0,
        "m/s^3",
        "Jerk limit of automatic moves: how fast their acceleration feed-forward may change",
    ),
    param("MPC_ACC_D_LIM", 10.0, 0.0, 100.0, "m/s^2", "Clamp of the velocity derivative term ([Q 3.4])"),
    param(
        "MPC_VELD_LP",
        5.0,
        0.0,
        10.0,
        "Hz",
        "Low-pass cut-off of the velocity derivative (0 = unfiltered): GPS corrections step the velocity estimate",
    ),
)

DISTURBANCE_PARAMS: tuple[ParamDef, ...] = (
    param(
        "MPC_DOB_EN", 1, 0, 1, "-", "Disturbance observer: feed the estimated external push forward", ParamType.INT32
    ),
    param("MPC_DOB_LP", 2.0, 0.1, 20.0, "Hz", "Low-pass cut-off of the disturbance observer"),
)

# The parameters of the controllers (listed in autopilot/param_catalogue.py).
PARAMS: tuple[ParamDef, ...] = RATE_PARAMS + ATTITUDE_PARAMS + GYRO_FILTER_PARAMS + POSITION_PARAMS + DISTURBANCE_PARAMS

_AXES = ("ROLL", "PITCH", "YAW")


def rate_gains(g: Getter) -> RateGains:
    """The rate controller's gains from MC_*RATE_P/I/D, MC_*R_INT_LIM and MC_RATE_D_LIM."""
    p0, p1, p2 = (g(f"MC_{a}RATE_P") for a in _AXES)
    i0, i1, i2 = (g(f"MC_{a}RATE_I") for a in _AXES)
    d0, d1, d2 = (g(f"MC_{a}RATE_D") for a in _AXES)
    return RateGains(
        p_per_s=(p0, p1, p2),
        i_per_s2=(i0, i1, i2),
        d_unitless=(d0, d1, d2),
        int_lim_rad_s2=(g("MC_RR_INT_LIM"), g("MC_PR_INT_LIM"), g("MC_YR_INT_LIM")),
        d_lim_rad_s2=g("MC_RATE_D_LIM"),
    )


def attitude_gains(g: Getter) -> AttitudeGains:
    """The attitude controller's gains from MC_ROLL_P ..., MC_*RATE_MAX (deg/s -> rad/s) and MC_YAW_WEIGHT."""
    r0, r1, r2 = (math.radians(g(f"MC_{a}RATE_MAX")) for a in _AXES)
    p = (g("MC_ROLL_P"), g("MC_PITCH_P"), g("MC_YAW_P"))
    return AttitudeGains(p_per_s=p, rate_max_rad_s=(r0, r1, r2), yaw_weight=g("MC_YAW_WEIGHT"))


def gyro_filter_settings(g: Getter) -> GyroFilterSettings:
    """The rate controller's gyro low-pass from IMU_GYRO_CUTOFF (at the 250 Hz control rate)."""
    return GyroFilterSettings(cutoff_hz=g("IMU_GYRO_CUTOFF"))


def position_gains(g: Getter) -> PositionGains:
    """The position controller's gains and limits from the MPC_* parameters (MPC_TILTMAX_AIR deg -> rad)."""
    xy, z = g("MPC_XY_P"), g("MPC_Z_P")
    return PositionGains(
        pos_p_per_s=(xy, xy, z),
        vel_p_per_s=_xyz(g, "MPC_XY_VEL_P_ACC", "MPC_Z_VEL_P_ACC"),
        vel_i_per_s2=_xyz(g, "MPC_XY_VEL_I_ACC", "MPC_Z_VEL_I_ACC"),
        vel_d_unitless=_xyz(g, "MPC_XY_VEL_D_ACC", "MPC_Z_VEL_D_ACC"),
        vel_int_lim_m_s2=_xyz(g, "MPC_XY_INT_LIM", "MPC_Z_INT_LIM"),
        vel_d_lim_m_s2=g("MPC_ACC_D_LIM"),
        vel_d_lowpass_hz=g("MPC_VELD_LP"),
        vel_xy_max_m_s=g("MPC_XY_VEL_MAX"),
        vel_up_max_m_s=g("MPC_Z_VEL_MAX_UP"),
        vel_down_max_m_s=g("MPC_Z_VEL_MAX_DN"),
        tilt_max_rad=math.radians(g("MPC_TILTMAX_AIR")),
        thrust_min_frac=g("MPC_THR_MIN"),
        thrust_max_frac=g("MPC_THR_MAX"),
        jerk_max_m_s3=g("MPC_JERK_AUTO"),
    )


def _xyz(g: Getter, xy_name: str, z_name: str) -> tuple[float, float, float]:
    xy = g(xy_name)
    return (xy, xy, g(z_name))


class GainsFromParams:
    """Builds the controllers from a parameter store and keeps their gains in step with it.

    One subscription to the store; each controller made here is bound to the names of
    its own parameters and gets a new gain record when one of them changes."""

    def __init__(self, params: ParameterStore) -> None:
        self.params = params
        self._bindings: list[tuple[frozenset[str], Callable[[], None]]] = []
        params.subscribe(self._on_change)

    def _on_change(self, name: str, value: float) -> None:
        for names, refresh in self._bindings:
            if name in names:
                refresh()

    def _bind(self, defs: tuple[ParamDef, ...], refresh: Callable[[], None]) -> None:
        self._bindings.append((frozenset(d.name for d in defs), refresh))

    def rate_control(self) -> RateControl:
        get = self.params.get
        rc = RateControl(rate_gains(get))
        self._bind(RATE_PARAMS, lambda: rc.set_gains(rate_gains(get)))
        return rc

    def attitude_control(self) -> AttitudeControl:
        get = self.params.get
        ac = AttitudeControl(attitude_gains(get))
        self._bind(ATTITUDE_PARAMS, lambda: ac.set_gains(attitude_gains(get)))
        return ac

    def gyro_filter(self) -> GyroFilter:
        get = self.params.get
        gf = GyroFilter(gyro_filter_settings(get))
        self._bind(GYRO_FILTER_PARAMS, lambda: gf.set_gains(gyro_filter_settings(get)))
        return gf

    def position_control(self, mass_kg: float, max_total_thrust_n: float) -> PositionControl:
        """Position control for a vehicle of this mass (kg) and total rotor thrust (N)."""
        get = self.params.get
        pc = PositionControl(position_gains(get), mass_kg, max_total_thrust_n)
        self._bind(POSITION_PARAMS, lambda: pc.set_gains(position_gains(get)))
        return pc

    def disturbance_feed_forward(self, mass_kg: float, motor_tau_s: float) -> DisturbanceFeedForward:
        """The disturbance observer fed forward (MPC_DOB_EN, MPC_DOB_LP) for a vehicle of this mass (kg) and
        motor time constant (s)."""
        get = self.params.get
        ff = DisturbanceFeedForward(mass_kg, motor_tau_s, bool(get("MPC_DOB_EN")), get("MPC_DOB_LP"))
        self._bind(DISTURBANCE_PARAMS, lambda: ff.set_settings(bool(get("MPC_DOB_EN")), get("MPC_DOB_LP")))
        return ff


# One controller, tuned live from a store (tests and tools that need a single controller).
def rate_control_from_params(params: ParameterStore) -> RateControl:
    return GainsFromParams(params).rate_control()


def attitude_control_from_params(params: ParameterStore) -> AttitudeControl:
    return GainsFromParams(params).attitude_control()


def gyro_filter_from_params(params: ParameterStore) -> GyroFilter:
    return GainsFromParams(params).gyro_filter()


def position_control_from_params(params: ParameterStore, mass_kg: float, max_total_thrust_n: float) -> PositionControl:
    return GainsFromParams(params).position_control(mass_kg, max_total_thrust_n)
