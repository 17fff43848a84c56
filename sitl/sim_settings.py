"""The simulator's settings: wind, sensor errors and failures, each a ``SIM_*`` parameter.

Each field of the three dataclasses below is declared once, with the MAVLink
parameter that sets it (name of at most 16 characters, INT32 or REAL32, limits,
unit, description) in the field's metadata.  The simulator's parameter service
(UDP 14740+N, ``sitl.param_server``) and scenario files (``sitl.scenario``) are
built on this one table; the models read the dataclasses directly on every step,
so a change acts on the next step.

Units are SI (m, s, rad) except where the unit says otherwise.  Body vectors are
FRD, world vectors NED.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, fields

from mavsim_core.param_types import ParamType
from vision.pad import NESTED_PAD, SINGLE_PAD, PadLayout


def sim_param(
    name: str,
    default: float,
    lo: float,
    hi: float,
    unit: str,
    description: str,
    kind: ParamType = ParamType.REAL32,
    start_only: bool = False,
):
    """A dataclass field that is also the MAVLink parameter ``name`` (``start_only``: refused in flight)."""
    assert len(name) <= 16 and name.startswith("SIM_"), name
    return field(
        default=default,
        metadata={
            "param": name,
            "type": kind,
            "min": lo,
            "max": hi,
            "unit": unit,
            "description": description,
            "start_only": start_only,
        },
    )


@dataclass
class WindSettings:
    """Steady wind, Dryden turbulence and discrete gusts (sitl.wind)."""

    speed_m_s: float = sim_param("SIM_WIND_SPD", 0.0, 0.0, 30.0, "m/s", "Steady horizontal wind speed")
    direction_deg: float = sim_param(
        "SIM_WIND_DIR",
        0.0,
        0.0,
        360.0,
        "deg",
        "Direction the steady wind blows from, degrees true (270 = from the West)",
    )
    turbulence_m_s: float = sim_param(
        "SIM_WIND_TURB", 0.0, 0.0, 10.0, "m/s", "RMS of the horizontal Dryden turbulence (0 = none)"
    )
    gust_speed_m_s: float = sim_param(
        "SIM_GUST_SPD", 0.0, 0.0, 20.0, "m/s", "Peak speed of discrete 1-cosine gusts (0 = no gusts)"
    )
    gust_duration_s: float = sim_param("SIM_GUST_DUR", 2.0, 0.2, 30.0, "s", "Duration of one gust")
    gust_interval_s: float = sim_param(
        "SIM_GUST_INT", 10.0, 1.0, 600.0, "s", "Mean time between the starts of two gusts (random, exponential)"
    )


@dataclass
class SensorSettings:
    """Noise, bias, delay and failures of the IMU, magnetometer, barometer and GPS (sitl.sensors, sitl.gps).

    Defaults: the IMU noise densities and bias walks are those of PX4's Gazebo IMU
    plugin defaults (an ADIS16448-class IMU: accelerometer 1.86e-3 m/s^2/sqrt(Hz),
    walk 6e-3; gyro 1.8665e-4 rad/s/sqrt(Hz), walk 3.8785e-5); turn-on biases are the
    residuals after a factory calibration (smaller than that plugin's 0.196 m/s^2 and
    0.0087 rad/s, which are uncalibrated); the GPS is a good dual-band receiver (0.1 m white noise,
    a 0.05 m slowly wandering error) at 5 Hz and 120 ms latency.
    """

    # IMU (250 Hz)
    accel_noise_density: float = sim_param(
        "SIM_ACC_NOISE", 1.86e-3, 0.0, 1.0, "m/s^2/sqrt(Hz)", "Accelerometer white noise density"
    )
    gyro_noise_density: float = sim_param(
        "SIM_GYR_NOISE", 1.8665e-4, 0.0, 0.1, "rad/s/sqrt(Hz)", "Gyro white noise density"
    )
    accel_bias_walk: float = sim_param(
        "SIM_ACC_BIAS_RW", 6.0e-3, 0.0, 1.0, "m/s^3/sqrt(Hz)", "Accelerometer bias random walk"
    )
    gyro_bias_walk: float = sim_param(
        "SIM_GYR_BIAS_RW", 3.8785e-5, 0.0, 0.1, "rad/s^2/sqrt(Hz)", "Gyro bias random walk"
    )
    accel_bias_sd: float = sim_param(
        "SIM_ACC_BIAS_SD",
        0.05,
        0.0,
        2.0,
        "m/s^2",
        "Standard deviation of the accelerometer turn-on bias (drawn at start)",
    )
    gyro_bias_sd: float = sim_param(
        "SIM_GYR_BIAS_SD", 0.005, 0.0, 0.5, "rad/s", "Standard deviation of the gyro turn-on bias (drawn at start)"
    )
    # IMU failures (sitl.sensor_faults; MAV_CMD_INJECT_FAILURE sets them through the flight controller)
    accel_off: int = sim_param("SIM_ACC_OFF", 0, 0, 1, "", "1: the accelerometer sends nothing", ParamType.INT32)
    accel_stuck: int = sim_param(
        "SIM_ACC_STUCK", 0, 0, 1, "", "1: the accelerometer repeats its last reading", ParamType.INT32
    )
    accel_garbage: int = sim_param(
        "SIM_ACC_GARBAGE", 0, 0, 1, "", "1: the accelerometer reads random values within +-16 g", ParamType.INT32
    )
    gyro_off: int = sim_param("SIM_GYR_OFF", 0, 0, 1, "", "1: the gyro sends nothing", ParamType.INT32)
    gyro_stuck: int = sim_param("SIM_GYR_STUCK", 0, 0, 1, "", "1: the gyro repeats its last reading", ParamType.INT32)
    gyro_garbage: int = sim_param(
        "SIM_GYR_GARBAGE", 0, 0, 1, "", "1: the gyro reads random values within +-2000 deg/s", ParamType.INT32
    )
    # Magnetometer
    mag_noise_gauss: float = sim_param("SIM_MAG_NOISE", 0.003, 0.0, 0.5, "gauss", "Magnetometer white noise")
    mag_offset_x_gauss: float = sim_param("SIM_MAG_OFS_X", 0.0, -2.0, 2.0, "gauss", "Magnetometer offset, body x")
    mag_offset_y_gauss: float = sim_param("SIM_MAG_OFS_Y", 0.0, -2.0, 2.0, "gauss", "Magnetometer offset, body y")
    mag_offset_z_gauss: float = sim_param("SIM_MAG_OFS_Z", 0.0, -2.0, 2.0, "gauss", "Magnetometer offset, body z")
    mag_motor_x_gauss_a: float = sim_param(
        "SIM_MAG_MOT_X",
        0.0,
        -0.1,
        0.1,
        "gauss/A",
        "Interference on the magnetometer per ampere of battery current, body x",
    )
    mag_motor_y_gauss_a: float = sim_param(
        "SIM_MAG_MOT_Y", 0.0, -0.1, 0.1, "gauss/A", "Interference per ampere, body y"
    )
    mag_motor_z_gauss_a: float = sim_param(
        "SIM_MAG_MOT_Z", 0.0, -0.1, 0.1, "gauss/A", "Interference per ampere, body z"
    )
    mag_stuck: int = sim_param(
        "SIM_MAG_STUCK", 0, 0, 1, "", "1: the magnetometer repeats its last reading", ParamType.INT32
    )
    mag_off: int = sim_param("SIM_MAG_OFF", 0, 0, 1, "", "1: the magnetometer sends nothing", ParamType.INT32)
    mag_garbage: int = sim_param(
        "SIM_MAG_GARBAGE", 0, 0, 1, "", "1: the magnetometer reads random values within +-4 gauss", ParamType.INT32
    )
    # Barometer
    baro_noise_m: float = sim_param("SIM_BARO_RND", 0.05, 0.0, 10.0, "m", "Barometer white noise, as altitude")
    baro_drift_m_s: float = sim_param(
        "SIM_BARO_DRIFT", 0.0, -1.0, 1.0, "m/s", "Barometer altitude drift rate (a slow pressure change)"
    )
    baro_stuck: int = sim_param(
        "SIM_BARO_STUCK", 0, 0, 1, "", "1: the barometer repeats its last reading", ParamType.INT32
    )
    baro_off: int = sim_param("SIM_BARO_OFF", 0, 0, 1, "", "1: the barometer sends nothing", ParamType.INT32)
    baro_garbage: int = sim_param(
        "SIM_BARO_GARBAGE", 0, 0, 1, "", "1: the barometer reads random pressures, 300-1100 hPa", ParamType.INT32
    )
    # GPS
    gps_rate_hz: float = sim_param("SIM_GPS_HZ", 5.0, 1.0, 50.0, "Hz", "GPS fix rate")
    gps_lag_ms: int = sim_param(
        "SIM_GPS_LAG_MS",
        120,
        0,
        500,
        "ms",
        "GPS latency: a fix reports the vehicle's state this long before it is sent",
        ParamType.INT32,
    )
    gps_noise_m: float = sim_param("SIM_GPS_NOISE", 0.1, 0.0, 20.0, "m", "GPS horizontal white noise, per axis")
    gps_vnoise_m: float = sim_param("SIM_GPS_VNOISE", 0.2, 0.0, 20.0, "m", "GPS vertical white noise")
    gps_vel_noise_m_s: float = sim_param("SIM_GPS_VELNOISE", 0.05, 0.0, 5.0, "m/s", "GPS velocity white noise")
    gps_drift_m: float = sim_param(
        "SIM_GPS_DRIFT", 0.05, 0.0, 20.0, "m", "RMS of the slowly wandering GPS position error (Gauss-Markov, 60 s)"
    )
    gps_fix_type: int = sim_param(
        "SIM_GPS_FIXTYPE",
        3,
        3,
        6,
        "",
        "GPS_FIX_TYPE of a good fix: 3 = 3D, 4 = DGPS, 5 = RTK float, 6 = RTK fixed (errors: the SIM_GPS_* above)",
        ParamType.INT32,
    )
    gps_dropout_per_min: float = sim_param(
        "SIM_GPS_DROP_RT", 0.0, 0.0, 60.0, "1/min", "Mean number of GPS outages (no fix) per minute"
    )
    gps_dropout_s: float = sim_param("SIM_GPS_DROP_S", 1.0, 0.1, 60.0, "s", "Duration of one GPS outage")
    gps_disable: int = sim_param("SIM_GPS_DISABLE", 0, 0, 1, "", "1: the GPS receiver sends nothing", ParamType.INT32)
    gps_stuck: int = sim_param(
        "SIM_GPS_STUCK", 0, 0, 1, "", "1: the GPS receiver repeats its last fix (position, velocity)", ParamType.INT32
    )
    gps_glitch_n_m: float = sim_param(
        "SIM_GPS_GLITCH_N",
        0.0,
        -1000.0,
        1000.0,
        "m",
        "GPS position glitch: offset added to the reported position, North",
    )
    gps_glitch_e_m: float = sim_param("SIM_GPS_GLITCH_E", 0.0, -1000.0, 1000.0, "m", "GPS glitch, East")
    gps_glitch_d_m: float = sim_param("SIM_GPS_GLITCH_D", 0.0, -1000.0, 1000.0, "m", "GPS glitch, Down")


@dataclass
class MotorSettings:
    """Motor failures (sitl.simulation applies them to sitl.rotors) and the battery's drain (sitl.battery)."""

    fail_motor: int = sim_param(
        "SIM_ENGINE_FAIL",
        0,
        0,
        12,
        "",
        "Motor (1-based, the vehicle file's order) running at SIM_ENGINE_MUL; 0 = none",
        ParamType.INT32,
    )
    fail_efficiency: float = sim_param(
        "SIM_ENGINE_MUL", 0.0, 0.0, 1.0, "", "Thrust multiplier of the failed motor (0 = stopped, 1 = healthy)"
    )
    # The battery (sitl.battery): PX4 SITL's drain parameters, to run the pack down in a test.
    battery_drain_s: float = sim_param(
        "SIM_BAT_DRAIN",
        0.0,
        0.0,
        86400.0,
        "s",
        "Time to drain the full pack at a steady rate, whatever the load (0 = the physical model: rotor power)",
    )
    battery_min_pct: float = sim_param(
        "SIM_BAT_MIN_PCT",
        0.0,
        0.0,
        100.0,
        "%",
        "The pack stops draining at this charge; raised above the charge, the charge rises to it (PX4: 50)",
    )
    battery_empty: int = sim_param(
        "SIM_BAT_EMPTY", 0, 0, 1, "",
        "1: the battery monitor reads an empty pack (0 %, 3.3 V a cell) whatever the charge (PX4's battery failure)",
        ParamType.INT32,
    )  # fmt: skip


