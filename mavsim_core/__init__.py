"""The shared core of the mavsim-flight stack: what the simulator, the flight controller and
the ground station all need, and nothing of any one of them.

Rotations and the one ENU/FLU <-> NED/FRD conversion point (``quaternion``, ``frames``),
geodesy, physical constants, PX4's mode numbers, MAVLink parameter encoding, the MAVLink
UDP endpoint, the simulator-API framing (HIL_SENSOR / HIL_ACTUATOR_CONTROLS) and its
low-latency receive, STATUSTEXT chunking, and the log formats and their file names.  Two tuning modules stay
here because two rooms use each: ``loop_design`` (the rate loop's design and margins: the vehicle's autotune in
``autopilot.tuning`` and ``design-gains`` in ``sitl.gain_design``) and ``autotune_report`` (the autotune's
STATUSTEXT line: written by the flight controller, read by ``gcs autotune``).  The outer loops' design and step
simulation, used by ``design-gains`` alone, live beside it in ``sitl`` (``cascade_design``, ``cascade_sim``).

It imports NumPy and pymavlink, never ``autopilot``, ``sitl``, ``gcs`` or MuJoCo
(checked by the import contracts in ``pyproject.toml``).
"""
