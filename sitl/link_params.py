"""The ``SIM_*`` parameters on the lockstep link: PARAM_SET and PARAM_REQUEST_READ from the flight controller.

The flight controller's failure injection (MAV_CMD_INJECT_FAILURE, ``autopilot/mavlink/failure_injection.py``)
changes the simulator's fault parameters through the TCP link it already has with the simulator, as
PX4's SITL asks its simulator to fail a sensor.  :class:`sitl.lockstep.LockstepServer` hands every
message from that link other than HIL_ACTUATOR_CONTROLS to :meth:`LinkParams.handle` while it waits
for the actuator controls, i.e. between two physics steps, and sends the answer at once: a change acts
on the next step, and the lockstep's timing is unchanged.

The protocol is the parameter protocol of the simulator's UDP component (:mod:`sitl.param_server`):
messages addressed to the simulator component (compid 51 of the vehicle's system, or broadcast), the
C-cast encoding (an INT32 3 is the float 3.0); a PARAM_SET or a PARAM_REQUEST_READ by name or index
is answered with the PARAM_VALUE in force (after a set: the new value, or the old one if refused).
An unknown name gets no answer (nothing to name in a PARAM_VALUE): the asker times out.
"""

from __future__ import annotations

from typing import Callable

from pymavlink.dialects.v20 import common as mavlink

from sitl.param_server import SIM_COMPID, param_value_message
from sitl.sim_params import SimParamError, SimParameters

OnChange = Callable[[str, "int | float"], None]  # (name, new value): a set that changed a value
OnRefused = Callable[[str], None]  # the reason a set was refused


class LinkParams:
    """Answers the flight controller's parameter requests on the lockstep link (see the module docstring)."""

    def __init__(
        self,
        params: SimParameters,
        sysid: int,
        compid: int = SIM_COMPID,
        on_change: OnChange | None = None,
        on_refused: OnRefused | None = None,
    ) -> None:
        self.params = params
        self.sysid, self.compid = sysid, compid
        self.on_change = on_change
        self.on_refused = on_refused

    def handle(self, msg: mavlink.MAVLink_message) -> list[mavlink.MAVLink_message]:
        """The answers to one message (empty: not a request for us)."""
        kind = msg.get_type()
        if kind not in ("PARAM_SET", "PARAM_REQUEST_READ"):
            return []
        if msg.target_system not in (0, self.sysid) or msg.target_component not in (0, self.compid):
            return []
        try:
            if kind == "PARAM_SET":
                return [self._set(msg.param_id, float(msg.param_value))]
            index = msg.param_index
            p = self.params.param(msg.param_id) if index < 0 else self.params.at(index)
        except SimParamError as e:
            if self.on_refused is not None:
                self.on_refused(str(e))
            return []
        return [param_value_message(self.params, p)]

    def _set(self, name: str, value: float) -> mavlink.MAVLink_message:
        p = self.params.param(name)  # SimParamError for an unknown name: no answer
        before = self.params.get(name)
        try:
            now = self.params.set(name, value)  # C-cast: the float is the value
        except SimParamError as e:
            if self.on_refused is not None:
                self.on_refused(str(e))
        else:
            if now != before and self.on_change is not None:
                self.on_change(name, now)
        return param_value_message(self.params, p)