PATH_STOP, PATH_LINE, PATH_CIRCLE, PATH_FIGURE8, PATH_RANDOM, PATH_MANUAL = range(6)
PAD_NESTED, PAD_SINGLE = range(2)  # SIM_PAD_LAYOUT


@dataclass
class UgvSettings:
    """The UGV's ``SIM_UGV_*`` parameters (see the module docstring)."""

    enabled: int = sim_param(
        "SIM_UGV_EN", 0, 0, 1, "", "1: the world holds the ground vehicle (read at start)", ParamType.INT32, True
    )
    north_m: float = sim_param("SIM_UGV_X", 3.0, -1000.0, 1000.0, "m", "UGV start: north of the multicopter's start")
    east_m: float = sim_param("SIM_UGV_Y", 0.0, -1000.0, 1000.0, "m", "UGV start: east of the multicopter's start")
    yaw_deg: float = sim_param("SIM_UGV_YAW", 0.0, 0.0, 360.0, "deg", "UGV start heading, degrees from North")
    path: int = sim_param(
        "SIM_UGV_PATH",
        PATH_STOP,
        PATH_STOP,
        PATH_MANUAL,
        "",
        "UGV path: 0 stop, 1 straight line, 2 circle, 3 figure-8, 4 random waypoints, 5 manual (MANUAL_CONTROL)",
        ParamType.INT32,
    )
    speed_m_s: float = sim_param("SIM_UGV_SPD", 1.0, 0.0, 4.5, "m/s", "UGV speed along its path")
    radius_m: float = sim_param("SIM_UGV_RAD", 2.0, 0.5, 100.0, "m", "Radius of the UGV's circle and figure-8")
    accel_m_s2: float = sim_param("SIM_UGV_ACC", 1.5, 0.1, 5.0, "m/s^2", "UGV acceleration limit")
    # The UGV's telemetry radio (sitl.ugv_broadcast): FOLLOW_TARGET to the flight controller, for AUTO.FOLLOW_TARGET.
    follow_target: int = sim_param(
        "SIM_UGV_FLW", 0, 0, 1, "",
        "1: the UGV broadcasts its GPS position and velocity as FOLLOW_TARGET to the flight controller's API socket",
        ParamType.INT32,
    )  # fmt: skip
    follow_rate_hz: float = sim_param("SIM_UGV_FLW_HZ", 5.0, 1.0, 50.0, "Hz", "Rate of the UGV's FOLLOW_TARGET")
    # The landing pad on the deck (vision.pad; drawn when the world is built, so read at start).
    pad_layout: int = sim_param(
        "SIM_PAD_LAYOUT", PAD_NESTED, PAD_NESTED, PAD_SINGLE, "",
        "Landing pad on the UGV's deck: 0 nested (a scenario's [pad] markers, or four large markers around a "
        "small one), 1 the single seed marker (id 76, 0.333 m) (read at start)",
        ParamType.INT32, True,
    )  # fmt: skip
    nested_pad: PadLayout = NESTED_PAD  # the nested pad's markers: a scenario file's [pad] table (sitl.scenario)

    def pad(self) -> PadLayout:
        """The pad on the deck: SIM_PAD_LAYOUT's choice (the pad frame is the UGV's body frame, x forward, y left)."""
        return SINGLE_PAD if int(self.pad_layout) == PAD_SINGLE else self.nested_pad

    def start_pose(self):
        """The start pose as :class:`sitl.ugv_paths.Pose2` (NED m, yaw rad)."""
        from sitl.ugv_paths import Pose2

        return Pose2(self.north_m, self.east_m, math.radians(self.yaw_deg))


