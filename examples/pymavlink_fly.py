"""Fly with pymavlink: wait until ready, arm, take off (to MIS_TAKEOFF_ALT), land. Argument: the link."""

import math
import sys

from pymavlink import mavutil

mav = mavutil.mavlink
link = mavutil.mavlink_connection(sys.argv[1] if len(sys.argv) > 1 else "udpin:0.0.0.0:14550", source_system=255)
link.wait_heartbeat(timeout=30)  # the first vehicle heard becomes link.target_system
print(f"heartbeat from system {link.target_system}", flush=True)


def command(cmd: int, *params: float) -> None:
    """COMMAND_LONG to the autopilot (parameters not given: NaN, unused); exit unless it is accepted."""
    link.mav.command_long_send(link.target_system, 1, cmd, 0, *params, *[math.nan] * (7 - len(params)))
    ack = link.recv_match(type="COMMAND_ACK", condition=f"COMMAND_ACK.command=={cmd}", blocking=True, timeout=10)
    if ack is None or ack.result != mav.MAV_RESULT_ACCEPTED:
        sys.exit(f"command {cmd} not accepted: {ack}")


def wait_for(mtype: str, check):
    """The first ``mtype`` message from the vehicle for which ``check(msg)`` is true."""
    while True:
        msg = link.recv_match(type=mtype, blocking=True)
        if msg.get_srcSystem() == link.target_system and check(msg):
            return msg


wait_for("SYS_STATUS", lambda m: m.onboard_control_sensors_health & mav.MAV_SYS_STATUS_PREARM_CHECK)  # ready
command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1)
command(mav.MAV_CMD_NAV_TAKEOFF)  # altitude NaN: MIS_TAKEOFF_ALT above home
wait_for("HEARTBEAT", lambda m: m.custom_mode == 4 << 16 | 3 << 24)  # AUTO.LOITER: the take-off is over
alt_m = wait_for("GLOBAL_POSITION_INT", lambda m: True).relative_alt / 1000
print(f"hovering at {alt_m:.2f} m above home; landing", flush=True)
command(mav.MAV_CMD_NAV_LAND)
wait_for("HEARTBEAT", lambda m: not m.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED)
print("landed and disarmed", flush=True)
