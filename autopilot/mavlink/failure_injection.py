"""MAV_CMD_INJECT_FAILURE as PX4 has it: the simulated vehicle's sensors and motors fail on command.

PX4's SITL fails a sensor in its simulator when a ground station or MAVSDK's Failure plugin sends
MAV_CMD_INJECT_FAILURE (param1 FAILURE_UNIT, param2 FAILURE_TYPE, param3 instance, 0 = all).  Here:

* ``SYS_FAILURE_EN`` (PX4's parameter, default 0) gates it: disabled, the command is DENIED and a
  STATUSTEXT says why (MAVSDK reads the parameter and refuses by itself: set it with its Param plugin);
* :func:`autopilot.mavlink.failure_table.resolve` names the ``SIM_*`` values that produce the fault, or
  refuses it (UNSUPPORTED for what the simulator cannot produce, DENIED for an instance the vehicle
  does not have), with a STATUSTEXT;
* :class:`SimParamBridge` sets them in the simulator: PARAM_SET to the simulator component (compid 51)
  over the lockstep TCP link the flight controller already has (``autopilot/mavlink/sim_link.py``,
  answered between two steps by ``sitl/link_params.py``), each answered with the PARAM_VALUE in force.
  The command is ACCEPTED only when the simulator confirmed every value, FAILED when it did not answer
  within ``ANSWER_TIMEOUT_S`` (wall clock) or refused one.

A fault replaces the unit's previous one; FAILURE_TYPE_OK clears it: the unit's fault flags back to
healthy and the settings the fault changed (SIM_GPS_HZ, SIM_ENGINE_MUL...) back to the values they had
before, which the service read from the simulator first.  The rest of the flight controller is told
nothing: the estimator and the commander find out from the sensors, as on a real vehicle.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Callable

from pymavlink.dialects.v20 import common as mavlink

from autopilot.mavlink.failure_table import OK, Fault, Refusal, resolve
from autopilot.parameters import ParamDef, ParameterStore, ParamType, param

if TYPE_CHECKING:
    from autopilot.mavlink.endpoint import LinkEndpoint
    from autopilot.mavlink.link_service import Handler, ServiceCommand
    from autopilot.mavlink.sim_link import SimLink

# The parameters this module reads (listed in autopilot/param_catalogue.py).
PARAMS: tuple[ParamDef, ...] = (
    param(
        "SYS_FAILURE_EN", 0, 0, 1, "",
        "Failure injection: 1 accepts MAV_CMD_INJECT_FAILURE, which fails simulated sensors and motors "
        "(it can easily cause a crash); 0 denies it",
        ParamType.INT32,
    ),
)  # fmt: skip

ANSWER_TIMEOUT_S = 1.0  # wall clock: the simulator answers within its current step
SIM_COMPID = 51  # the simulator component (sitl/param_server.py)
Say = Callable[[int, str], None]  # (MAV_SEVERITY, text): a STATUSTEXT to the ground stations


class SimParamBridge:
    """The simulator's ``SIM_*`` parameters, read and set over the lockstep link (C-cast values, as the
    simulator component encodes them).  ``None`` from :meth:`get` or :meth:`set`: no answer in time."""

    def __init__(self, sim: SimLink, timeout_s: float = ANSWER_TIMEOUT_S) -> None:
        self.sim = sim
        self.timeout_s = timeout_s

    def _ask(self, msg: mavlink.MAVLink_message, name: str) -> float | None:
        def answer(m: mavlink.MAVLink_message) -> bool:
            return m.get_type() == "PARAM_VALUE" and m.param_id == name

        got = self.sim.request(msg, answer, self.timeout_s)
        return None if got is None else float(got.param_value)

    def get(self, name: str) -> float | None:
        """The value in force."""
        msg = mavlink.MAVLink_param_request_read_message(self.sim.sysid, SIM_COMPID, name.encode("ascii"), -1)
        return self._ask(msg, name)

    def set(self, name: str, value: float) -> float | None:
        """Set ``name``; the value in force afterwards (the old one if the simulator refused)."""
        msg = mavlink.MAVLink_param_set_message(
            self.sim.sysid, SIM_COMPID, name.encode("ascii"), float(value), mavlink.MAV_PARAM_TYPE_REAL32
        )
        return self._ask(msg, name)


def _same(a: float, b: float) -> bool:
    """Equal as a float32 parameter value carries them."""
    return abs(a - b) <= 1e-6 * max(1.0, abs(b))


class FailureInjection:
    """The MAV_CMD_INJECT_FAILURE service (see the module docstring); ``n_motors`` of the vehicle."""

    def __init__(self, params: ParameterStore, sim_params: SimParamBridge, n_motors: int, say: Say) -> None:
        self.params = params
        self.sim_params = sim_params
        self.n_motors = n_motors
        self.say = say
        self.saved: dict[int, dict[str, float]] = {}  # unit -> settings its fault changed: their earlier values

    def handlers(self) -> dict[str, Handler]:
        return {}

    def commands(self) -> dict[int, ServiceCommand]:
        return {mavlink.MAV_CMD_INJECT_FAILURE: self._command}

    def update(self, now_us: int) -> None:
        pass

    def _command(self, ep: LinkEndpoint, params: tuple, frame: int) -> int:
        if int(self.params.get("SYS_FAILURE_EN")) != 1:
            self.say(mavlink.MAV_SEVERITY_WARNING, "Failure injection disabled: set SYS_FAILURE_EN to 1")
            return mavlink.MAV_RESULT_DENIED
        fault = resolve(params[0], params[1], params[2], self.n_motors)
        if isinstance(fault, Refusal):
            self.say(mavlink.MAV_SEVERITY_WARNING, f"Failure injection: {fault.reason}")
            return fault.result
        return self.inject(fault)

    def inject(self, fault: Fault) -> int:
        """Set ``fault`` in the simulator (clearing the unit's previous one); the MAV_RESULT."""
        old = self.saved.pop(fault.unit, {})
        keep: dict[str, float] = {}
        for name in fault.settings:  # the settings' values before any fault of this unit
            before = old[name] if name in old else self.sim_params.get(name)
            if before is None:
                self.saved[fault.unit] = old
                return self._failed(fault, f"no answer from the simulator for {name}")
            keep[name] = before
        sets = {**old, **fault.flags, **fault.values}
        for name, value in sets.items():
            got = self.sim_params.set(name, value)
            if got is None or not _same(got, value):
                self.saved[fault.unit] = {**keep, **old}  # OK restores every earlier value known
                why = "no answer from the simulator" if got is None else f"the simulator kept {got:g}"
                return self._failed(fault, f"{name} = {value:g}: {why}")
        if keep:
            self.saved[fault.unit] = keep
        self.say(mavlink.MAV_SEVERITY_INFO, f"Failure {'cleared' if fault.ftype == OK else 'injected'}: {fault.label}")
        return mavlink.MAV_RESULT_ACCEPTED

    def _failed(self, fault: Fault, why: str) -> int:
        self.say(mavlink.MAV_SEVERITY_WARNING, f"Failure injection ({fault.label}) failed: {why}")
        return mavlink.MAV_RESULT_FAILED