@dataclass
class CameraSettings:
    """The downward camera's errors and the vision companion's latency (sitl.camera, sitl.companion)."""

    latency_ms: int = sim_param(
        "SIM_CAM_LAT_MS",
        50,
        0,
        1000,
        "ms",
        "Capture to LANDING_TARGET at the flight controller (render, detect, send)",
        ParamType.INT32,
    )
    noise_grey: float = sim_param("SIM_CAM_NOISE", 2.0, 0.0, 50.0, "grey", "Pixel noise, standard deviation (0-255)")
    fail: int = sim_param("SIM_CAM_FAIL", 0, 0, 1, "", "1: the camera delivers no frames", ParamType.INT32)
    mount: int = sim_param(
        "SIM_CAM_MOUNT",
        0,
        0,
        2,
        "",
        "Camera mount: 0 the vehicle file's (with the UGV; fixed without), 1 fixed, 2 gimbal (read at start)",
        ParamType.INT32,
        True,
    )

    render: int = sim_param(
        "SIM_CAM_RENDER", 1, 0, 1, "",
        "Camera renderer: 0 MuJoCo's OpenGL render of the whole world, 1 the deck and the ground drawn with OpenCV "
        "(sitl/deck_render.py: the same detections at a third of the cost) (read at start)",
        ParamType.INT32, True,
    )  # fmt: skip
    process: int = sim_param(
        "SIM_CAM_PROC", 1, 0, 1, "",
        "Where the camera's frames are rendered and read: 1 a process of its own (they overlap the physics and the "
        "flight controller), 0 a thread of the simulator; the same frames either way (read at start)",
        ParamType.INT32, True,
    )  # fmt: skip

    video: int = sim_param(
        "SIM_VID_EN", 1, 0, 1, "", "1: the camera's video goes out as RTP H.264 to UDP 5600+N (read at start)",
        ParamType.INT32, True,
    )  # fmt: skip
    video_fps: float = sim_param(
        "SIM_VID_FPS", 0.0, 0.0, 60.0, "Hz", "Frame rate of the video stream (0: the camera's; read at start)",
        start_only=True,
    )  # fmt: skip
    video_annotate: int = sim_param(
        "SIM_VID_ANNOT", 0, 0, 1, "", "1: the video shows the companion's detections (markers outlined, pose)",
        ParamType.INT32,
    )  # fmt: skip
    video_kbps: int = sim_param(
        "SIM_VID_KBPS", 2000, 100, 20000, "kbit/s", "Bit rate of the video stream (read at start)",
        ParamType.INT32, True,
    )  # fmt: skip

    def mount_name(self, vehicle_file_mount: str) -> str:
        """The camera mount to build ("fixed" or "gimbal"): SIM_CAM_MOUNT's, or the vehicle file's when it is 0."""
        return {1: "fixed", 2: "gimbal"}.get(int(self.mount), vehicle_file_mount)


def param_fields(settings) -> list:
    """The dataclass fields of a settings object that are SIM_* parameters."""
    return [f for f in fields(settings) if "param" in f.metadata]
