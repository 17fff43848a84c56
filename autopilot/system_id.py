"""The vehicle's MAVLink system id as a parameter, ``MAV_SYS_ID``, as PX4 keeps it.

PX4 SITL instance N starts with MAV_SYS_ID 1+N (its start script sets it); a new value is stored and
reported at once but used from the next start on (PX4: "reboot required").  Here the same:

- :func:`set_instance_default`: MAV_SYS_ID's default is 1+N for instance N (before the saved state is read,
  so a saved value overrides it and only a changed value is saved);
- :func:`system_id_at_start`: the id this start runs with: ``--sysid`` when given (and MAV_SYS_ID then takes
  it, as PX4's start script sets it: saved with ``--state-dir`` like any set value), else MAV_SYS_ID (1+N, or
  the value an earlier run saved in ``--state-dir``).  Without ``--state-dir`` nothing is saved: every start
  is 1+N again.  PREFLIGHT_REBOOT_SHUTDOWN's in-place restart keeps the link running: a new id needs a new
  start of the process.
"""

from __future__ import annotations

from autopilot.parameters import ParamDef, ParameterStore, param
from mavsim_core import ports
from mavsim_core.param_types import ParamType

PARAMS: tuple[ParamDef, ...] = (
    param(
        "MAV_SYS_ID", 1, 1, 250, "",
        "MAVLink system id of this vehicle (default 1+N for instance N, as PX4 SITL; a new value is kept with "
        "--state-dir; --sysid overrides it)",
        ParamType.INT32, reboot_required=True,
    ),
)  # fmt: skip


def set_instance_default(params: ParameterStore, instance: int) -> None:
    """MAV_SYS_ID's default (and value) for ``instance``: 1+N."""
    params.set_defaults({"MAV_SYS_ID": ports.system_id(instance)})


def system_id_at_start(params: ParameterStore, given: int | None) -> tuple[int, str | None]:
    """(the system id to run with, a note for the log or None): ``given`` (``--sysid``) wins and becomes
    MAV_SYS_ID's value when within its range; else MAV_SYS_ID."""
    if given is None:
        return int(params.get("MAV_SYS_ID")), None
    d = params.definition("MAV_SYS_ID")
    if not d.min <= given <= d.max:
        return given, f"--sysid {given} is outside MAV_SYS_ID's range {d.min:g}-{d.max:g}: MAV_SYS_ID not set"
    params.set("MAV_SYS_ID", given)
    return given, None
