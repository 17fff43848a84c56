"""PLACEHOLDER (being written): offboard setpoint messages."""


def offboard_setpoint(msg, now_us, wall_s, est):
    return None
