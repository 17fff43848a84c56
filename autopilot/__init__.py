"""The flight-controller process: estimation, control, mixing, modes, MAVLink."""
