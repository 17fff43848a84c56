"""Typed messages between the parts of the flight controller (PX4's uORB topics).

Small frozen dataclasses with a timestamp (simulated microseconds since the
simulator started), validity flags and units in field names.  Frames: NED world,
FRD body; quaternions are (w, x, y, z) and rotate FRD vectors into NED.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import IntEnum
from typing import TYPE_CHECKING

import numpy as np

from autopilot.control.gimbal_pointing import NO_GIMBAL_REQUEST, GimbalRequest
from autopilot.manual_input import ManualInput as ManualInput  # the sticks' record (re-exported: it lives there)
from mavsim_core.px4_modes import Mode

if TYPE_CHECKING:
    from autopilot.telemetry_extras import TelemetryExtras


@dataclass(frozen=True, slots=True)
class ImuSample:
    """One HIL_SENSOR message, converted to SI."""

    timestamp_us: int
    accel_frd_m_s2: np.ndarray  # specific force
    gyro_frd_rad_s: np.ndarray
    mag_frd_gauss: np.ndarray
    pressure_hpa: float
    temperature_c: float
    fields_updated: int


@dataclass(frozen=True, slots=True)
class GpsSample:
    """One HIL_GPS message, converted to SI."""

    timestamp_us: int
    fix_type: int  # GPS_FIX_TYPE: 3 = 3D fix
    lat_deg: float
    lon_deg: float
    alt_amsl_m: float
    vel_ned_m_s: np.ndarray
    eph_m: float
    epv_m: float
    satellites: int


@dataclass(frozen=True, slots=True)
class VehicleEstimate:
    """Estimator output: what the controllers and telemetry use.

    ``pos_ned_m`` is relative to the estimator origin (``origin_*``), the place
    of the first good GPS fix.  ``alt_amsl_m`` = origin_alt_amsl_m - pos_ned_m[2].
    """

    timestamp_us: int
    q_wxyz: np.ndarray  # FRD -> NED
    rate_frd_rad_s: np.ndarray  # bias-corrected
    accel_ned_m_s2: np.ndarray  # kinematic acceleration, gravity removed
    pos_ned_m: np.ndarray
    vel_ned_m_s: np.ndarray
    attitude_valid: bool
    position_valid: bool  # horizontal and vertical position and velocity usable
    origin_lat_deg: float
    origin_lon_deg: float
    origin_alt_amsl_m: float
    roll_rad: float = 0.0
    pitch_rad: float = 0.0
    yaw_rad: float = 0.0
    height_valid: bool = True  # vertical position (barometer) usable even when position_valid is not
    reset_count: int = 0  # position resets so far (e.g. to GPS after a persistent glitch)
    reset_delta_ned_m: np.ndarray | None = None  # the latest reset's jump, m NED

    @property
    def alt_amsl_m(self) -> float:
        return self.origin_alt_amsl_m - float(self.pos_ned_m[2])


@dataclass(frozen=True, slots=True)
class EstimatorStatus:
    """The EKF's health (PX4's estimator_status): test ratios are innovation^2 / (gate^2 S), > 1 rejected."""

    timestamp_us: int
    flags: int  # ESTIMATOR_STATUS_FLAGS
    vel_ratio: float
    pos_horiz_ratio: float
    pos_vert_ratio: float
    mag_ratio: float
    pos_horiz_accuracy_m: float  # 1-sigma
    pos_vert_accuracy_m: float
    tilt_std_rad: float
    yaw_std_rad: float
    mag_fault: bool
    gps_glitch: bool
    position_ok: bool
    failed_sensors: tuple[str, ...] = ()  # "accelerometer", "gyro", "barometer" (estimation/sensor_checks.py)


class LandedState(IntEnum):
    """MAV_LANDED_STATE values."""

    UNDEFINED = 0
    ON_GROUND = 1
    IN_AIR = 2
    TAKEOFF = 3
    LANDING = 4


@dataclass(frozen=True, slots=True)
class HomePosition:
    lat_deg: float
    lon_deg: float
    alt_amsl_m: float
    pos_ned_m: np.ndarray  # relative to the estimator origin
    yaw_rad: float


@dataclass(frozen=True, slots=True)
class BatteryState:
    voltage_v: float
    current_a: float  # -1 unknown
    remaining_frac: float  # 0..1, -1 unknown
    cell_count: int = 4
    consumed_mah: float = -1.0  # charge drawn since start, mAh; -1 unknown


class BatteryWarning(IntEnum):
    """The commander's battery warning level (PX4's battery_status.warning), from BAT_*_THR."""

    NONE = 0
    LOW = 1  # remaining below BAT_LOW_THR
    CRITICAL = 2  # below BAT_CRIT_THR
    EMERGENCY = 3  # below BAT_EMERGEN_THR


@dataclass(frozen=True, slots=True)
class ActuatorStatus:
    """What the flight controller sent to the motors this step (PX4's actuator_outputs).

    Published by the flight controller after every control step; read by the commander
    (land detector), the telemetry and the flight log.
    """

    timestamp_us: int
    motor_outputs: tuple[float, ...]  # motor commands 0..1, one per rotor; () before the first step
    thrust_n: float  # collective thrust the mixer delivers, N
    throttle_frac: float  # the same as a fraction of the maximum collective thrust, 0..1
    thrust_frac_of_hover: float  # the same as a fraction of the vehicle's weight


NO_ACTUATORS = ActuatorStatus(0, (), 0.0, 0.0, 0.0)


class MissionState(IntEnum):
    """MISSION_CURRENT.mission_state (MAVLink MISSION_STATE)."""

    UNKNOWN = 0
    NO_MISSION = 1
    NOT_STARTED = 2
    ACTIVE = 3
    PAUSED = 4
    COMPLETE = 5


@dataclass(frozen=True, slots=True)
class MissionStatus:
    """The stored plans and the mission's progress (MISSION_CURRENT), and the geofence (SYS_STATUS)."""

    seq: int = 0  # the current mission item (== total once complete)
    total: int = 0  # mission items stored
    state: MissionState = MissionState.NO_MISSION
    in_mission_mode: bool = False
    fence_items: int = 0
    rally_items: int = 0
    fence_breached: bool = False  # a breach (or a predicted one) was reported and not yet cleared


NO_MISSION_STATUS = MissionStatus()


@dataclass(frozen=True, slots=True)
class FailsafeStatus:
    """The failsafes' state (autopilot.commander.failsafes): HEARTBEAT system_status and SYS_STATUS bits."""

    action_in_force: bool = False  # a failsafe's mode is being flown (MAV_STATE_CRITICAL)
    emergency: bool = False  # battery emergency while armed, or motors stopped by a failsafe (MAV_STATE_EMERGENCY)
    rc_seen: bool = False  # MANUAL_CONTROL arrived at least once (the RC receiver counts as present)
    rc_lost: bool = False  # ... and is silent now (COM_RC_LOSS_T)
    gcs_lost: bool = False  # the ground station's HEARTBEATs are silent (COM_DL_LOSS_T)


NO_FAILSAFE = FailsafeStatus()


@dataclass(frozen=True, slots=True)
class CommanderStatus:
    """What the commander decided (PX4's vehicle_status, vehicle_land_detected and home_position).

    Published by the commander at the end of each update and after every command, mode
    change or battery reading; read by the flight controller (armed, ground contact, in
    air), the flight log, the process loop and the ground-station telemetry.
    ``estimate`` and ``gps`` are the inputs of the commander's latest update.
    """

    timestamp_us: int
    mav_type: int  # MAV_TYPE of the airframe
    armed: bool
    mode: Mode
    landed_state: LandedState
    in_air: bool  # the land detector says flying
    ground_contact: bool  # on the ground, or landing conditions holding: integrators stop
    home: HomePosition | None
    estimate: VehicleEstimate | None
    gps: GpsSample | None
    gps_ok: bool  # a recent GPS fix
    battery: BatteryState
    battery_warning: BatteryWarning
    prearm_failures: tuple[str, ...]  # why arming would be refused now (empty while armed)
    position_setpoint_ned_m: np.ndarray | None  # the active flight task's, None when not flying one
    mission: MissionStatus = NO_MISSION_STATUS
    failsafe: FailsafeStatus = NO_FAILSAFE
    gimbal_request: GimbalRequest = NO_GIMBAL_REQUEST  # the flight controller's own use of the gimbal


@dataclass(frozen=True, slots=True)
class ControlSetpoints:
    """What the controllers are aiming at (ATTITUDE_TARGET, POSITION_TARGET_LOCAL_NED).

    Position components are NaN where the position is not controlled.  ``q_sp_wxyz``
    takes FRD vectors to NED like the estimate (NaN while body rates are flown: no attitude
    setpoint then); ``thrust_frac`` is the collective thrust setpoint as a fraction of the maximum (0..1).
    """

    timestamp_us: int
    pos_ned_m: np.ndarray
    vel_ned_m_s: np.ndarray
    acc_ned_m_s2: np.ndarray
    yaw_rad: float
    q_sp_wxyz: np.ndarray
    rate_sp_frd_rad_s: np.ndarray
    thrust_frac: float


@dataclass(frozen=True, slots=True)
class TelemetrySnapshot:
    """Everything the ground-station link reports, gathered once per iteration."""

    timestamp_us: int
    mav_type: int  # MAV_TYPE
    armed: bool
    base_mode: int  # MAV_MODE_FLAG bits, as PX4 sets them
    custom_mode: int  # PX4: main_mode << 16 | sub_mode << 24
    system_status: int  # MAV_STATE
    landed_state: LandedState
    estimate: VehicleEstimate | None
    gps: GpsSample | None
    home: HomePosition | None
    battery: BatteryState
    throttle_frac: float  # collective thrust command 0..1
    sensors_present: int  # MAV_SYS_STATUS_SENSOR bits
    sensors_enabled: int
    sensors_health: int
    prearm_ok: bool
    position_setpoint_ned_m: np.ndarray | None = None
    motor_outputs: tuple[float, ...] = field(default=())
    control: ControlSetpoints | None = None  # None while the controllers are not flying
    estimator_status: EstimatorStatus | None = None
    battery_warning: BatteryWarning = BatteryWarning.NONE
    mission: MissionStatus = NO_MISSION_STATUS
    extras: TelemetryExtras | None = None  # IMU sample, UTC and flight times (autopilot/telemetry_extras.py)


def input_age_s(received_us: int, received_wall_s: float, now_us: int, wall_s: float | None) -> float:
    """How long an input from outside (sticks, offboard setpoints, a ground station's heartbeat) has been
    silent, in seconds: the lesser of its simulated and its wall-clock age (``wall_s`` None: simulated
    only).  A client sends on the wall clock while the simulation may run many times faster (or slower),
    so an input counts as lost only once it is silent on both clocks, never because the simulation
    outran a client that kept sending.
    """
    sim_age = (now_us - received_us) * 1e-6
    if wall_s is None:
        return sim_age
    return min(sim_age, wall_s - received_wall_s)


class OffboardKind(IntEnum):
    """What an offboard setpoint controls (the lowest level it gives decides)."""

    POSITION = 0  # position (and velocity / acceleration feed-forward)
    VELOCITY = 1
    ACCELERATION = 2
    ATTITUDE = 3  # attitude quaternion and collective thrust
    BODY_RATES = 4  # body rates and collective thrust


@dataclass(frozen=True, slots=True)
class OffboardSetpoint:
    """One SET_POSITION_TARGET_LOCAL_NED / _GLOBAL_INT or SET_ATTITUDE_TARGET, decoded (PX4's
    offboard_control_mode + trajectory_setpoint / vehicle_attitude_setpoint).

    Vectors are local NED (m from the estimator origin, m/s, m/s^2) whatever frame the sender used:
    the receiver (:mod:`autopilot.mavlink.offboard_messages`) converts body, offset and global frames
    with the estimate at reception; ``frame`` keeps the sender's MAV_FRAME value.
    NaN marks a component the sender masked out.  ``q_wxyz`` / ``body_rate_frd_rad_s``: the
    attitude target (FRD -> NED) or body rates, None when not given; ``thrust_frac`` 0..1
    (NaN: not given).  Stamps as :class:`ManualInput`'s.
    """

    received_us: int
    received_wall_s: float
    kind: OffboardKind
    frame: int
    pos_ned_m: np.ndarray
    vel_ned_m_s: np.ndarray
    acc_ned_m_s2: np.ndarray
    yaw_rad: float  # NaN: not given
    yaw_rate_rad_s: float  # NaN: not given
    q_wxyz: np.ndarray | None = None
    body_rate_frd_rad_s: np.ndarray | None = None
    thrust_frac: float = math.nan


@dataclass(frozen=True, slots=True)
class AttitudeSetpoint:
    """An attitude-level setpoint for the inner loops (STABILIZED, ACRO, offboard attitude or rates,
    the descend failsafe), in place of a :class:`PositionSetpoint` that the position loop flies.

    ``q_wxyz``: the attitude (FRD -> NED), None to fly ``body_rate_frd_rad_s`` (rad/s) directly;
    ``yaw_rate_rad_s``: yaw rate fed forward with an attitude; ``thrust_frac``: collective thrust as
    a fraction of the vehicle's maximum, 0..1, along the body's -z axis.
    """

    q_wxyz: np.ndarray | None
    body_rate_frd_rad_s: np.ndarray | None
    thrust_frac: float
    yaw_rate_rad_s: float = 0.0


@dataclass(frozen=True, slots=True)
class LandingTargetMeasurement:
    """One decoded LANDING_TARGET message: where the target is seen from the vehicle.

    ``rel_pos_ned_m`` is the target's position minus the vehicle's, in NED metres.
    ``std_m`` is the measurement's standard deviation in metres per horizontal axis;
    NaN when the sender gave none (the estimator then uses ``LTEST_MEAS_UNC``).
    ``source_frame`` is the message's MAV_FRAME value; ``angular`` says whether it came
    from the angle_x/angle_y/distance form.  ``square_yaw_rad``: the heading of the target's edges
    (its x axis, NED, rad) modulo 90 deg, in [-45, 45) deg, from the message's ``q``; None when the
    message gave no usable orientation.
    """

    timestamp_us: int
    rel_pos_ned_m: np.ndarray
    std_m: float
    source_frame: int
    valid: bool
    angular: bool = False
    square_yaw_rad: float | None = None


@dataclass(frozen=True, slots=True)
class LandingTargetEstimate:
    """The landing target's estimated state relative to the vehicle (PX4's landing_target_pose).

    NED metres and metres per second.  ``target_vel_ned_m_s`` is the target's velocity
    over ground (None when the vehicle's velocity was not given).  ``rel_pos_var_m2`` is
    the north and east position variance.  ``valid`` is False before the first
    measurement, after the timeout, or (polynomial predictor) with too few samples.
    """

    timestamp_us: int
    rel_pos_ned_m: np.ndarray
    rel_vel_ned_m_s: np.ndarray
    valid: bool
    is_static: bool = False
    target_vel_ned_m_s: np.ndarray | None = None
    rel_pos_var_m2: np.ndarray = field(default_factory=lambda: np.full(2, np.inf))
