"""MAV_CMD_DO_AUTOTUNE_ENABLE (212): a row of the command table, routed to :mod:`autopilot.tuning.autotune`.

param1 (MAVLink: 1 enable, 0 disable; 2 is this flight controller's "accept the proposal"): 1 starts a run
or, while one runs or a proposal waits, polls its progress (COMMAND_ACK IN_PROGRESS with ``progress`` in
per cent, as PX4 answers QGroundControl's once-a-second repeat); 0 aborts a run or rejects a waiting
proposal; 2 applies the waiting proposal.  param2 (PX4: axes, must be 0) and the rest are ignored: the
axes are MC_AT_AXES.  The commander carries the vehicle's :class:`~autopilot.tuning.autotune.Autotune` as
``autotune`` (the flight controller sets it); without one the command is unsupported.
"""

from __future__ import annotations

from typing import Any

from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink import command_fields as f


def handle_autotune(cmd: Any, p: tuple[float, ...]) -> int:
    """The MAV_RESULT of DO_AUTOTUNE_ENABLE on the commander ``cmd`` (a bad param1: FieldError, DENIED)."""
    action = f.choice(p[0], "param1 (0 abort/reject, 1 start/poll, 2 accept)", (0, 1, 2))
    tune = getattr(cmd, "autotune", None)
    if tune is None:
        return mavlink.MAV_RESULT_UNSUPPORTED
    reply = tune.command(action, cmd.mode, cmd.armed, cmd.in_air, cmd.now_us)
    return getattr(mavlink, "MAV_RESULT_" + reply.value)


def autotune_progress(vehicle: Any) -> int:
    """The ``progress`` (per cent) of a DO_AUTOTUNE_ENABLE COMMAND_ACK for a flight controller's vehicle."""
    tune = getattr(getattr(getattr(vehicle, "fc", None), "commander", None), "autotune", None)
    return 0 if tune is None else int(tune.progress)
