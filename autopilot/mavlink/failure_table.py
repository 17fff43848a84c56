"""Which simulator parameters produce each failure of MAV_CMD_INJECT_FAILURE (unit, type, instance).

A pure table (no I/O): :func:`resolve` turns the command's FAILURE_UNIT (param1), FAILURE_TYPE
(param2) and instance (param3; 0 = all, as PX4) into a :class:`Fault`: the ``SIM_*`` values that
produce it in the simulator (``sitl/sim_settings.py``) and the unit's fault flags with their healthy
values, or into a :class:`Refusal` (a MAV_RESULT and the reason).  The failure injection service
(:mod:`autopilot.mavlink.failure_injection`) sets them through the simulator link.

What the simulator can produce (one of each sensor, ``n`` motors; see ``docs/failure_injection.md``):

======== ===================================================================================
GPS      OFF (no fixes), STUCK (the last fix repeated), WRONG (50 m north of the truth),
         SLOW (1 Hz), DELAYED (500 ms latency), INTERMITTENT (outages of 1 s, 12 a minute)
accel    OFF (no readings), STUCK (the last reading repeated), GARBAGE (random within range)
gyro     OFF, STUCK, GARBAGE
mag      OFF, STUCK, GARBAGE, WRONG (0.5 gauss added on the body x axis, as a magnet nearby)
baro     OFF, STUCK, GARBAGE
battery  OFF: the monitor reads an empty pack (PX4's battery failure)
motor    OFF (motor i stopped), WRONG (motor i at half thrust); one motor at a time
======== ===================================================================================

FAILURE_TYPE_OK clears a unit: its fault flags back to healthy (and the service restores the other
values it changed).  Everything else of the MAVLink enums is :data:`UNSUPPORTED`; values outside
the enums and instances the vehicle does not have are DENIED.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from pymavlink.dialects.v20 import common as mavlink

GYRO, ACCEL, MAG, BARO, GPS = (
    mavlink.FAILURE_UNIT_SENSOR_GYRO,
    mavlink.FAILURE_UNIT_SENSOR_ACCEL,
    mavlink.FAILURE_UNIT_SENSOR_MAG,
    mavlink.FAILURE_UNIT_SENSOR_BARO,
    mavlink.FAILURE_UNIT_SENSOR_GPS,
)
BATTERY, MOTOR = mavlink.FAILURE_UNIT_SYSTEM_BATTERY, mavlink.FAILURE_UNIT_SYSTEM_MOTOR
OK, OFF, STUCK, GARBAGE, WRONG, SLOW, DELAYED, INTERMITTENT = range(8)  # FAILURE_TYPE
TYPE_NAMES = ("ok", "off", "stuck", "garbage", "wrong", "slow", "delayed", "intermittent")
UNIT_NAMES = {
    GYRO: "gyro", ACCEL: "accelerometer", MAG: "magnetometer", BARO: "barometer", GPS: "GPS",
    mavlink.FAILURE_UNIT_SENSOR_OPTICAL_FLOW: "optical flow", mavlink.FAILURE_UNIT_SENSOR_VIO: "VIO",
    mavlink.FAILURE_UNIT_SENSOR_DISTANCE_SENSOR: "distance sensor", mavlink.FAILURE_UNIT_SENSOR_AIRSPEED: "airspeed",
    BATTERY: "battery", MOTOR: "motor", mavlink.FAILURE_UNIT_SYSTEM_SERVO: "servo",
    mavlink.FAILURE_UNIT_SYSTEM_AVOIDANCE: "avoidance", mavlink.FAILURE_UNIT_SYSTEM_RC_SIGNAL: "RC signal",
    mavlink.FAILURE_UNIT_SYSTEM_MAVLINK_SIGNAL: "MAVLink signal",
}  # fmt: skip

GPS_WRONG_NORTH_M = 50.0
MAG_WRONG_GAUSS = 0.5
MOTOR_WRONG_THRUST = 0.5
_MOTOR = -1.0  # stands for the instance (1-based motor number) in FAULTS

# Each unit's fault flags and their healthy values: what FAILURE_TYPE_OK sets.
FLAGS: dict[int, dict[str, float]] = {
    GPS: {"SIM_GPS_DISABLE": 0, "SIM_GPS_STUCK": 0},
    ACCEL: {"SIM_ACC_OFF": 0, "SIM_ACC_STUCK": 0, "SIM_ACC_GARBAGE": 0},
    GYRO: {"SIM_GYR_OFF": 0, "SIM_GYR_STUCK": 0, "SIM_GYR_GARBAGE": 0},
    MAG: {"SIM_MAG_OFF": 0, "SIM_MAG_STUCK": 0, "SIM_MAG_GARBAGE": 0},
    BARO: {"SIM_BARO_OFF": 0, "SIM_BARO_STUCK": 0, "SIM_BARO_GARBAGE": 0},
    BATTERY: {"SIM_BAT_EMPTY": 0},
    MOTOR: {"SIM_ENGINE_FAIL": 0},
}
# (unit, type) -> the SIM_* values that produce it.  Values of parameters that are not flags of the
# unit (SIM_GPS_HZ, SIM_ENGINE_MUL...) are settings: the service restores what was there before.
FAULTS: dict[tuple[int, int], dict[str, float]] = {
    (GPS, OFF): {"SIM_GPS_DISABLE": 1},
    (GPS, STUCK): {"SIM_GPS_STUCK": 1},
    (GPS, WRONG): {"SIM_GPS_GLITCH_N": GPS_WRONG_NORTH_M},
    (GPS, SLOW): {"SIM_GPS_HZ": 1.0},
    (GPS, DELAYED): {"SIM_GPS_LAG_MS": 500},
    (GPS, INTERMITTENT): {"SIM_GPS_DROP_RT": 12.0, "SIM_GPS_DROP_S": 1.0},
    (ACCEL, OFF): {"SIM_ACC_OFF": 1},
    (ACCEL, STUCK): {"SIM_ACC_STUCK": 1},
    (ACCEL, GARBAGE): {"SIM_ACC_GARBAGE": 1},
    (GYRO, OFF): {"SIM_GYR_OFF": 1},
    (GYRO, STUCK): {"SIM_GYR_STUCK": 1},
    (GYRO, GARBAGE): {"SIM_GYR_GARBAGE": 1},
    (MAG, OFF): {"SIM_MAG_OFF": 1},
    (MAG, STUCK): {"SIM_MAG_STUCK": 1},
    (MAG, GARBAGE): {"SIM_MAG_GARBAGE": 1},
    (MAG, WRONG): {"SIM_MAG_OFS_X": MAG_WRONG_GAUSS},
    (BARO, OFF): {"SIM_BARO_OFF": 1},
    (BARO, STUCK): {"SIM_BARO_STUCK": 1},
    (BARO, GARBAGE): {"SIM_BARO_GARBAGE": 1},
    (BATTERY, OFF): {"SIM_BAT_EMPTY": 1},
    (MOTOR, OFF): {"SIM_ENGINE_FAIL": _MOTOR, "SIM_ENGINE_MUL": 0.0},
    (MOTOR, WRONG): {"SIM_ENGINE_FAIL": _MOTOR, "SIM_ENGINE_MUL": MOTOR_WRONG_THRUST},
}


@dataclass(frozen=True)
class Fault:
    """What to set for one injection: ``values`` (the fault's SIM_* values; for OK: none) on top of
    ``flags`` (all the unit's fault flags at their healthy values, so the previous fault is cleared)."""

    unit: int
    ftype: int
    flags: dict[str, float]
    values: dict[str, float]
    label: str  # "GPS off", "motor 2 off"; for OK the unit: "GPS"

    @property
    def settings(self) -> list[str]:
        """The parameters this fault changes that are not flags (their old values are to be restored)."""
        return [name for name in self.values if name not in self.flags]


@dataclass(frozen=True)
class Refusal:
    result: int  # MAV_RESULT
    reason: str


UNSUPPORTED, DENIED = mavlink.MAV_RESULT_UNSUPPORTED, mavlink.MAV_RESULT_DENIED


def _whole(x: float) -> int | None:
    """A command parameter as a non-negative integer (PX4 rounds: x + 0.5), None if it is not one."""
    if not math.isfinite(x) or x < -0.5:
        return None
    return int(x + 0.5)


def resolve(unit_f: float, type_f: float, instance_f: float, n_motors: int) -> Fault | Refusal:
    """The fault of MAV_CMD_INJECT_FAILURE's param1-3 on a vehicle with ``n_motors`` (see the module docstring)."""
    unit, ftype, instance = _whole(unit_f), _whole(type_f), _whole(instance_f)
    if unit not in UNIT_NAMES:
        return Refusal(DENIED, f"unknown failure unit {unit_f:g}")
    if ftype is None or not 0 <= ftype < len(TYPE_NAMES):
        return Refusal(DENIED, f"unknown failure type {type_f:g}")
    if instance is None:
        return Refusal(DENIED, f"bad instance {instance_f:g}")
    name, what = UNIT_NAMES[unit], TYPE_NAMES[ftype]
    if unit not in FLAGS or (ftype != OK and (unit, ftype) not in FAULTS):
        return Refusal(UNSUPPORTED, f"{name} {what} is not supported in simulation")
    count = n_motors if unit == MOTOR else 1
    if instance > count:
        return Refusal(DENIED, f"no {name} {instance}: the vehicle has {count}")
    values = dict(FAULTS.get((unit, ftype), {}))
    label = name if ftype == OK else f"{name} {what}"
    if unit == MOTOR and ftype != OK:
        if instance == 0:
            return Refusal(UNSUPPORTED, "all motors at once is not supported: the simulator fails one motor (1..n)")
        values = {k: float(instance) if v == _MOTOR else v for k, v in values.items()}
        label = f"motor {instance} {what}"
    return Fault(unit, ftype, dict(FLAGS[unit]), values, label)
