"""The simulator link's sensor messages besides HIL_SENSOR: HIL_GPS of a fix and BATTERY_STATUS of the pack.

Units at the MAVLink edge as [MAV] common.xml has them: degE7, mm, cm, cm/s (NED), course in cdeg; cell voltages
in mV, current in cA, consumed mAh, percent left.  The messages are built, not packed (the link packs them with
its own sequence numbers).
"""

from __future__ import annotations

import math

from pymavlink.dialects.v20 import common as mavlink

from sitl.battery import Battery, cell_ocv_v
from sitl.gps import GpsReading, course_over_ground_deg


def hil_gps_message(time_us: int, fix: GpsReading) -> mavlink.MAVLink_hil_gps_message:
    """HIL_GPS for a fix, stamped ``time_us``."""
    v = fix.vel_ned_m_s
    return mavlink.MAVLink_hil_gps_message(
        time_us,
        fix.fix_type,
        round(fix.lat_deg * 1e7),
        round(fix.lon_deg * 1e7),
        round(fix.alt_amsl_m * 1000),
        round(fix.eph_m * 100),
        round(fix.epv_m * 100),
        round(math.hypot(v[0], v[1]) * 100),
        round(v[0] * 100),
        round(v[1] * 100),
        round(v[2] * 100),
        round(course_over_ground_deg(v) * 100) % 36000,
        fix.satellites,
        0,
        0,
    )


def battery_status_message(b: Battery, empty: bool) -> mavlink.MAVLink_battery_status_message:
    """BATTERY_STATUS of the simulated pack; ``empty``: the monitor reads an empty pack (PX4's battery failure)."""
    cell_v, remaining = b.voltage_v / b.cells, b.remaining_frac
    if empty:
        cell_v, remaining = cell_ocv_v(0.0), 0.0
    cells = [min(65534, round(cell_v * 1000))] * b.cells + [65535] * (10 - b.cells)
    return mavlink.MAVLink_battery_status_message(
        0,
        mavlink.MAV_BATTERY_FUNCTION_ALL,
        mavlink.MAV_BATTERY_TYPE_LIPO,
        32767,
        cells,
        round(b.current_a * 100),
        round(b.consumed_mah),
        -1,
        round(remaining * 100),
    )
