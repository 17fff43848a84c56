"""In-flight autotune of the body-rate loop (MAV_CMD_DO_AUTOTUNE_ENABLE), as PX4's mc_autotune_attitude_control.

Pure modules (no socket, no clock, no MAVLink I/O): :mod:`.excitation` makes the bounded signal added to
the rate setpoint (no more than :mod:`.authority` says an axis can follow), :mod:`.identify` fits the rate
plant to the logged (alpha_sp, rate) samples, :mod:`.proposal` designs gains and margins from it,
:mod:`.autotune` is the state machine the flight controller steps and the commander commands.
"""
